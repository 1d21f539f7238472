#pragma once
// The multi-resolution retina (the paper's Algorithm 1).
//
// L levels of W x H pixels. Level L-1 (the fovea) is a direct crop of W x H
// around the fovea; level 0 covers the whole frame. Level k's region grows
// linearly between them: with t = k / (L-1), its size is lerp(frame, W x H, t)
// and its top-left corner lerp((0,0), fovea corner, t), so every level lies
// inside the frame and inside the levels outside it.
//
// Five-point mode: level pixel (i, j) sits at the centre of its cell,
// c = region.tl + floor((i + 0.5) * step); its value is the rounded mean of
// (cx, cy), (cx +- s_x, cy), (cx, cy +- s_y) with s = ceil(step / 3) (the paper's
// h/3 with h taken up to the next multiple of 3). A centre closer than s to the
// frame's edge is moved in by the difference, so every sample lies in the frame
// (only the outermost level's edge cells can be affected).
// Area-mean mode: the exact mean of the cell's pixels.
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::retina {

enum class SamplingMode { kFivePoint, kAreaMean };

struct RetinaConfig {
  int levels = 5;
  cv::Size size{32, 24};
  SamplingMode mode = SamplingMode::kFivePoint;
};

// Clamps the fovea centre so the fovea crop lies inside the frame; returns the
// crop's top-left corner.
cv::Point clamp_fovea_corner(const RetinaConfig& config, cv::Size frame, cv::Point2d fovea);

// Geometry of every level (index 0 outermost) for a fovea centre.
std::vector<LevelGeometry> retina_geometry(const RetinaConfig& config, cv::Size frame, cv::Point2d fovea);
// The same into `out`, reusing its storage.
void retina_geometry(const RetinaConfig& config, cv::Size frame, cv::Point2d fovea, std::vector<LevelGeometry>& out);

// Plain per-pixel implementation of the sampling rule above: the reference the
// fast sampler is tested against.
void sample_reference(const RetinaConfig& config, const cv::Mat& frame, const std::vector<LevelGeometry>& geometry,
                      std::vector<cv::Mat>& levels);

// One level, plainly: the five-point rule with a real-valued origin, pixel (i, j)
// centred at floor(x0 + (i + 0.5) * step_x), floor(y0 + (j + 0.5) * step_y) (moved in
// from the frame's edge as above), or with `crop` the frame's pixels from
// (floor(x0), floor(y0)). With an integer origin this is exactly the retina's own
// level: sample_reference is built on it, and stereo uses it to look at the right
// frame where the left level's scene is predicted to be.
void sample_level(const cv::Mat& frame, double x0, double y0, double step_x, double step_y, cv::Size size, bool crop,
                  cv::Mat& out);

// Fast sampler: per-level offset tables are rebuilt only when the frame size,
// type or fovea change; otherwise sampling allocates nothing.
class RetinaSampler {
 public:
  explicit RetinaSampler(RetinaConfig config);
  // Checks the frame against the configuration: ok when it fits, else why not.
  Status check(const cv::Mat& frame) const;
  // Samples `frame` (8-bit, 1 or 3 channels) into `levels` and fills `geometry`.
  void sample(const cv::Mat& frame, cv::Point2d fovea, std::vector<cv::Mat>& levels,
              std::vector<LevelGeometry>& geometry);
  // The same into a Retina message: levels, geometry, the source's size, the
  // fovea's centre as sampled (after clamping) and the sampling mode. The
  // caller attaches the source frame and the camera id.
  void sample(const cv::Mat& frame, cv::Point2d fovea, Retina& out);
  const RetinaConfig& config() const { return config_; }

 private:
  void prepare(const cv::Mat& frame, cv::Point corner);
  void sample_five_point(const cv::Mat& frame, std::vector<cv::Mat>& levels);

  struct LevelTable {
    std::vector<std::ptrdiff_t> col;  // byte offset of each cell centre in a row
    std::vector<std::ptrdiff_t> row;  // byte offset of each cell centre's row in the frame
    // The up and down samples as offsets from the centre: constant per level,
    // because cell centres are moved in from the frame's edge by the sub-step.
    std::ptrdiff_t up_bytes = 0, down_bytes = 0;
    std::ptrdiff_t sub_x_bytes = 0;
  };
  RetinaConfig config_;
  std::vector<LevelTable> tables_;
  std::vector<LevelGeometry> geometry_;
  std::vector<uint16_t> sums_;
  cv::Size prepared_size_;
  int prepared_type_ = -1;
  std::size_t prepared_pitch_ = 0;
  cv::Point prepared_corner_{-1, -1};
};

}  // namespace saccade::retina
