#include "stereo_truth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

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

}  // namespace saccade::bench
