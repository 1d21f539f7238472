#pragma once
// The target's colours as a chromaticity histogram: it tells a target partly
// hidden (part of its colours, exactly) from a look-alike of another tint (all
// of its colours shifted), where the mean colour moves as far for both
// (docs/tracking.md).
#include <algorithm>
#include <array>
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

// Per-channel multipliers (B, G, R, each a multiple of 1/256 from 0.5 to 2;
// the readings hold them to that range) that every colour reading below
// applies to a pixel's channels first: a camera's white balance (or the light's colour) multiplies every pixel's
// channels by the same gains, which move every chromaticity and so every
// colour the tracker learnt; read through their inverse (WhiteBalanceDrift),
// the colours are the ones learnt.
struct ChannelGains {
  std::array<int, 3> q8{256, 256, 256};  // the multipliers times 256
  bool neutral() const { return q8[0] == 256 && q8[1] == 256 && q8[2] == 256; }
};

// The camera's white balance followed from frame to frame: how far the
// red and blue gains have moved, relative to green, measured on what did not
// change between consecutive frames. Each frame is reduced to a grid of
// cells (the four pixels at each cell's quarter points, as color_likelihood
// reads them); per cell, the change of
// its red-to-green and blue-to-green ratios since the last frame; the median
// change over the cells is the camera's (a cell whose content moved or
// changed changes its ratios its own way, a gain change every cell's the
// same way). The changes add up over frames, each frame forgetting kLeak of
// the sum: a pan's content biases each frame's median a little, and added up
// for good those biases reached 17% over 300 frames of the tracking
// benchmark's `rotation` with no white balance change at all (docs/
// tracking.md); forgotten, a lasting change is undone for tens of frames, as
// long as the tracker's own colour learning needs to catch up with it. A
// frame told not to `forget` adds its change and forgets nothing: the box
// tracker's while its target is lost, when nothing learns and the colours
// learnt before it went must be read through the whole change since.
// gains() are the multipliers that undo the sum, so a colour read through
// them is about the colour the same surface had on the first frame. A frame
// is not measured (a cut, a flash) where under a quarter of the cells can be
// compared with the last frame's (dark or clipped), or under a third of those
// changed within 5% of the median, in red or in blue. Allocation-free once its
// buffers have their size.
class WhiteBalanceDrift {
 public:
  static constexpr int kCellsX = 32, kCellsY = 24;
  static constexpr double kLeak = 0.03;
  void update(const cv::Mat& frame, bool forget = true);
  ChannelGains gains() const;

 private:
  bool started_ = false;
  double log_red_ = 0, log_blue_ = 0;  // ln of the red and blue gains' moves, over green's
  std::vector<float> last_red_, last_blue_, now_red_, now_blue_, changes_;
  cv::Size size_;
};

// The chromaticity histogram of `area`'s pixels (clipped to the frame) of an
// 8-bit BGR or BGRA frame, as shares summing to 1, into `shares`
// (kChromaBins x kChromaBins, r-major), each pixel's channels first
// multiplied by `gains`. All 0 for a gray frame or an area without a pixel
// bright enough. Allocates nothing once `shares` has its size.
void chroma_histogram(const cv::Mat& frame, cv::Rect area, std::vector<float>& shares, const ChannelGains& gains = {});

// The share of `area`'s pixels (clipped to the frame; those under
// kDarkestChroma left out) of an 8-bit BGR(A) frame whose chromaticity lies
// more than `tolerance` from gray's (1/3, 1/3) in r or g (its channels
// multiplied by `gains`): how much colour there is to tell things apart by.
// 0 for a gray frame, also one whose three channels are equal (a monochrome
// camera's frames read as colour), or an area without a pixel bright enough.
double colourful_share(const cv::Mat& frame, cv::Rect area, double tolerance, const ChannelGains& gains = {});

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
// points, its channels multiplied by `gains`; a cell too dark for a colour
// scores 0. CV_32F `out`; all 0 for a gray frame. `bins` is scratch.
void color_likelihood(const cv::Mat& frame, cv::Size cells, const std::vector<float>& target, cv::Mat& out,
                      std::vector<int>& bins, const ChannelGains& gains = {});

}  // namespace saccade::fovea
