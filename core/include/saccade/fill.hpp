#pragma once
// cv::Mat::setTo allocates a scratch buffer on every call (OpenCV 4.6); hot paths
// use this instead, which allocates nothing.
#include <algorithm>
#include <cstdint>

#include <opencv2/core.hpp>

namespace saccade {

// Sets every element of a CV_8U, CV_32S or CV_32F matrix (any channel count) to `value`.
inline void fill(cv::Mat& m, double value) {
  if (m.empty()) return;
  // A continuous matrix is one long row: one loop instead of one per row.
  const bool one_row = m.isContinuous();
  const int rows = one_row ? 1 : m.rows;
  const std::size_t n = one_row ? m.total() * static_cast<std::size_t>(m.channels())
                                : static_cast<std::size_t>(m.cols) * static_cast<std::size_t>(m.channels());
  for (int y = 0; y < rows; ++y) {
    switch (m.depth()) {
      case CV_8U: std::fill_n(m.ptr<uint8_t>(y), n, cv::saturate_cast<uint8_t>(value)); break;
      case CV_32S: std::fill_n(m.ptr<int32_t>(y), n, cv::saturate_cast<int32_t>(value)); break;
      case CV_32F: std::fill_n(m.ptr<float>(y), n, static_cast<float>(value)); break;
      default: m.setTo(value); return;
    }
  }
}

}  // namespace saccade
