#include "view_motion.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "frame_samples.hpp"
#include "saccade/fill.hpp"

namespace saccade::fovea {

namespace {

// The shift of the image whose half spectrum is `now` from the one whose
// half spectrum is `before`, by phase correlation: the whole image's
// motion, in its pixels, to a fraction of one; `peak`, the correlation's
// height (1: the one image shifted, near 0: unrelated).
cv::Point2d phase_shift(RealFft2d& fft, const HalfSpectrum& now, const HalfSpectrum& before, HalfSpectrum& cross,
                        cv::Mat& response, double& peak) {
  const std::size_t n = now.re.size();
  cross.re.resize(n);
  cross.im.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float re = now.re[i] * before.re[i] + now.im[i] * before.im[i];
    const float im = now.im[i] * before.re[i] - now.re[i] * before.im[i];
    const float scale = 1.0f / (std::sqrt(re * re + im * im) + 1e-6f);
    cross.re[i] = re * scale, cross.im[i] = im * scale;
  }
  fft.inverse(cross, response);
  cv::Point at;
  cv::minMaxLoc(response, nullptr, &peak, nullptr, &at);
  // To a fraction of a pixel: the centroid of the 3x3 pixels around the peak
  // (as cv::phaseCorrelate's), their values under 0 left out. A parabola
  // through the peak's neighbours leans towards whole pixels on this sharp a
  // peak: a pan measured 3.3 px off after 135 px, 0.7 px this way.
  const int w = response.cols, h = response.rows;
  const auto wrap = [](int i, int size) { return (i + size) % size; };
  double sum_x = 0, sum_y = 0, sum = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const double v = std::max(0.0f, response.at<float>(wrap(at.y + dy, h), wrap(at.x + dx, w)));
      sum_x += v * dx, sum_y += v * dy, sum += v;
    }
  const cv::Point2d whole(at.x > w / 2 ? at.x - w : at.x, at.y > h / 2 ? at.y - h : at.y);
  return sum > 0 ? whole + cv::Point2d(sum_x / sum, sum_y / sum) : whole;
}

}  // namespace

void ViewMotion::reset() {
  has_reference_ = lost_ = false;
  keyframe_shift_ = shift_ = {};
  peak_ = 0;
}

void ViewMotion::view(const cv::Mat& frame, HalfSpectrum& spectrum) {
  cells_.create(grid_, CV_32F);
  sample_cell_means(frame, {frame.cols / 2.0, frame.rows / 2.0}, cell_.x, cell_.y, grid_, cells_.ptr<float>());
  if (window_.size() != grid_) cv::createHanningWindow(window_, grid_, CV_32F);
  canvas_.create(kCells, kCells, CV_32F);
  fill(canvas_, 0);
  cv::multiply(cells_, window_, canvas_(cv::Rect(cv::Point(), grid_)));
  fft_.forward(canvas_, spectrum);
}

void ViewMotion::measure(const cv::Mat& frame) {
  if (lost_) return;
  if (!has_reference_) {
    frame_size_ = frame.size();
    const double side = static_cast<double>(std::max(frame.cols, frame.rows)) / kCells;
    grid_ = {std::clamp(static_cast<int>(std::lround(frame.cols / side)), 8, kCells),
             std::clamp(static_cast<int>(std::lround(frame.rows / side)), 8, kCells)};
    cell_ = {static_cast<double>(frame.cols) / grid_.width, static_cast<double>(frame.rows) / grid_.height};
    view(frame, keyframe_);
    has_reference_ = true;
    return;
  }
  if (frame.size() != frame_size_) {
    lost_ = true;
    return;
  }
  view(frame, now_);
  const cv::Point2d d = phase_shift(fft_, now_, keyframe_, cross_, response_, peak_);
  if (peak_ < kMinPeak) {
    lost_ = true;
    return;
  }
  shift_ = keyframe_shift_ + cv::Point2d(d.x * cell_.x, d.y * cell_.y);
  // An eighth of the view: the next frames' overlap with the keyframe, and
  // so their peaks, would shrink; this one becomes the keyframe.
  if (std::abs(d.x) >= grid_.width / 8.0 || std::abs(d.y) >= grid_.height / 8.0) {
    keyframe_shift_ = shift_;
    std::swap(keyframe_, now_);
  }
}

}  // namespace saccade::fovea
