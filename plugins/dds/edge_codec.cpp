#include "edge_codec.hpp"

#include <algorithm>

#include "plain.hpp"
#include "ros2.hpp"
#include "saccade/message.hpp"
#include "wire.hpp"

namespace saccade::dds {

Result<const Codec*> choose_codec(std::string_view type, const CodecRequest& request) {
  const Codec* serialized = find_codec(type);
  if (serialized == nullptr) return Status::error("no IDL type for '" + std::string(type) + "'");
  if (request.ros2) {
    if (const Codec* ros2 = find_ros2_codec(type)) return ros2;
    std::string have;
    for (const auto& c : ros2_codecs()) have += (have.empty() ? "" : ", ") + std::string(c.type);
    return Status::error("ROS 2 has no message for " + std::string(type) + " (it has for " + have + ")");
  }
  if (!request.zero_copy) return serialized;
  using SharedMemory = CodecRequest::SharedMemory;
  const bool is_image = type == Image::kTypeName;
  if (request.shared_memory == SharedMemory::kMailbox || (request.shared_memory == SharedMemory::kAuto && !is_image))
    return serialized;
  const bool ring = !request.reliable && (request.shared_memory == SharedMemory::kRing ||
                                          (request.shared_memory == SharedMemory::kAuto && is_image));
  if (ring)
    if (const Codec* c = find_ring_codec(type)) return c;
  if (const Codec* plain = find_plain_codec(type, request.capacity)) return plain;
  std::size_t largest = 0;
  for (const auto& c : plain_codecs())
    if (c.type == type) largest = std::max(largest, c.capacity);
  if (largest == 0) return serialized;  // no plain form: small types travel serialised
  return Status::error("no shared-memory form of " + std::string(type) + " holds " + std::to_string(request.capacity) +
                       " bytes (the largest holds " + std::to_string(largest) + ")");
}

void set_mailbox(const CodecRequest& request, const Codec& codec, int depth, WireOptions& options) {
  using SharedMemory = CodecRequest::SharedMemory;
  options.mailbox = request.zero_copy && !request.ros2 && codec.form == Codec::Form::kSerialized &&
                    (request.shared_memory == SharedMemory::kAuto || request.shared_memory == SharedMemory::kMailbox);
  options.in_order = request.reliable;
  options.mailbox_slots = static_cast<uint32_t>(std::max(16, depth));
}

}  // namespace saccade::dds
