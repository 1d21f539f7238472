#pragma once
// A target given as a box, followed by a discriminative correlation filter
// built for the retina: the filter sees the target through a small patch
// sampled around it the way a retina level is (sample_level), at the step
// that makes the target span a fixed number of patch pixels, so the target's
// scale picks the sampling step as the retina's levels do, and the cost per
// frame does not grow with the target or the frame.
//
// Per frame: predict (constant velocity, minus the camera's own moves),
// sample patches at a few scales around the prediction, correlate, take the
// best peak; its peak-to-sidelobe ratio is the confidence. Confident frames
// update the model; unconfident ones do not (a model that learns the
// occluder locks on it). After `lost_frames` untrusted frames the target is
// lost: each frame, its coarse look (learnt alongside the filter) is matched
// over the whole frame seen at a coarse step, as a retina's outer level sees
// it, and the best places are checked by the filter until a confident peak
// holds at one place on consecutive frames (less confident near where the
// target was last tracked, if of its colour). A find elsewhere is taken only
// as far from where the target was last tracked as the image's move since
// (the camera's, measured over the whole frame: view_motion.hpp) and its own
// motion could take it, unless it peaks nearly as high as the target usually
// does; a target that left the frame, only as far in from the border it
// crossed.
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/status.hpp"

namespace saccade::fovea {

enum class TrackState { kTracking, kUncertain, kLost };
const char* to_string(TrackState state);

struct BoxTrackerConfig {
  int patch = 64;               // patch side, pixels (a power of two keeps the DFT fast)
  double padding = 2.0;         // patch side / the target's larger side (more for targets under patch / padding pixels)
  double learning_rate = 0.02;  // model <- (1 - a) model + a frame, on confident frames
  double lambda = 1e-3;         // regularisation of the filter
  double sigma = 0.1;           // the desired response's width, times the target's larger side
  double angle_step = 5;        // degrees: the target's turn searched either side (0: never) ...
  double turn_psr = 0.8;        // ... when the peak-to-sidelobe ratio falls below this share of its mean ...
  int turn_search_every = 4;    // ... and at least every this many frames, ...
  bool follow_turns = true;     // ... and on the frame after one that found a turn the way the last one
                                // was, at most turn_search_every searches before (false: not then)
  double scale_step = 1.02;     // ratio between the scale filter's neighbouring scales, at least ...
  double scale_step_pixels = 1;  // ... enough to change the given box's larger side by this many pixels (0: not asked)
  int scales = 17;               // scales the scale filter compares (odd)
  double scale_turn_min = 20;    // degrees: from this turn on, the scale filter sees the target turned as the patch
                                 // does (under it, upright; docs/tracking.md)
  double min_target = 8;         // smallest target side accepted, source pixels
  double tracking_psr = 6.0;     // peak-to-sidelobe ratio at or above which the target is tracked ...
  double relative_psr = 0.5;     // ... and at or above this share of its mean over tracked frames
                                 // (or under it, sure otherwise, on warmup_frames frames in a row:
                                 // the target changed, and the mean is made anew from them)
  int warmup_frames = 10;        // tracked frames that make that mean before it is used
  double rival_ratio = 0.7;      // a second peak above this share of the first: not sure (1: never)
  double min_chroma_change = 0.02;  // a tracked target's colour (chromaticity) may move this far ...
  double chroma_deviations = 4;     // ... or this many times its usual frame-to-frame deviation
  int color_patience = 60;          // frames away after which a target may come back another colour
  double min_shared_colors = 0.25;  // while its colour is checked, a re-detection (also a sure one) must
                                    // share this much of the target's chromaticity histogram: a look-alike
                                    // of another tint is refused, a target partly hidden is not (0: not
                                    // asked; docs/tracking.md)
  double min_shared_tones = 0.6;    // a re-detection (also a sure one) must share this much of the
                                    // target's histogram of gray relative to its mean gray: a monochrome
                                    // camera's only check of a find, and a second one in colour (0: not
                                    // asked; docs/tracking.md)
  double lost_psr = 5.0;            // below this the peak is not trusted at all
  int lost_frames = 5;              // consecutive frames below lost_psr before the target is lost
  int unsure_frames = 30;           // consecutive frames not tracked before the target is lost
  int redetect_after = 3;           // consecutive frames not tracked before the whole frame is searched too
  double redetect_psr = 9.0;        // a re-detection must reach this ...
  int redetect_frames = 2;          // ... on this many consecutive frames, at a consistent place
  double redetect_near = 2.0;       // within this many times its larger side of where it was last tracked ...
  double redetect_near_psr = 7.0;   // ... and of its colour, a re-detection need only reach this
  double near_shared_tones = 0.9;   // (a target without colours: sharing this much of its tones, 0: never;
                                    // in a monochrome camera's frames also asked before a lower peak
                                    // becomes its usual one, 0: not asked)
  double redetect_margin = 1.5;     // unsure, with a trusted peak where it sits: a re-detection elsewhere
                                    // must reach this many times that peak (0: not asked), or be nearer
                                    // the target's colour by min_chroma_change (a look-alike while the
                                    // target is partly hidden) ...
  int redetect_margin_frames = 10;  // ... for this many unsure frames (then the target is more likely gone),
                                    // or longer while that peak still reaches redetect_psr
  int proposals = 2;                // lost: places per size the whole-frame search proposes to the filter by look ...
  int color_proposals = 1;          // ... and by look and colour together (while lost, or unsure on a sure peak
                                    // of another colour: a look-alike; while its colour is checked; 0: none)
  double follow_lost_colors = 0.5;  // lost: the local look moves to a peak near where the target was lost that
                                    // shares this much of its colours (a target without colours:
                                    // min_shared_tones of its tones), and looks there at other sizes too
                                    // (0: it stays where the target was lost; docs/tracking.md)
  double max_size_change = 0.03;    // a re-detection's size may differ from the size the target was last
                                    // tracked at by this share per frame since (0: any of the sizes searched)
  int rescale_frames = 10;          // for this many frames from a re-detection elsewhere than where the
                                    // tracker sat (its own frame counted), unsure frames measure the target's
                                    // size too (a re-detection's size is the search's nearest, and a box of the
                                    // wrong size is doubted for its colour; 0 and 1: tracked frames only)
  int look_size_frames = 30;        // for this many frames from a re-detection elsewhere than where the tracker
                                    // sat, and from each size this gives, a tracked frame on which the scale
                                    // filter finds no size better than the others looks with the position's
                                    // filter at other sizes, and a peak higher there (reaching tracking_psr)
                                    // gives the target that size (0: never; docs/tracking.md)
  double flat_scale = 0.75;         // ... "no size better": the scale filter answers its middle scale and its
                                    // response two scales either side is this share of its top or more
  double look_size_step = 1.1;      // ... "other sizes": this many times the target's and 1 / that
  double reentry_speed = 0.05;      // a target whose centre left the frame comes back across that border: a
                                    // re-detection must lie within its size of it, plus how far the camera
                                    // turned back since, plus this many times its size per frame since (0: not
                                    // asked; docs/tracking.md)
  double reach_speed = 0.1;         // not tracked, a find elsewhere than where the tracker sits must lie within the
                                    // target's size of where it was last tracked (moved with the camera's measured
                                    // and told moves), plus this many times its size per frame since, unless it peaks
                                    // nearly as high as the target's tracked frames usually do (0: not asked;
                                    // docs/tracking.md)
  double resize_ratio = 1.25;       // unsure, a look near where the tracker sits at a larger size whose peak is this
                                    // many times the one at the target's size (and reaches redetect_psr, of its
                                    // colours and tones, a size it could have grown to) gives the target that
                                    // size and place: it came nearer (0: never; under 1 counts as 1;
                                    // docs/tracking.md)
  double velocity_gain = 0.5;       // weight of the newest velocity measurement
  bool balance_colors = true;       // colours read through the camera's white balance changes since the target
                                    // was given, undone (WhiteBalanceDrift): a white balance drifting, or the
                                    // light's colour changing, then moves no colour the tracker learnt
                                    // (docs/tracking.md)
};

struct TrackEstimate {
  cv::Rect2d box;         // the target, source pixels
  double confidence = 0;  // peak-to-sidelobe ratio of the best response
  TrackState state = TrackState::kLost;
};

class BoxTracker {
 public:
  explicit BoxTracker(BoxTrackerConfig config = {});
  // Learns the target inside `box` (source pixels) of `frame` (8-bit, gray or
  // BGR). An error says why not (a box outside the frame, too small, flat);
  // the tracker is then unchanged.
  Status init(const cv::Mat& frame, cv::Rect2d box);
  bool initialized() const { return initialized_; }
  // Follows the target into `frame`.
  TrackEstimate update(const cv::Mat& frame);
  // The camera (a head turn, the fovea's own move) shifted the image content
  // by `shift` source pixels since the last frame.
  void camera_moved(cv::Point2d shift) { camera_shift_ += shift; }
  const TrackEstimate& last() const { return last_; }
  const BoxTrackerConfig& config() const { return config_; }

 private:
  struct Impl;
  void follow(const cv::Mat& frame, cv::Point2d predicted);
  struct UnsurePlace;
  void redetect(const cv::Mat& frame, cv::Point2d predicted, bool unsure, const UnsurePlace& sits);
  // `sits_psr`: the peak where the unsure tracker sits, 0 when not trusted.
  void look_elsewhere(const cv::Mat& frame, double sits_psr);
  BoxTrackerConfig config_;
  bool initialized_ = false;
  TrackEstimate last_;
  cv::Point2d camera_shift_;
  std::shared_ptr<Impl> impl_;
};

}  // namespace saccade::fovea
