#pragma once
// The target's colours as a chromaticity histogram: it tells a target partly
// hidden (part of its colours, exactly) from a look-alike of another tint (all
// of its colours shifted), where the mean colour moves as far for both
// (docs/tracking.md).
#include <algorithm>
#include <vector>

#include <opencv2/core.hpp>

namespace saccade::fovea {

inline constexpr int kChromaBins = 32;     // bins over r and over g (each channel's share of R + G + B)
inline constexpr int kDarkestChroma = 30;  // R + G + B under which a pixel is left out: its chromaticity is noise

// The share of a target's pixels that must lie off gray (by the colour
// tolerance: colourful_share) for its colour to be evidence.
inline constexpr double kMinColourful = 0.05;

// Where a target's colours and tones are measured: the central half of its
// box (centred at `center`, of `size`), within the frame; the rest of a box
// is most often background.
inline cv::Rect central_half(const cv::Mat& frame, cv::Point2d center, cv::Size2d size) {
  return cv::Rect(
             cv::Point(static_cast<int>(center.x - size.width / 4), static_cast<int>(center.y - size.height / 4)),
             cv::Size(std::max(1, static_cast<int>(size.width / 2)), std::max(1, static_cast<int>(size.height / 2)))) &
         cv::Rect(0, 0, frame.cols, frame.rows);
}

// The chromaticity histogram of `area`'s pixels (clipped to the frame) of an
// 8-bit BGR or BGRA frame, as shares summing to 1, into `shares`
// (kChromaBins x kChromaBins, r-major). All 0 for a gray frame or an area
// without a pixel bright enough. Allocates nothing once `shares` has its size.
void chroma_histogram(const cv::Mat& frame, cv::Rect area, std::vector<float>& shares);

// The share of `area`'s pixels (clipped to the frame; those under
// kDarkestChroma left out) of an 8-bit BGR(A) frame whose chromaticity lies
// more than `tolerance` from gray's (1/3, 1/3) in r or g: how much colour
// there is to tell things apart by. 0 for a gray frame, also one whose three
// channels are equal (a monochrome camera's frames read as colour), or an
// area without a pixel bright enough.
double colourful_share(const cv::Mat& frame, cv::Rect area, double tolerance);

inline constexpr int kToneBins = 32;     // bins over a pixel's gray as a share of the area's mean gray, 0 to ...
inline constexpr double kToneTop = 2.5;  // ... this many times the mean (brighter pixels in the last bin)
inline constexpr int kDarkestTone = 8;   // a mean gray under which an area has no tones to tell apart

// The histogram of `area`'s pixels' gray (clipped to the frame) as a
// share of the area's mean gray, of an 8-bit gray, BGR or BGRA frame: the
// gray counterpart of chroma_histogram, the same under a brighter or dimmer
// light, for a target without colours or a monochrome camera. Shares
// summing to 1 into `shares` (kToneBins); all 0 for an area darker than
// kDarkestTone. Allocates nothing once `shares` has its size.
void tone_histogram(const cv::Mat& frame, cv::Rect area, std::vector<float>& shares);

// The share of one histogram's colours the other has too (histogram
// intersection): 1 for the same colours, 0 for none in common.
double shared_colors(const std::vector<float>& a, const std::vector<float>& b);

// How likely each cell of a `cells` grid laid over an 8-bit BGR(A) frame is
// to be of the target's colours (`target`, chroma_histogram's shares): the
// ratio of the target's share of the cell's chromaticity bin to the grid's
// own share of it, at most 1 (Swain and Ballard's ratio histogram: a colour
// the target has and the scene rarely does scores high, one all over the
// scene low). A cell's colour is the mean of the four pixels at its quarter
// points; a cell too dark for a colour scores 0. CV_32F `out`; all 0 for a
// gray frame. `bins` is scratch.
void color_likelihood(const cv::Mat& frame, cv::Size cells, const std::vector<float>& target, cv::Mat& out,
                      std::vector<int>& bins);

}  // namespace saccade::fovea
