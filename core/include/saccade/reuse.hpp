#pragma once
// cv::Mat::create allocates anew whenever the size differs, also when it
// shrinks: a hot path whose matrices change size from call to call (a search
// at several sizes, the looks of a tracker at and under the step it halves
// at) allocates on every call. This keeps one allocation for them.
#include <cstddef>

#include <opencv2/core.hpp>

namespace saccade {

// A continuous `size` x `type` matrix over `storage`'s memory, which grows
// when it must and never shrinks. The matrix does not own the memory: it is
// valid until `storage` grows again or is released, so each matrix reused
// this way needs its own `storage`.
inline cv::Mat reuse(cv::Mat& storage, cv::Size size, int type) {
  const std::size_t bytes = static_cast<std::size_t>(size.area()) * CV_ELEM_SIZE(type);
  if (storage.total() * storage.elemSize() < bytes) storage.create(1, static_cast<int>(bytes), CV_8U);
  return cv::Mat(size, type, storage.data);
}

}  // namespace saccade
