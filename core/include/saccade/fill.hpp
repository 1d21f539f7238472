#pragma once
// cv::Mat::setTo allocates a scratch buffer on every call (OpenCV 4.6); hot paths
// use this instead, which allocates nothing.
#include <algorithm>
#include <cstdint>

#include <opencv2/core.hpp>

namespace saccade {

// Sets every element of a CV_8U, CV_32S or CV_32F matrix (any channel count) to `value`.
inline void fill(cv::Mat& m, double value) {
  const int n = m.cols * m.channels();
  for (int y = 0; y < m.rows; ++y) {
    switch (m.depth()) {
      case CV_8U: std::fill_n(m.ptr<uint8_t>(y), n, cv::saturate_cast<uint8_t>(value)); break;
      case CV_32S: std::fill_n(m.ptr<int32_t>(y), n, cv::saturate_cast<int32_t>(value)); break;
      case CV_32F: std::fill_n(m.ptr<float>(y), n, static_cast<float>(value)); break;
      default: m.setTo(value); return;
    }
  }
}

}  // namespace saccade
