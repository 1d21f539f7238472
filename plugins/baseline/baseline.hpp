#pragma once
// The paper's "original" column: the same features computed by OpenCV at full
// resolution, so a graph can run them side by side with the retina.
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "saccade/status.hpp"

namespace saccade::baseline {

// Full-frame feature names, a subset of the filter bank's with the same meaning.
const std::vector<std::string>& full_frame_features();

// Computes `feature` on an 8-bit gray frame with OpenCV (reflect-101 borders)
// into `out` (buffers reused); an error naming a feature that is not one of
// full_frame_features().
Status compute_feature(const std::string& feature, const cv::Mat& gray, cv::Mat& out, cv::Mat& scratch);

enum class StereoAlgorithm { kBlockMatching, kSemiGlobal };

struct StereoConfig {
  StereoAlgorithm algorithm = StereoAlgorithm::kBlockMatching;
  int num_disparities = 128;  // multiple of 16
  int block_size = 5;         // odd
};

// Disparity in pixels (CV_32F, -1 where invalid) with OpenCV's StereoBM/SGBM.
// Left to right: for each left pixel, x_right = x_left - d. Right to left: for
// each right pixel, x_left = x_right + d (computed on mirrored images).
class FullFrameStereo {
 public:
  explicit FullFrameStereo(StereoConfig config);
  void left_to_right(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity);
  void right_to_left(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity);

 private:
  void match(const cv::Mat& a, const cv::Mat& b, cv::Mat& disparity);
  StereoConfig config_;
  cv::Ptr<cv::StereoMatcher> matcher_;
  cv::Mat fixed_, flip_a_, flip_b_, flipped_;
};

}  // namespace saccade::baseline
