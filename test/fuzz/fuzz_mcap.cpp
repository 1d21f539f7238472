// libFuzzer: an MCAP file, any bytes. The reader opens it (from its summary,
// or by scanning its data section), reads every message as it is (stopping at
// the first damage) and salvaging, and a TopicReader plays back every topic,
// decoding each message into saccade's types. Every damage must be an error
// that names its file offset; nothing may crash, hang, leak or allocate
// without bound. The bytes go through a memory file, as the reader maps files.
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "mcap.hpp"
#include "recording.hpp"

namespace {

std::string path;  // of the memory file
int fd = -1;

// A damage's error: it names the offset (Reader::fail) or the message's.
void expect_offset(const std::string& error) {
  if (error.find("offset ") == std::string::npos) {
    std::fprintf(stderr, "an error without its offset: %s\n", error.c_str());
    __builtin_trap();
  }
}

// Every message of an open reader; the number read.
uint64_t read_all(saccade::mcap::Reader& reader, const saccade::mcap::ReadOptions& options) {
  reader.rewind(options);
  saccade::mcap::MessageView view;
  uint64_t count = 0;
  for (;; ++count) {
    const saccade::Result<bool> read = reader.next(view);
    if (!read.ok()) {
      if (options.salvage) __builtin_trap();  // salvaging skips damage instead
      expect_offset(read.error());
      break;
    }
    if (!*read) break;
    volatile uint8_t sum = 0;
    for (std::size_t i = 0; i < view.size; i += 4096) sum = sum + view.data[i];  // the bytes are readable
  }
  return count;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fd = memfd_create("fuzz.mcap", MFD_CLOEXEC);
  if (fd < 0) __builtin_trap();
  path = "/proc/self/fd/" + std::to_string(fd);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (ftruncate(fd, 0) != 0 || pwrite(fd, data, size, 0) != static_cast<ssize_t>(size)) __builtin_trap();
  for (const bool salvage : {false, true}) {
    saccade::mcap::Reader reader;
    if (saccade::Status opened = reader.open(path, salvage); !opened.ok()) {
      expect_offset(opened.message());
      continue;
    }
    for (const std::string& warning : reader.warnings()) expect_offset(warning);
    read_all(reader, {});
    saccade::mcap::ReadOptions options;
    options.salvage = true;
    read_all(reader, options);
    for (const std::string& warning : reader.warnings()) expect_offset(warning);
    if (!reader.channels().empty()) {
      // Only the first channel: chunks without it are passed over.
      options.channels = {reader.channels().begin()->first};
      read_all(reader, options);
    }

    // Every topic back as saccade messages.
    std::vector<std::string> topics;
    for (const auto& [id, channel] : reader.channels()) {
      bool named = false;
      for (const std::string& t : topics) named = named || t == channel.topic;
      if (!named) topics.push_back(channel.topic);
    }
    saccade::mcap::TopicReader player;
    if (!player.open(path, topics, salvage).ok()) continue;  // a topic named twice, a schema saccade does not read
    for (;;) {
      const saccade::Result<saccade::MessagePtr> next = player.next();
      if (!next.ok()) {
        expect_offset(next.error());
        break;
      }
      if (*next == nullptr) break;
    }
  }
  return 0;
}
