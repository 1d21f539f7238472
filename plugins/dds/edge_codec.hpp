#pragma once
// The codec an edge uses, from what its parameters ask: the serialised form
// (wire.hpp), a shared-memory form (plain.hpp) or the ROS 2 form (ros2.hpp).
#include <cstddef>
#include <string>
#include <string_view>

#include "codec.hpp"
#include "saccade/status.hpp"

namespace saccade::dds {

// How an edge asks its type to travel.
struct CodecRequest {
  bool zero_copy = false;  // one host: the frame ring, the plain form or the mailbox (shared_memory)
  // zero_copy: kAuto is the frame ring for Image (loans when reliable) and
  // the serialised form through the same-host mailbox for every other type,
  // whose few kilobytes it carries faster than a loaned sample
  // (docs/performance.md). kRing on a reliable edge is loans: a ring of
  // reused buffers cannot promise every frame to a slow reader.
  enum class SharedMemory { kAuto, kRing, kLoans, kMailbox } shared_memory = SharedMemory::kAuto;
  bool reliable = false;
  std::size_t capacity = 0;  // zero_copy: bytes the plain form must hold (0: the type's default)
  bool ros2 = false;         // the ROS 2 form (wins over zero_copy: ROS 2 cannot read plain types)
};

// The codec an edge uses: the ROS 2 form when asked (an error when the type has
// none); with `zero_copy`, the frame ring, the plain form holding `capacity`
// or the serialised form (for the mailbox) as `shared_memory` says (a plain
// form too small is an error naming the largest); else the serialised form.
// An error when there is none (a type without an IDL form, too).
Result<const Codec*> choose_codec(std::string_view type, const CodecRequest& request);
// Sets `options`' mailbox fields for an edge that asked `request`, got
// `codec` and keeps `depth` samples: the same-host message mailbox for zero
// copy, the serialised form and shared_memory auto or mailbox (the bridges
// ask for loans under DDS security, so a secure edge has none); every post
// in order on a reliable edge; max(16, depth) slots.
void set_mailbox(const CodecRequest& request, const Codec& codec, int depth, WireOptions& options);

}  // namespace saccade::dds
