#include "color_histogram.hpp"

#include <algorithm>
#include <array>
#include <cstdint>

namespace saccade::fovea {
namespace {

// floor(n / sum) for n < 2^15 and sum <= 765 as (n * reciprocal[sum]) >> 25,
// exactly (the reciprocal's rounding error times n stays under 2^25): the
// histogram's two divisions per pixel were most of its cost.
constexpr int kReciprocalShift = 25;
struct Reciprocals {
  std::array<uint32_t, 766> of{};
  constexpr Reciprocals() {
    for (uint32_t s = 1; s < of.size(); ++s) of[s] = ((uint32_t{1} << kReciprocalShift) + s - 1) / s;
  }
};
constexpr Reciprocals kReciprocals;

int divided(int n, int sum) {
  return static_cast<int>((static_cast<uint64_t>(n) * kReciprocals.of[static_cast<std::size_t>(sum)]) >>
                          kReciprocalShift);
}

}  // namespace

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
      const int r = std::min(kChromaBins - 1, divided(pixel[2] * kChromaBins, sum));
      const int g = std::min(kChromaBins - 1, divided(pixel[1] * kChromaBins, sum));
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
