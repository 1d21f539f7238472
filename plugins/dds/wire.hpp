#pragma once
// saccade's messages on a DDS edge in their serialised form: the IDL types of
// idl/saccade.idl, whose CDR bytes saccade/cdr.hpp writes from and reads into
// the messages themselves (no generated type in between), and their codecs.
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "codec.hpp"
#include "saccade/cdr.hpp"
#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::dds {

using cdr::kEndOfStream;

// What a serialised type's TopicDataType writes from and reads into.
struct CdrSample {
  const Message* message = nullptr;  // to write (serialize, getSerializedSizeProvider)
  Message* target = nullptr;         // to read into (deserialize)
  std::unique_ptr<Message> owned;    // the target of a sample Fast DDS made itself (createData)
  cdr::Envelope envelope;
  std::shared_ptr<Retina>* spare = nullptr;  // see cdr::read
  // What the last deserialize made of the bytes: ok for a whole message,
  // else what was wrong (an unreadable sample reaches the reader, which
  // counts it).
  Status status;
};

// The serialised codec of `type`; nullptr for a type without an IDL form.
const Codec* find_codec(std::string_view type);
// The types that have a serialised codec.
std::vector<std::string_view> codec_types();

}  // namespace saccade::dds
