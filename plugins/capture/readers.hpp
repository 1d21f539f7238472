#pragma once
// Frame readers behind the capture nodes: a video file, an image sequence, one
// image repeated, a camera device, and a synthetic scene with exact ground truth.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "saccade/status.hpp"

namespace saccade::capture {

class FrameReader {
 public:
  virtual ~FrameReader() = default;
  // Reads the next frame into `out` (reusing its buffer): ok, end_of_stream when
  // the source has no more frames, or the error naming the file or device.
  // `media_ns` gets the frame's media time (file position) or capture time.
  virtual Status read(cv::Mat& out, int64_t& media_ns) = 0;
  // Back to the first frame, for looping; false when the source cannot.
  virtual bool rewind() { return false; }
  // Frames per second the source declares (0 when unknown).
  virtual double fps() const { return 0.0; }
  // True for live sources whose media time is wall-clock time.
  virtual bool live() const { return false; }
  // Frames from the first to the end, as far as the source tells (a video's
  // header may be off by a few); 0 when unknown or endless.
  virtual int64_t length() const { return 0; }
  // Frames the source announced and could not give: a video cut short, or one
  // its decoder cannot read past some frame (the most on any pass); 0 while
  // every announced frame came.
  virtual int64_t frames_unread() const { return 0; }
};

// How many of the `announced` frames a source that gave `read` failed to
// give, beyond a header's usual error (2 frames or 1%): 0 within it.
int64_t frames_short_of(int64_t announced, int64_t read);

// What a path names: a printf pattern ("left%02d.jpg") is a sequence, a still
// image extension one image, a bare number or /dev/video* a camera, else a video.
enum class SourceKind { kVideo, kSequence, kImage, kCamera };
SourceKind classify_source(const std::string& path);

// Each returns the reader, or the error naming the path when it cannot open.
Result<std::unique_ptr<FrameReader>> open_video(const std::string& path);
// An image sequence's file pattern: the file of frame i is the pattern with its
// one %d (optionally %0Nd) replaced by i, as printf would, without printf.
// The largest image a reader decodes, in pixels (docs/reliability.md).
inline constexpr long long kMaxImagePixels = 64LL << 20;

class NumberedPattern {
 public:
  // The pattern, or the error naming it when it is not one %d.
  static Result<NumberedPattern> parse(const std::string& pattern);
  std::string name(int i) const;
  // The numbers of the files in the pattern's folder that it names, in
  // order (none when the number is in a folder's name, not the file's).
  std::vector<int> numbers_present() const;

 private:
  std::string prefix_, suffix_;
  int width_ = 0;
  bool zero_ = false;
};

Result<std::unique_ptr<FrameReader>> open_sequence(const std::string& pattern, int first, double fps);
Result<std::unique_ptr<FrameReader>> open_image(const std::string& path, int64_t count, double fps);
Result<std::unique_ptr<FrameReader>> open_camera(const std::string& device, cv::Size size, double fps);
Result<std::unique_ptr<FrameReader>> open_any(const std::string& path, double fps);

// A textured square moving over a real background on a known path; the right
// view sees the target shifted left by `disparity` and the background by
// `background_disparity` (pixels).
struct SyntheticScene {
  cv::Mat background;  // BGR
  int target_size = 48;
  std::string path = "circle";  // circle | line | still | bounce
  double radius = 120.0;        // circle radius or half the line's length, pixels
  double period_frames = 120.0;
  // bounce: a straight run at `speed` pixels per frame (direction `angle_deg`),
  // reflected at the frame's edges moved out by `overshoot` pixels, so the
  // target leaves the image when overshoot > 0.
  double speed = 4.0;
  double angle_deg = 30.0;
  double overshoot = 0.0;
  // Every `jump_every` frames (0: never) the target jumps to a new place chosen
  // from `seed`: a move no tracker can follow, to test re-acquisition.
  int jump_every = 0;
  int disparity = 0;
  int background_disparity = 0;
  uint64_t seed = 1;
};

class SyntheticRenderer {
 public:
  explicit SyntheticRenderer(SyntheticScene scene);
  // Centre of the rendered target in the left view at frame k (exact: the
  // rendered square's centre, after rounding its corner to whole pixels). It
  // may lie outside the frame (bounce with overshoot).
  cv::Point2d target_center(int64_t k) const;
  // Fraction of the target's area inside the frame at frame k (0..1).
  double target_visible(int64_t k) const;
  void render(int64_t k, cv::Mat& left, cv::Mat& right) const;
  const SyntheticScene& scene() const { return scene_; }

 private:
  cv::Point target_corner(int64_t k) const;
  SyntheticScene scene_;
  cv::Mat texture_;
  cv::Mat right_background_;
};

}  // namespace saccade::capture
