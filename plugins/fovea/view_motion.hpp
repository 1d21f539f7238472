#pragma once
// How far the image has moved since a reference frame: a hand-held camera's
// turn or a head's, seen in the frames themselves. Each frame is reduced to
// a coarse view of the whole of it (cell means, kCells along its longer
// side, as a retina's outer level sees it), windowed, put on a kCells x
// kCells canvas of zeros and phase-correlated, by the box tracker's own
// transform, with the view of a keyframe: the reference frame's while the
// move stays under an eighth of the view, then a newer one, its move added,
// so that a long pan is followed while a still camera's noise is not summed
// frame by frame. A frame that no longer correlates with its keyframe (a
// cut, a turn too fast or too far to measure) ends the measurement until the
// next reset.
#include <opencv2/core.hpp>

#include "real_fft.hpp"

namespace saccade::fovea {

class ViewMotion {
 public:
  static constexpr int kCells = 64;  // the coarse view's longer side, cells
  // A correlation peak under this is no measurement. Cuts between fresh
  // sets 1-4's sequences peak at 0.07-0.15 (median 0.09), a cut to another
  // part of the same photograph at 0.10; those sets' hand-held cameras' frames
  // against their keyframes at 0.11-0.98 (median 0.38, 0.4% under this),
  // vtest.avi's still camera's at 0.32-0.95 (docs/tracking.md; test
  // ViewMotionOnRealPictures.ACutPeaksUnderTheBarAndAMovingCamerasFramesOverIt).
  static constexpr double kMinPeak = 0.15;
  // Frames may go unmeasured between measurements (measure() need not see
  // every frame), at most this many in a row: a pan of up to two cells a
  // frame then moves under a keyframe's eighth of the view between two
  // measurements, well within what a measurement sees (test
  // ViewMotion.FollowsAPanMeasuredOnlyEveryFewFrames). A faster one may no
  // longer correlate, and is then lost as a cut is.
  static constexpr int kMaxGap = 4;

  // Forgets the reference: the next frame measured becomes it.
  void reset();
  // Measures `frame` (8-bit, gray or BGR; the reference's size) against the
  // keyframe; the first frame since reset() becomes the reference.
  void measure(const cv::Mat& frame);
  // A reference taken (since reset()).
  bool started() const { return has_reference_; }
  // A reference taken and every frame measured since correlated with its keyframe.
  bool measuring() const { return has_reference_ && !lost_; }
  // The frame no longer correlated with its keyframe (or changed size).
  bool lost() const { return lost_; }
  // The image content's move from the reference frame to the last frame
  // measured, source pixels (0 unless measuring()).
  cv::Point2d shift() const { return measuring() ? shift_ : cv::Point2d(); }
  // The last measurement's correlation peak (1: the same view shifted).
  double peak() const { return peak_; }

 private:
  void view(const cv::Mat& frame, HalfSpectrum& spectrum);
  bool has_reference_ = false;
  bool lost_ = false;
  cv::Size frame_size_;
  cv::Point2d keyframe_shift_;  // the keyframe's move from the reference
  cv::Point2d shift_;
  double peak_ = 0;
  cv::Size grid_;     // the view's cells
  cv::Point2d cell_;  // a cell's size, source pixels
  RealFft2d fft_{kCells};
  cv::Mat cells_, window_, canvas_, response_;
  HalfSpectrum keyframe_, now_, cross_;
};

}  // namespace saccade::fovea
