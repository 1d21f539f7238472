// libFuzzer: the CDR bytes of every message type's channel (the DDS wire
// conversions, MCAP files, a live view): the first byte picks the type and
// form, the rest are the bytes. A decoder must refuse what does not decode,
// never crash or allocate without bound.
#include <cstdint>
#include <string>
#include <vector>

#include "channel.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  static const std::vector<std::string_view> types = saccade::dds::channel_types();
  const std::size_t pick = data[0] % (types.size() + 2);
  const saccade::dds::ChannelEncoding* encoding =
      pick < types.size() ? saccade::dds::channel_encoding(types[pick], false)
                          : saccade::dds::channel_encoding(pick == types.size() ? "Image" : "JointState", true);
  auto decoder = saccade::dds::make_decoder(*encoding);
  saccade::Result<saccade::MessagePtr> m = decoder->decode(data + 1, size - 1);
  if (m.ok()) {
    // What decodes encodes again.
    std::vector<uint8_t> bytes;
    (void)saccade::dds::make_encoder(*encoding)->encode(**m, bytes);
  }
  return 0;
}
