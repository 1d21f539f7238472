#include "client_protocol.hpp"

#include <cstring>

#include <nlohmann/json.hpp>

namespace saccade::view {
namespace {

using json = nlohmann::json;

bool as_u32(const json& j, const char* key, uint32_t& out) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_number_unsigned() || it->get<uint64_t>() > 0xffffffffu) return false;
  out = static_cast<uint32_t>(it->get<uint64_t>());
  return true;
}

bool number(const json& j, const char* key, double& out) {
  auto k = j.find(key);
  if (k == j.end() || !k->is_number()) return false;
  out = k->get<double>();
  return true;
}

ClientRequest malformed(std::string why) {
  ClientRequest r;
  r.malformed = std::move(why);
  return r;
}

}  // namespace

ClientRequest parse_client_text(std::string_view text) {
  const json m = json::parse(text.begin(), text.end(), nullptr, false);
  if (m.is_discarded() || !m.is_object()) return malformed("not a JSON object");
  auto op_it = m.find("op");
  if (op_it == m.end() || !op_it->is_string()) return malformed("no 'op'");
  const std::string& op = op_it->get_ref<const std::string&>();
  ClientRequest r;
  if (op == "subscribe") {
    auto subs = m.find("subscriptions");
    if (subs == m.end() || !subs->is_array()) return malformed("subscribe without 'subscriptions'");
    r.op = ClientRequest::Op::kSubscribe;
    for (const json& s : *subs) {
      ClientRequest::Subscription sub;
      if (!s.is_object() || !as_u32(s, "id", sub.id) || !as_u32(s, "channelId", sub.channel_id)) {
        r.malformed = "subscribe: each subscription needs an 'id' and a 'channelId'";
        break;
      }
      r.subscriptions.push_back(sub);
    }
  } else if (op == "unsubscribe") {
    auto ids = m.find("subscriptionIds");
    if (ids == m.end() || !ids->is_array()) return malformed("unsubscribe without 'subscriptionIds'");
    r.op = ClientRequest::Op::kUnsubscribe;
    for (const json& id : *ids) {
      if (!id.is_number_unsigned()) {
        r.malformed = "unsubscribe: an id is not a number";
        break;
      }
      r.ids.push_back(static_cast<uint32_t>(id.get<uint64_t>()));
    }
  } else if (op == "advertise") {
    auto channels = m.find("channels");
    if (channels == m.end() || !channels->is_array()) return malformed("advertise without 'channels'");
    r.op = ClientRequest::Op::kAdvertise;
    for (const json& c : *channels) {
      ClientRequest::AdvertisedChannel channel;
      auto topic = c.is_object() ? c.find("topic") : c.end();
      auto encoding = c.is_object() ? c.find("encoding") : c.end();
      if (!c.is_object() || !as_u32(c, "id", channel.id) || topic == c.end() || !topic->is_string() ||
          encoding == c.end() || !encoding->is_string()) {
        r.malformed = "advertise: each channel needs 'id', 'topic' and 'encoding'";
        break;
      }
      channel.topic = topic->get<std::string>();
      channel.encoding = encoding->get<std::string>();
      r.channels.push_back(std::move(channel));
    }
  } else if (op == "unadvertise") {
    auto ids = m.find("channelIds");
    if (ids == m.end() || !ids->is_array()) return malformed("unadvertise without 'channelIds'");
    r.op = ClientRequest::Op::kUnadvertise;
    for (const json& id : *ids)
      if (id.is_number_unsigned()) r.ids.push_back(static_cast<uint32_t>(id.get<uint64_t>()));
  } else {
    return malformed("unknown op '" + op + "'");
  }
  return r;
}

bool parse_message_data(const uint8_t* data, std::size_t size, uint32_t& channel_id) {
  if (size < 5 || data[0] != 0x01) return false;
  std::memcpy(&channel_id, data + 1, 4);
  return true;
}

Status parse_region_json(const uint8_t* data, std::size_t size, Region& region) {
  const json m = json::parse(data, data + size, nullptr, false);
  if (m.is_discarded() || !m.is_object()) return Status::error("a Region needs 'center': {'x', 'y'}");
  auto center = m.find("center");
  if (center == m.end() || !center->is_object() || !number(*center, "x", region.center.x) ||
      !number(*center, "y", region.center.y))
    return Status::error("a Region needs 'center': {'x', 'y'}");
  if (auto s = m.find("size"); s != m.end()) {
    if (!s->is_object() || !number(*s, "width", region.size.width) || !number(*s, "height", region.size.height) ||
        region.size.width < 0 || region.size.height < 0)
      return Status::error("a Region's 'size' needs 'width' and 'height' >= 0");
  }
  if (auto label = m.find("label"); label != m.end() && label->is_string()) region.label = label->get<std::string>();
  if (auto camera = m.find("camera_id"); camera != m.end() && camera->is_number_integer())
    region.camera_id = camera->get<int>();
  region.score = 1.0;
  return {};
}

}  // namespace saccade::view
