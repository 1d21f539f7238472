#pragma once
// The target's colours as a chromaticity histogram: it tells a target partly
// hidden (part of its colours, exactly) from a look-alike of another tint (all
// of its colours shifted), where the mean colour moves as far for both
// (docs/tracking.md).
#include <vector>

#include <opencv2/core.hpp>

namespace saccade::fovea {

inline constexpr int kChromaBins = 32;     // bins over r and over g (each channel's share of R + G + B)
inline constexpr int kDarkestChroma = 30;  // R + G + B under which a pixel is left out: its chromaticity is noise

// The chromaticity histogram of `area`'s pixels (clipped to the frame) of an
// 8-bit BGR or BGRA frame, as shares summing to 1, into `shares`
// (kChromaBins x kChromaBins, r-major). All 0 for a gray frame or an area
// without a pixel bright enough. Allocates nothing once `shares` has its size.
void chroma_histogram(const cv::Mat& frame, cv::Rect area, std::vector<float>& shares);

// The share of one histogram's colours the other has too (histogram
// intersection): 1 for the same colours, 0 for none in common.
double shared_colors(const std::vector<float>& a, const std::vector<float>& b);

}  // namespace saccade::fovea
