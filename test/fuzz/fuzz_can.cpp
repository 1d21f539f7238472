// libFuzzer: what arrives from the CAN side: a cannelloni UDP packet, and the
// CANopen / CiA 402 frames it carries, decoded as the master and the drives
// decode them.
#include <cstdint>
#include <string>
#include <vector>

#include "cannelloni.hpp"
#include "canopen.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace saccade::can;
  std::vector<Frame> frames;
  uint8_t seq = 0;
  if (!cannelloni::decode(data, size, seq, frames).ok()) return 0;
  for (const Frame& f : frames) {
    Sdo sdo;
    (void)parse_sdo(f, sdo);
    uint16_t word = 0;
    int8_t mode = 0;
    int32_t a = 0, b = 0;
    (void)parse_rpdo1(f, word, mode);
    (void)parse_rpdo2(f, a);
    (void)parse_tpdo1(f, word, mode);
    (void)parse_tpdo2(f, a, b);
    (void)decode_statusword(word);
  }
  // What decodes encodes again, within a packet's size.
  std::vector<uint8_t> packet;
  if (!frames.empty() && frames.size() < 200) (void)cannelloni::encode(seq, frames.data(), frames.size(), packet);
  return 0;
}
