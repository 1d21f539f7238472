#pragma once
// What a live view's client sends (the Foxglove WebSocket protocol,
// foxglove.websocket.v1), parsed without the server's state: the JSON
// requests (subscribe, unsubscribe, advertise, unadvertise) and the binary
// messageData frames of clientPublish with the JSON Region they carry. The
// server applies what is parsed (view_server.cpp); the fuzz_view harness
// feeds these functions any bytes.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::view {

struct ClientRequest {
  enum class Op { kMalformed, kSubscribe, kUnsubscribe, kAdvertise, kUnadvertise };
  struct Subscription {
    uint32_t id = 0, channel_id = 0;
  };
  struct AdvertisedChannel {
    uint32_t id = 0;
    std::string topic, encoding;
  };
  Op op = Op::kMalformed;
  std::vector<Subscription> subscriptions;  // subscribe
  std::vector<uint32_t> ids;                // unsubscribe: subscription ids; unadvertise: channel ids
  std::vector<AdvertisedChannel> channels;  // advertise
  // Why the request is dropped (kMalformed), or why one of its entries is:
  // the entries before that one are above and are applied first, as a server
  // taking them one at a time would. Empty when the whole request is good.
  std::string malformed;
};

// One text message from a client.
ClientRequest parse_client_text(std::string_view text);

// A binary message from a client: messageData (opcode 1, the channel id as
// 4 bytes little-endian, the payload after byte 5). false when it is not.
bool parse_message_data(const uint8_t* data, std::size_t size, uint32_t& channel_id);

// The JSON Region a client publishes (a messageData payload) into `region`
// (a message to fill), or an error saying why it is not a Region.
Status parse_region_json(const uint8_t* data, std::size_t size, Region& region);

}  // namespace saccade::view
