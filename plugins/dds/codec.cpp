#include "codec.hpp"

#include <algorithm>

#include <fastdds/dds/subscriber/DataReader.hpp>

namespace saccade::dds {

WireSample::~WireSample() = default;

void WireSample::wait(eprosima::fastdds::dds::DataReader& reader, int timeout_ms) {
  wait_for_dds(reader, static_cast<int64_t>(timeout_ms) * 1'000'000);
}

void wait_on_doorbell(eprosima::fastdds::dds::DataReader& reader, int timeout_ms,
                      const std::function<bool(int64_t)>& sleep, const std::function<bool()>& arrived) {
  constexpr int64_t kSliceNs = 5'000'000;
  const int64_t deadline = steady_now_ns() + static_cast<int64_t>(timeout_ms) * 1'000'000;
  for (;;) {
    if (reader.get_unread_count() > 0) return;
    const int64_t left = deadline - steady_now_ns();
    if (left <= 0) return;
    if (!sleep(std::min(left, kSliceNs))) {
      wait_for_dds(reader, left);
      return;
    }
    if (arrived()) return;
  }
}

void wait_for_dds(eprosima::fastdds::dds::DataReader& reader, int64_t timeout_ns) {
  reader.wait_for_unread_message(eprosima::fastrtps::Duration_t(static_cast<int32_t>(timeout_ns / 1'000'000'000),
                                                                static_cast<uint32_t>(timeout_ns % 1'000'000'000)));
}

}  // namespace saccade::dds
