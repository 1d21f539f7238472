// libFuzzer: an image sequence's file pattern (capture.images and the stereo
// readers): one %d, or an error; never a printf format.
#include <cstdint>
#include <string>

#include "readers.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string pattern(reinterpret_cast<const char*>(data), size);
  if (auto p = saccade::capture::NumberedPattern::parse(pattern); p.ok()) {
    (void)p->name(0);
    (void)p->name(123456789);
    (void)p->name(-7);
  }
  return 0;
}
