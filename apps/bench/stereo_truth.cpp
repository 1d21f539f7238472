#include "stereo_truth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace saccade::bench {
namespace {

// Right-image places are kept at an eighth of a pixel: finer than any truth
// these benchmarks carry (Middlebury's is whole pixels, the rendered scenes'
// sub-pixel but smooth).
constexpr int kBins = 8;

bool known(float d) { return std::isfinite(d) && d >= 0; }

class RowDepth {
 public:
  explicit RowDepth(int width) : nearest_(static_cast<std::size_t>((width + 2) * kBins)) {}

  void clear() { std::fill(nearest_.begin(), nearest_.end(), -std::numeric_limits<float>::infinity()); }

  // A surface from right-image place a (disparity da) to b (db), a <= b.
  void cover(double a, float da, double b, float db) {
    const int first = std::max(0, static_cast<int>(std::ceil(bin_of(a))));
    const int last = std::min(static_cast<int>(nearest_.size()) - 1, static_cast<int>(std::floor(bin_of(b))));
    for (int i = first; i <= last; ++i) {
      const double t = b > a ? (place_of(i) - a) / (b - a) : 0.0;
      float& n = nearest_[static_cast<std::size_t>(i)];
      n = std::max(n, static_cast<float>(da + t * (db - da)));
    }
  }

  float nearest_at(double place) const {
    const long i = std::lround(bin_of(place));
    if (i < 0 || i >= static_cast<long>(nearest_.size())) return -std::numeric_limits<float>::infinity();
    return nearest_[static_cast<std::size_t>(i)];
  }

 private:
  // Bin 0 is place -1: a footprint reaches half a pixel left of place 0.
  static double bin_of(double place) { return (place + 1.0) * kBins; }
  static double place_of(int bin) { return static_cast<double>(bin) / kBins - 1.0; }
  std::vector<float> nearest_;
};

}  // namespace

cv::Mat hidden_from_right_camera(const cv::Mat& truth) {
  CV_Assert(truth.type() == CV_32F);
  cv::Mat hidden(truth.size(), CV_8U, cv::Scalar(0));
  RowDepth depth(truth.cols);
  for (int y = 0; y < truth.rows; ++y) {
    const float* t = truth.ptr<float>(y);
    depth.clear();
    for (int x = 0; x < truth.cols; ++x) {
      if (!known(t[x])) continue;
      const double place = x - t[x];
      depth.cover(place - 0.5, t[x], place + 0.5, t[x]);
      if (x + 1 < truth.cols && known(t[x + 1]) && std::abs(t[x + 1] - t[x]) <= 1.0f) {
        depth.cover(place, t[x], x + 1 - t[x + 1], t[x + 1]);  // at most two pixels on, never behind
      }
    }
    uint8_t* out = hidden.ptr<uint8_t>(y);
    for (int x = 0; x < truth.cols; ++x) {
      if (!known(t[x])) continue;
      const double place = x - t[x];
      if (place < -0.5 || place > truth.cols - 0.5 || depth.nearest_at(place) > t[x] + 1.0f) out[x] = 255;
    }
  }
  return hidden;
}

BoardDisparity::BoardDisparity(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right,
                               cv::Size corners)
    : corners_(corners) {
  const auto n = static_cast<std::size_t>(corners.area());
  CV_Assert(corners.width >= 2 && corners.height >= 2 && left.size() == n && right.size() == n);
  std::vector<cv::Point2f> board;
  for (std::size_t i = 0; i < n; ++i) {
    disparity_.push_back(left[i].x - right[i].x);
    const double row = std::abs(left[i].y - right[i].y);
    row_error_max_ = std::max(row_error_max_, row);
    row_error_mean_ += row / static_cast<double>(n);
    board.emplace_back(static_cast<float>(i % static_cast<std::size_t>(corners.width)),
                       static_cast<float>(i / static_cast<std::size_t>(corners.width)));
  }
  to_image_ = cv::Matx33d(cv::findHomography(board, left));
  to_board_ = to_image_.inv();
}

double BoardDisparity::at(cv::Point2d p) const {
  const cv::Vec3d q = to_board_ * cv::Vec3d(p.x, p.y, 1);
  const double u = q[0] / q[2], v = q[1] / q[2];
  const int i = std::clamp(static_cast<int>(std::floor(u)), 0, corners_.width - 2);
  const int j = std::clamp(static_cast<int>(std::floor(v)), 0, corners_.height - 2);
  const double fu = u - i, fv = v - j;
  const auto d = [&](int col, int row) { return disparity_[static_cast<std::size_t>(row * corners_.width + col)]; };
  return (1 - fv) * ((1 - fu) * d(i, j) + fu * d(i + 1, j)) + fv * ((1 - fu) * d(i, j + 1) + fu * d(i + 1, j + 1));
}

cv::Point2d BoardDisparity::on_board(double u, double v) const {
  const cv::Vec3d q = to_image_ * cv::Vec3d(u, v, 1);
  return {q[0] / q[2], q[1] / q[2]};
}

cv::Mat BoardDisparity::truth(cv::Size size) const {
  const double last_u = corners_.width, last_v = corners_.height;
  std::vector<cv::Point> outline;
  for (const cv::Point2d c : {on_board(-1, -1), on_board(last_u, -1), on_board(last_u, last_v), on_board(-1, last_v)})
    outline.emplace_back(static_cast<int>(std::lround(c.x)), static_cast<int>(std::lround(c.y)));
  cv::Mat board = cv::Mat::zeros(size, CV_8U);
  cv::fillConvexPoly(board, outline, cv::Scalar(255));
  cv::Mat out(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      out.at<float>(y, x) =
          board.at<uint8_t>(y, x) ? static_cast<float>(at({static_cast<double>(x), static_cast<double>(y)})) : -1.0f;
  return out;
}

int disparities_over(const cv::Mat& truth) {
  double largest = 0;
  cv::minMaxLoc(truth, nullptr, &largest);
  return (static_cast<int>(std::ceil(largest)) / 16 + 1) * 16;
}

}  // namespace saccade::bench
