#pragma once
// CAN over UDP in cannelloni's version-2 packet format, so a saccade process
// interworks with a real `cannelloni` bridging can0 on the robot PC.
//
// Packet: version (2), op code (0 = data), sequence number, frame count (big
// endian u16); then per frame the kernel's can_id (big endian u32, with the
// EFF/RTR/ERR flags), the length (bit 7 set for CAN FD, then a flags byte) and
// the data (none for remote frames).
#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "bus.hpp"

namespace saccade::can {

namespace cannelloni {
inline constexpr uint8_t kVersion = 2, kOpData = 0, kFdFlag = 0x80;
inline constexpr std::size_t kHeaderSize = 5;
inline constexpr std::size_t kMaxPacket = 1400;  // stays below a typical MTU, as cannelloni does

// Bytes `f` takes in a packet.
std::size_t encoded_size(const Frame& f);
// Writes a packet holding frames [0, n) to `out` (resized); returns its size.
std::size_t encode(uint8_t seq, const Frame* frames, std::size_t n, std::vector<uint8_t>& out);
// Appends the frames of one packet to `out`; false with `error` (and nothing
// appended) when the packet is malformed: wrong version or op code, truncated,
// a classic frame longer than 8 bytes or an FD frame longer than 64.
bool decode(const uint8_t* packet, std::size_t size, uint8_t& seq, std::vector<Frame>& out, std::string& error);
}  // namespace cannelloni

class UdpTunnel final : public Bus {
 public:
  struct Options {
    int local_port = 20000;
    std::string peer_host = "127.0.0.1";
    int peer_port = 20001;
    double loss = 0.0;  // fault injection: probability that an outgoing packet is thrown away
    uint64_t seed = 1;
  };
  // spec "LOCAL_PORT:HOST:PORT".
  static std::unique_ptr<UdpTunnel> open(const std::string& spec, std::string& error);
  static std::unique_ptr<UdpTunnel> open(const Options& options, std::string& error);
  ~UdpTunnel() override;

  bool send(const Frame& f) override;
  void flush() override;
  bool receive(Frame& out, int64_t timeout_ns) override;
  void set_filters(FilterSet filters) override { filters_ = std::move(filters); }
  BusState state() const override { return BusState::kErrorActive; }
  const BusCounters& counters() const override { return counters_; }
  std::string describe() const override;
  void set_loss(double loss, uint64_t seed) {
    options_.loss = loss;
    rng_.seed(seed);
  }
  uint64_t packets_sent() const { return packets_sent_; }

 private:
  UdpTunnel(int fd, Options options, const void* peer, std::size_t peer_size);
  bool read_packet(int64_t timeout_ns);

  int fd_;
  Options options_;
  unsigned char peer_[32] = {};
  std::size_t peer_size_;
  std::vector<Frame> outgoing_, incoming_;
  std::size_t outgoing_bytes_ = cannelloni::kHeaderSize;  // the packet outgoing_ would make
  std::size_t incoming_next_ = 0;
  std::vector<uint8_t> packet_;
  uint8_t seq_out_ = 0;
  int next_seq_in_ = -1;
  uint64_t packets_sent_ = 0;
  BusCounters counters_;
  FilterSet filters_;
  std::mt19937_64 rng_;
  std::string last_error_;
};

}  // namespace saccade::can
