#include "color_histogram.hpp"

#include <algorithm>
#include <cstdint>

namespace saccade::fovea {

void chroma_histogram(const cv::Mat& frame, cv::Rect area, std::vector<float>& shares) {
  shares.assign(static_cast<std::size_t>(kChromaBins * kChromaBins), 0.f);
  if (frame.channels() < 3 || frame.depth() != CV_8U) return;
  const cv::Rect inside = area & cv::Rect(0, 0, frame.cols, frame.rows);
  const int channels = frame.channels();
  int counted = 0;
  for (int y = inside.y; y < inside.y + inside.height; ++y) {
    const uint8_t* pixel = frame.ptr<uint8_t>(y) + static_cast<std::ptrdiff_t>(inside.x) * channels;
    for (int x = 0; x < inside.width; ++x, pixel += channels) {
      const int sum = pixel[0] + pixel[1] + pixel[2];
      if (sum < kDarkestChroma) continue;
      const int r = std::min(kChromaBins - 1, pixel[2] * kChromaBins / sum);
      const int g = std::min(kChromaBins - 1, pixel[1] * kChromaBins / sum);
      shares[static_cast<std::size_t>(r * kChromaBins + g)] += 1.f;
      ++counted;
    }
  }
  if (counted == 0) return;
  for (float& share : shares) share /= static_cast<float>(counted);
}

double shared_colors(const std::vector<float>& a, const std::vector<float>& b) {
  double shared = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) shared += std::min(a[i], b[i]);
  return shared;
}

}  // namespace saccade::fovea
