#include "baseline.hpp"

#include <opencv2/imgproc.hpp>

namespace saccade::baseline {

const std::vector<std::string>& full_frame_features() {
  static const std::vector<std::string> names = {"gauss", "sobel_x", "sobel_y", "grad_mag", "laplacian", "log"};
  return names;
}

Status compute_feature(const std::string& feature, const cv::Mat& gray, cv::Mat& out, cv::Mat& scratch) {
  constexpr int kBorder = cv::BORDER_REFLECT_101;
  if (feature == "gauss") {
    cv::GaussianBlur(gray, scratch, {3, 3}, 0, 0, kBorder);
    scratch.convertTo(out, CV_32F);
  } else if (feature == "sobel_x") {
    cv::Sobel(gray, out, CV_32F, 1, 0, 3, 1, 0, kBorder);
  } else if (feature == "sobel_y") {
    cv::Sobel(gray, out, CV_32F, 0, 1, 3, 1, 0, kBorder);
  } else if (feature == "grad_mag") {
    cv::Sobel(gray, scratch, CV_32F, 1, 0, 3, 1, 0, kBorder);
    cv::Sobel(gray, out, CV_32F, 0, 1, 3, 1, 0, kBorder);
    cv::magnitude(scratch, out, out);
  } else if (feature == "laplacian") {
    cv::Laplacian(gray, out, CV_32F, 1, 1, 0, kBorder);
  } else if (feature == "log") {
    cv::GaussianBlur(gray, scratch, {3, 3}, 0, 0, kBorder);
    scratch.convertTo(scratch, CV_32F);
    cv::Laplacian(scratch, out, CV_32F, 1, 1, 0, kBorder);
  } else {
    return Status::error("unknown full-frame feature '" + feature + "'");
  }
  return {};
}

FullFrameStereo::FullFrameStereo(StereoConfig config) : config_(config) {
  if (config_.algorithm == StereoAlgorithm::kBlockMatching) {
    matcher_ = cv::StereoBM::create(config_.num_disparities, config_.block_size);
  } else {
    const int cn = 1, b = config_.block_size;
    matcher_ = cv::StereoSGBM::create(0, config_.num_disparities, b, 8 * cn * b * b, 32 * cn * b * b, 1, 0, 10, 100, 2,
                                      cv::StereoSGBM::MODE_SGBM_3WAY);
  }
}

void FullFrameStereo::match(const cv::Mat& a, const cv::Mat& b, cv::Mat& disparity) {
  matcher_->compute(a, b, fixed_);
  // Fixed point with 4 fractional bits; below the minimum disparity is invalid.
  fixed_.convertTo(disparity, CV_32F, 1.0 / 16.0);
  cv::Mat invalid = fixed_ < 0;
  disparity.setTo(-1.0f, invalid);
}

void FullFrameStereo::left_to_right(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity) {
  match(left, right, disparity);
}

void FullFrameStereo::right_to_left(const cv::Mat& left, const cv::Mat& right, cv::Mat& disparity) {
  // Mirrored, the right image becomes a left one: x_left = x_right + d turns into
  // the usual x' - d.
  cv::flip(right, flip_a_, 1);
  cv::flip(left, flip_b_, 1);
  match(flip_a_, flip_b_, flipped_);
  cv::flip(flipped_, disparity, 1);
}

}  // namespace saccade::baseline
