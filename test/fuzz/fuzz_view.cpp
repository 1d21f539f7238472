// libFuzzer: what a live view's client sends (the Foxglove WebSocket
// protocol): the first byte picks a text message (the JSON requests:
// subscribe, unsubscribe, advertise, unadvertise) or a binary one
// (messageData, with the JSON Region a client publishes), the rest are its
// bytes, parsed as the server parses them (plugins/view/client_protocol.hpp).
// Nothing may crash, hang or leak, and what is taken must be whole.
#include <cmath>
#include <cstdint>
#include <string_view>

#include "client_protocol.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t* bytes = data + 1;
  const std::size_t n = size - 1;
  if ((data[0] & 1) == 0) {
    const saccade::view::ClientRequest r =
        saccade::view::parse_client_text(std::string_view(reinterpret_cast<const char*>(bytes), n));
    if (r.op == saccade::view::ClientRequest::Op::kMalformed && r.malformed.empty()) __builtin_trap();
    if (r.subscriptions.size() + r.ids.size() + r.channels.size() > n) __builtin_trap();  // more entries than bytes
    return 0;
  }
  uint32_t channel = 0;
  if (!saccade::view::parse_message_data(bytes, n, channel)) return 0;
  saccade::Region region;
  if (saccade::view::parse_region_json(bytes + 5, n - 5, region).ok()) {
    // Taken: a centre, and a size that is not negative.
    if (!(region.size.width >= 0) || !(region.size.height >= 0) || std::isnan(region.center.x) ||
        std::isnan(region.center.y))
      __builtin_trap();
  }
  return 0;
}
