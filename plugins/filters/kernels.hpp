#pragma once
// The retina's filter bank: plain functions over small 8-bit images, a fused
// fast path and a scalar reference the tests compare it with (borders included).
//
// Masks (correlation, as cv::filter2D applies them):
//   gauss      1-2-1 x 1-2-1 / 16
//   sobel_x    [-1 0 1; -2 0 2; -1 0 1]         sobel_y its transpose
//   grad_mag   sqrt(sobel_x^2 + sobel_y^2)      grad_mask  255 where grad_mag > threshold
//   grad_dir   atan2(sobel_y, sobel_x), radians in (-pi, pi]
//   laplacian  [0 1 0; 1 -4 1; 0 1 0]           log  laplacian of gauss
//   ggrad_x/y  derivative of a sampled Gaussian (sigma) along x/y, Gaussian across;
//              ggrad_mag, ggrad_mask as above with their own threshold
// Every map is CV_32F but the masks (CV_8U, 0/255).
#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace saccade::filters {

enum class Border { kReflect101, kReplicate };
int to_cv_border(Border border);

enum Feature : int {
  kGauss,
  kSobelX,
  kSobelY,
  kGradMag,
  kGradMask,
  kGradDir,
  kLaplacian,
  kLoG,
  kGGradX,
  kGGradY,
  kGGradMag,
  kGGradMask,
  kFeatureCount
};
extern const std::array<const char*, kFeatureCount> kFeatureNames;
int feature_index(const std::string& name);  // -1 when unknown

struct BankConfig {
  std::array<bool, kFeatureCount> wanted{};
  float grad_threshold = 100.0f;
  float ggrad_sigma = 1.0f;
  float ggrad_threshold = 10.0f;
  Border border = Border::kReflect101;
};

cv::Mat gaussian3_kernel();
cv::Mat sobel_x_kernel();
cv::Mat sobel_y_kernel();
cv::Mat laplacian4_kernel();
// 1-D kernels (row vectors) of radius ceil(3 sigma): a normalised Gaussian and its
// derivative, scaled so that a unit ramp gives exactly 1.
std::pair<cv::Mat, cv::Mat> gaussian_derivative_kernels(float sigma);
int gaussian_radius(float sigma);

float fast_atan2(float y, float x);

// Correlates an 8U or 32F single-channel image with a 32F kernel, one pixel at a
// time, resolving the border by index arithmetic. Returns CV_32F.
cv::Mat correlate_reference(const cv::Mat& src, const cv::Mat& kernel, Border border);

// Every wanted feature by the reference path; outs[f] is left empty when not wanted.
void bank_reference(const cv::Mat& level, const BankConfig& config, std::array<cv::Mat, kFeatureCount>& outs);

// The Gaussian gradient (the bank's ggrad_x/y kernels) of a single-channel
// float image, as a separable pair of passes; buffers persist between calls.
class GaussianGradient {
 public:
  GaussianGradient(float sigma, Border border);
  int radius() const { return radius_; }
  // `src` CV_32FC1 (or CV_8UC1); gx, gy CV_32F of the same size.
  void run(const cv::Mat& src, cv::Mat& gx, cv::Mat& gy);
  // On an image already padded by `pad` >= radius() on every side (w x h inside).
  void run_padded(const cv::Mat& padded, int pad, int w, int h, cv::Mat& gx, cv::Mat& gy);

 private:
  Border border_;
  int radius_ = 1;
  std::vector<float> g_, dg_;
  std::vector<int> map_x_;
  std::vector<const float*> rows_g_, rows_dg_;
  cv::Mat padded_, row_g_, row_dg_;
};

// The fused fast path: one pass for the 3x3 masks and what derives from them, one
// for the LoG, one separable pair for the Gaussian gradient. Scratch buffers are
// kept between calls, so steady state allocates nothing.
class FilterBank {
 public:
  explicit FilterBank(BankConfig config);
  // `level` 8-bit single channel; outs[f] is written for every wanted feature.
  void run(const cv::Mat& level, std::array<cv::Mat, kFeatureCount>& outs);
  const BankConfig& config() const { return config_; }

 private:
  BankConfig config_;
  GaussianGradient ggrad_;
  cv::Mat padded_f_, gauss_padded_;
  std::vector<int> map_x_;
  std::array<cv::Mat, kFeatureCount> scratch_;
};

}  // namespace saccade::filters
