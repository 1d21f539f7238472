#pragma once
// Semi-global aggregation of the matcher's correlations (NccConfig::semi_global):
// the stereo library's own, called by ncc_match_cross after its sweep.
#include <cstddef>

#include <opencv2/core.hpp>

#include "ncc.hpp"

namespace saccade::stereo {

// The sweep's result: the correlation of left pixel x with right pixel x - d
// at data[(d - d_min) * plane + y * width + x], computed for the columns
// span_lo[d - d_min] .. span_hi[d - d_min] of rows y0 .. y1.
struct SweepVolume {
  const float* data;
  std::size_t plane;
  int width, d_min, d_max;
  const int *span_lo, *span_hi;
  bool has(int d, int x) const {
    return d >= d_min && d <= d_max && x >= span_lo[d - d_min] && x <= span_hi[d - d_min];
  }
};

// Both directions' disparities from the sweep's volume aggregated along
// config.paths paths, over every left pixel with a range (lo <= hi) whose
// window (half width r) fits, flat ones too: their neighbours decide. Right
// pixels search exactly the pairs the left pixels do (ncc_match_cross).
void semi_global_match(const SweepVolume& volume, const cv::Mat& lo, const cv::Mat& hi, int r, const NccConfig& config,
                       NccScratch& scratch, cv::Mat& disparity_lr, cv::Mat& score_lr, cv::Mat& disparity_rl,
                       cv::Mat& score_rl);

}  // namespace saccade::stereo
