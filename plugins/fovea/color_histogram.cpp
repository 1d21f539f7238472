#include "color_histogram.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>

#include "saccade/fill.hpp"

namespace saccade::fovea {
namespace {

// floor(n / sum) for n < 2^14 and sum <= 1530 (three channels of up to 510,
// balanced by gains up to 2) as (n * reciprocal[sum]) >> 25, exactly (the
// reciprocal's rounding error times n stays under 2^25 / 2048, under 1 /
// sum): the histogram's two divisions per pixel were most of its cost.
constexpr int kReciprocalShift = 25;
constexpr int kMostBalancedSum = 3 * 510;
struct Reciprocals {
  std::array<uint32_t, kMostBalancedSum + 1> of{};
  constexpr Reciprocals() {
    for (uint32_t s = 1; s < of.size(); ++s) of[s] = ((uint32_t{1} << kReciprocalShift) + s - 1) / s;
  }
};
constexpr Reciprocals kReciprocals;

int divided(int n, int sum) {
  return static_cast<int>((static_cast<uint64_t>(n) * kReciprocals.of[static_cast<std::size_t>(sum)]) >>
                          kReciprocalShift);
}

// The gains (ChannelGains::q8) held to 128..512, so that three balanced
// channels stay within the reciprocals' 1530.
std::array<int, 3> held(const ChannelGains& gains) {
  return {std::clamp(gains.q8[0], 128, 512), std::clamp(gains.q8[1], 128, 512), std::clamp(gains.q8[2], 128, 512)};
}

// A channel's value times its held gain, rounded.
int balanced(int value, int q8) { return (value * q8 + 128) >> 8; }

// Calls visit(cell index, b, g, r) with each cell's channel sums over the
// four pixels at its quarter points, for a `cells` grid laid over an 8-bit
// frame of three or four channels: a cell's colour, as the readings of the
// whole frame take it.
template <typename Visit>
void for_each_cell_colour(const cv::Mat& frame, cv::Size cells, Visit visit) {
  const int channels = frame.channels();
  const double cell_w = static_cast<double>(frame.cols) / cells.width,
               cell_h = static_cast<double>(frame.rows) / cells.height;
  const auto at = [](double v, int size) { return std::clamp(static_cast<int>(v), 0, size - 1); };
  for (int cy = 0; cy < cells.height; ++cy) {
    const std::array<const uint8_t*, 2> rows{frame.ptr<uint8_t>(at((cy + 0.25) * cell_h, frame.rows)),
                                             frame.ptr<uint8_t>(at((cy + 0.75) * cell_h, frame.rows))};
    for (int cx = 0; cx < cells.width; ++cx) {
      const std::array<int, 2> xs{at((cx + 0.25) * cell_w, frame.cols), at((cx + 0.75) * cell_w, frame.cols)};
      int b = 0, g = 0, r = 0;
      for (const uint8_t* row : rows)
        for (const int x : xs) {
          const uint8_t* pixel = row + static_cast<std::ptrdiff_t>(x) * channels;
          b += pixel[0], g += pixel[1], r += pixel[2];
        }
      visit(cy * cells.width + cx, b, g, r);
    }
  }
}

}  // namespace

void WhiteBalanceDrift::update(const cv::Mat& frame, bool forget) {
  if (frame.channels() < 3 || frame.depth() != CV_8U || frame.cols < kCellsX || frame.rows < kCellsY) return;
  if (frame.size() != size_) started_ = false, size_ = frame.size();
  const std::size_t cells = static_cast<std::size_t>(kCellsX * kCellsY);
  now_red_.assign(cells, NAN);
  now_blue_.assign(cells, NAN);
  for_each_cell_colour(frame, {kCellsX, kCellsY}, [this](int i, int b, int g, int r) {
    // A dark or clipped cell's ratios are noise or stuck at the clip.
    if (std::min({b, g, r}) < 4 * 16 || std::max({b, g, r}) > 4 * 250) return;
    const float green = 1.0f / static_cast<float>(g);
    now_red_[static_cast<std::size_t>(i)] = static_cast<float>(r) * green;
    now_blue_[static_cast<std::size_t>(i)] = static_cast<float>(b) * green;
  });
  if (started_) {
    // The median change per channel (as a factor: the median of the factors
    // is the factor of the median log), over cells measured on both frames;
    // a frame where fewer than a third of the cells changed within 5% of
    // their median is not measured.
    const auto median_change = [&](const std::vector<float>& last, const std::vector<float>& now, double& change) {
      changes_.clear();
      for (std::size_t i = 0; i < cells; ++i)
        if (!std::isnan(last[i]) && !std::isnan(now[i])) changes_.push_back(now[i] / last[i]);
      if (changes_.size() < cells / 4) return false;
      const auto middle = changes_.begin() + static_cast<std::ptrdiff_t>(changes_.size() / 2);
      std::nth_element(changes_.begin(), middle, changes_.end());
      const float factor = *middle;
      const auto agreeing = std::count_if(changes_.begin(), changes_.end(),
                                          [factor](float c) { return c > factor * 0.95f && c < factor * 1.05f; });
      change = std::log(static_cast<double>(factor));
      return static_cast<std::size_t>(agreeing) * 3 >= changes_.size();
    };
    double red = 0, blue = 0;
    if (!(median_change(last_red_, now_red_, red) && median_change(last_blue_, now_blue_, blue))) red = blue = 0;
    // (Held within the gains' range: beyond it the sum would only grow unread.)
    const double most = std::log(2.0);
    const double kept = forget ? 1 - kLeak : 1.0;
    log_red_ = std::clamp(kept * log_red_ + red, -most, most);
    log_blue_ = std::clamp(kept * log_blue_ + blue, -most, most);
  }
  started_ = true;
  std::swap(last_red_, now_red_);
  std::swap(last_blue_, now_blue_);
}

ChannelGains WhiteBalanceDrift::gains() const {
  ChannelGains gains;
  // Undo the moves: red times e^-log_red_, blue times e^-log_blue_, green as it is.
  gains.q8[2] = static_cast<int>(std::clamp(std::lround(256 * std::exp(-log_red_)), 128L, 512L));
  gains.q8[0] = static_cast<int>(std::clamp(std::lround(256 * std::exp(-log_blue_)), 128L, 512L));
  return gains;
}

void chroma_histogram(const cv::Mat& frame, cv::Rect area, std::vector<float>& shares, const ChannelGains& gains) {
  shares.assign(static_cast<std::size_t>(kChromaBins * kChromaBins), 0.f);
  if (frame.channels() < 3 || frame.depth() != CV_8U) return;
  const cv::Rect inside = area & cv::Rect(0, 0, frame.cols, frame.rows);
  const int channels = frame.channels();
  const std::array<int, 3> q8 = held(gains);
  int counted = 0;
  for (int y = inside.y; y < inside.y + inside.height; ++y) {
    const uint8_t* pixel = frame.ptr<uint8_t>(y) + static_cast<std::ptrdiff_t>(inside.x) * channels;
    for (int x = 0; x < inside.width; ++x, pixel += channels) {
      const int b = balanced(pixel[0], q8[0]), gr = balanced(pixel[1], q8[1]), red = balanced(pixel[2], q8[2]);
      const int sum = b + gr + red;
      if (sum < kDarkestChroma) continue;
      const int r = std::min(kChromaBins - 1, divided(red * kChromaBins, sum));
      const int g = std::min(kChromaBins - 1, divided(gr * kChromaBins, sum));
      shares[static_cast<std::size_t>(r * kChromaBins + g)] += 1.f;
      ++counted;
    }
  }
  if (counted == 0) return;
  for (float& share : shares) share /= static_cast<float>(counted);
}

double colourful_share(const cv::Mat& frame, cv::Rect area, double tolerance, const ChannelGains& gains) {
  if (frame.channels() < 3 || frame.depth() != CV_8U) return 0;
  const cv::Rect inside = area & cv::Rect(0, 0, frame.cols, frame.rows);
  const int channels = frame.channels();
  const std::array<int, 3> q8 = held(gains);
  int counted = 0, colourful = 0;
  for (int y = inside.y; y < inside.y + inside.height; ++y) {
    const uint8_t* pixel = frame.ptr<uint8_t>(y) + static_cast<std::ptrdiff_t>(inside.x) * channels;
    for (int x = 0; x < inside.width; ++x, pixel += channels) {
      const int gr = balanced(pixel[1], q8[1]), red = balanced(pixel[2], q8[2]);
      const int sum = balanced(pixel[0], q8[0]) + gr + red;
      if (sum < kDarkestChroma) continue;
      ++counted;
      // |channel / sum - 1/3| > tolerance, in integers: |3 channel - sum| > 3 tolerance sum.
      const double limit = 3 * tolerance * sum;
      if (std::abs(3 * red - sum) > limit || std::abs(3 * gr - sum) > limit) ++colourful;
    }
  }
  return counted == 0 ? 0.0 : static_cast<double>(colourful) / counted;
}

void tone_histogram(const cv::Mat& frame, cv::Rect area, std::vector<float>& shares) {
  shares.assign(static_cast<std::size_t>(kToneBins), 0.f);
  if (frame.depth() != CV_8U || frame.channels() == 2) return;
  const cv::Rect inside = area & cv::Rect(0, 0, frame.cols, frame.rows);
  if (inside.area() == 0) return;
  const int channels = frame.channels();
  // cv::cvtColor's gray (OpenCV 4's 15-bit fixed-point weights and
  // rounding, bit for bit), counted per value; the bins are then a table
  // of 256.
  std::array<int, 256> counts{};
  for (int y = inside.y; y < inside.y + inside.height; ++y) {
    const uint8_t* pixel = frame.ptr<uint8_t>(y) + static_cast<std::ptrdiff_t>(inside.x) * channels;
    for (int x = 0; x < inside.width; ++x, pixel += channels)
      ++counts[channels == 1 ? pixel[0] : (3735 * pixel[0] + 19235 * pixel[1] + 9798 * pixel[2] + 16384) >> 15];
  }
  int64_t sum = 0;
  for (int v = 0; v < 256; ++v) sum += int64_t{v} * counts[static_cast<std::size_t>(v)];
  const int64_t count = inside.area();
  if (sum < int64_t{kDarkestTone} * count) return;
  // bin = v / (mean * kToneTop) * kToneBins = v * count * kToneBins * 2 / (sum * 5).
  static_assert(kToneTop == 2.5);
  for (int v = 0; v < 256; ++v) {
    const int64_t bin = std::min<int64_t>(kToneBins - 1, v * count * kToneBins * 2 / (sum * 5));
    shares[static_cast<std::size_t>(bin)] += static_cast<float>(counts[static_cast<std::size_t>(v)]);
  }
  for (float& share : shares) share /= static_cast<float>(count);
}

double shared_colors(const std::vector<float>& a, const std::vector<float>& b) {
  double shared = 0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) shared += std::min(a[i], b[i]);
  return shared;
}

void color_likelihood(const cv::Mat& frame, cv::Size cells, const std::vector<float>& target, cv::Mat& out,
                      std::vector<int>& bins, const ChannelGains& gains) {
  out.create(cells, CV_32F);
  fill(out, 0);
  if (frame.channels() < 3 || frame.depth() != CV_8U || cells.area() == 0) return;
  const std::array<int, 3> q8 = held(gains);
  bins.assign(static_cast<std::size_t>(cells.area()), -1);
  std::array<int, kChromaBins * kChromaBins> counts{};
  int counted = 0;
  for_each_cell_colour(frame, cells, [&](int i, int b, int g, int r) {
    b = balanced(b, q8[0]), g = balanced(g, q8[1]), r = balanced(r, q8[2]);
    const int sum = b + g + r;
    if (sum < 4 * kDarkestChroma) return;
    const int bin = std::min(kChromaBins - 1, r * kChromaBins / sum) * kChromaBins +
                    std::min(kChromaBins - 1, g * kChromaBins / sum);
    bins[static_cast<std::size_t>(i)] = bin;
    ++counts[static_cast<std::size_t>(bin)];
    ++counted;
  });
  if (counted == 0 || target.size() != counts.size()) return;
  for (int i = 0; i < cells.area(); ++i) {
    const int bin = bins[static_cast<std::size_t>(i)];
    if (bin < 0) continue;
    const double scene = static_cast<double>(counts[static_cast<std::size_t>(bin)]) / counted;
    out.ptr<float>(i / cells.width)[i % cells.width] =
        static_cast<float>(std::min(1.0, target[static_cast<std::size_t>(bin)] / scene));
  }
}

}  // namespace saccade::fovea
