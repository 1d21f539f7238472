#pragma once
// Motion on the retina: per level, the frame difference dI = I(t) - I(t-1), its
// smoothed derivatives Mx, My (Gaussian first derivatives of dI), a thresholded
// mask, and the level's motion energy and centroid.
//
// When the fovea moved between t-1 and t the levels' regions moved too; then
// the previous frame is sampled again on the current geometry, so both images
// of a level see exactly the same part of the scene and a fovea shift is not
// motion. Without the previous frame (a retina that carries no source), the
// previous level is resampled bilinearly instead and only the pixels both
// levels saw are compared.
#include <vector>

#include <opencv2/core.hpp>

#include "kernels.hpp"
#include "saccade/message.hpp"

namespace saccade::motion {

struct MotionConfig {
  float threshold = 15.0f;  // |dI| above this is motion
  float sigma = 1.0f;       // of the Gaussian derivatives
  filters::Border border = filters::Border::kReflect101;
};

struct LevelMotion {
  cv::Mat diff;                  // CV_32F, I(t) - I(t-1)
  cv::Mat mx;                    // CV_32F
  cv::Mat my;                    // CV_32F
  cv::Mat mask;                  // CV_8U, 255 where |dI| > threshold and both frames saw the pixel
  cv::Mat valid;                 // CV_8U, 255 where both frames saw the pixel
  double energy = 0;             // mean of dI^2 over valid pixels
  double moving = 0;             // fraction of valid pixels in the mask
  cv::Point2d centroid{-1, -1};  // of the mask, in level pixels
};

// The plain per-level computation, tested directly. `prev` must show the same
// region as `cur` (same geometry); `valid` may be empty (all valid).
class LevelMotionEstimator {
 public:
  explicit LevelMotionEstimator(MotionConfig config);
  void run(const cv::Mat& cur, const cv::Mat& prev, const cv::Mat& valid, LevelMotion& out);
  const MotionConfig& config() const { return config_; }

 private:
  MotionConfig config_;
  filters::GaussianGradient gradient_;
};

// Resamples level `prev` (geometry `prev_geometry`) onto `geometry` bilinearly;
// `valid` marks the pixels that fell inside the previous level.
void resample_level(const cv::Mat& prev, const LevelGeometry& prev_geometry, const LevelGeometry& geometry,
                    cv::Mat& out, cv::Mat& valid);

}  // namespace saccade::motion
