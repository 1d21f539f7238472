#pragma once
// CAN over UDP in cannelloni's version-2 packet format, so a saccade process
// interworks with a real `cannelloni` bridging can0 on the robot PC.
//
// Packet: version (2), op code (0 = data), sequence number, frame count (big
// endian u16); then per frame the kernel's can_id (big endian u32, with the
// EFF/RTR/ERR flags), the length (bit 7 set for CAN FD, then a flags byte) and
// the data (none for remote frames).
//
// Optionally every packet is authenticated with a shared key: a trailer of
// the sender's epoch (its start time, big endian u64), a packet counter (big
// endian u64) and a 16-byte HMAC-SHA256 tag follows the frames. A real
// `cannelloni` does not speak this form: it is for saccade at both ends.
#include <netinet/in.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "bus.hpp"

struct evp_mac_ctx_st;  // OpenSSL's EVP_MAC_CTX

namespace saccade::can {

namespace cannelloni {
inline constexpr uint8_t kVersion = 2, kOpData = 0, kFdFlag = 0x80;
inline constexpr std::size_t kHeaderSize = 5;
inline constexpr std::size_t kMaxPacket = 1400;  // stays below a typical MTU, as cannelloni does

// Bytes `f` takes in a packet.
std::size_t encoded_size(const Frame& f);
// Writes a packet holding frames [0, n) to `out` (resized); returns its size.
std::size_t encode(uint8_t seq, const Frame* frames, std::size_t n, std::vector<uint8_t>& out);
// Appends the frames of one packet to `out` (the receiver's reused buffer)
// and sets `seq`; an error (and nothing appended) when the packet is
// malformed: wrong version or op code, truncated, a classic frame longer than
// 8 bytes or an FD frame longer than 64.
Status decode(const uint8_t* packet, std::size_t size, uint8_t& seq, std::vector<Frame>& out);

// A link's shared key: 32 bytes, wiped from memory when destroyed.
struct Key {
  std::array<uint8_t, 32> bytes{};
  Key() = default;
  Key(const Key&) = default;
  Key& operator=(const Key&) = default;
  ~Key();
};
inline constexpr std::size_t kTagSize = 16;                    // HMAC-SHA256 truncated to 128 bits
inline constexpr std::size_t kTrailerSize = 8 + 8 + kTagSize;  // epoch, counter, tag

// Reads a key file (64 hex characters, surrounding white space allowed) into
// `key` (filled in place: the secret is never copied into a temporary). An
// error naming the file when it cannot be read, is not a regular file, holds
// anything else, or is readable or writable by its group or others (the error
// says the chmod that fixes it).
Status load_key(const std::string& path, Key& key);

// The two ends of a link as the tag covers them (IPv4 address and port of the
// sender, then of the receiver, network byte order), so that a packet sent
// back to its sender, or onto another link with the same key, is not
// authentic there.
struct LinkEnds {
  uint32_t from_addr = 0, to_addr = 0;  // network byte order
  uint16_t from_port = 0, to_port = 0;  // network byte order
};

// HMAC-SHA256 with one key, prepared once (OpenSSL's EVP_MAC).
class Authenticator {
 public:
  explicit Authenticator(const Key& key);
  ~Authenticator();
  Authenticator(const Authenticator&) = delete;
  Authenticator& operator=(const Authenticator&) = delete;
  bool ok() const { return ctx_ != nullptr; }
  // Appends the trailer (epoch, counter, tag) to `packet`.
  void seal(std::vector<uint8_t>& packet, uint64_t epoch, uint64_t counter, const LinkEnds& ends);
  // Checks a sealed packet's tag in constant time; on success the frames are
  // bytes [0, payload_size) and `epoch`, `counter` the trailer's. False when
  // it is too short to hold a trailer or its tag is not the key's.
  bool open(const uint8_t* packet, std::size_t size, const LinkEnds& ends, std::size_t& payload_size, uint64_t& epoch,
            uint64_t& counter);

 private:
  bool tag(const uint8_t* data, std::size_t size, const LinkEnds& ends, uint8_t (&out)[32]);
  ::evp_mac_ctx_st* ctx_ = nullptr;
};

// Authentic packets of one sender: the newest session (epoch) and which of
// its last 64 counters were seen, so that a replayed packet is refused while
// packets reordered within 64 are still taken.
class ReplayWindow {
 public:
  static constexpr uint64_t kSize = 64;
  enum class Verdict { kNew, kNewSession, kReplayed, kStaleSession };
  // Records the packet when it is new; `gap` is the number of counters
  // skipped before it (packets lost so far), `late` true when it fills an
  // earlier gap.
  Verdict accept(uint64_t epoch, uint64_t counter, uint64_t& gap, bool& late);

 private:
  bool started_ = false;
  uint64_t epoch_ = 0, highest_ = 0, seen_ = 0;  // bit i: counter highest_ - i was seen
};

// Fault injection on a link's packets (for tests of what the loop survives):
// each packet is dropped, altered in one byte, held back to go after the next
// one, or sent twice, each with its own probability, from a seed. A
// probability of 0 draws nothing, so the other faults' draws stay the same.
struct Faults {
  double drop = 0, duplicate = 0, reorder = 0, corrupt = 0;
  uint64_t seed = 1;
};
class FaultyLink {
 public:
  explicit FaultyLink(Faults faults = {}) : faults_(faults), rng_(faults.seed) {}
  // Puts `packet` (of `frames` frames) on the wire through `send(bytes, frames)`:
  // nothing (dropped), or it, altered or not, then again (duplicated), then a
  // packet held back earlier; or holds it back for after the next one
  // (reordered). Counted in frames: dropped, corrupted, reordered, duplicated.
  template <class Send>
  void pass(const std::vector<uint8_t>& packet, std::size_t frames, BusCounters& counters, Send&& send) {
    if (chance(faults_.drop)) {
      counters.dropped += frames;
      return;
    }
    const std::vector<uint8_t>* out = &packet;
    if (chance(faults_.corrupt) && !packet.empty()) {
      altered_ = packet;
      const std::size_t at = std::uniform_int_distribution<std::size_t>(0, packet.size() - 1)(rng_);
      altered_[at] ^= static_cast<uint8_t>(std::uniform_int_distribution<int>(1, 255)(rng_));
      counters.corrupted += frames;
      out = &altered_;
    }
    if (chance(faults_.reorder) && !held_) {
      held_ = *out;
      held_frames_ = frames;
      counters.reordered += frames;
      return;
    }
    send(*out, frames);
    if (chance(faults_.duplicate)) {
      send(*out, frames);
      counters.duplicated += frames;
    }
    if (held_) {
      send(*held_, held_frames_);
      held_.reset();
    }
  }
  const Faults& faults() const { return faults_; }

 private:
  bool chance(double p) { return p > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < p; }
  Faults faults_;
  std::mt19937_64 rng_;
  std::vector<uint8_t> altered_;
  std::optional<std::vector<uint8_t>> held_;
  std::size_t held_frames_ = 0;
};
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
  // Where the tunnel listens and how it trusts its peer.
  struct Link {
    // The local address to bind. Empty: 127.0.0.1 when the peer is a loopback
    // address, else the address the kernel routes to the peer from; never
    // every interface unless given as 0.0.0.0 (not with a key).
    std::string bind_address;
    // With a key every packet sent is sealed and every packet received must
    // be authentic, new and of the peer's newest session.
    const cannelloni::Key* key = nullptr;
  };
  // The bound tunnel, or the error naming the tunnel and what failed (a spec
  // not of the form "[BIND_ADDR:]LOCAL_PORT:HOST:PORT", a port out of range,
  // a host that does not resolve, no route, a bind that fails).
  static Result<std::unique_ptr<UdpTunnel>> open(const std::string& spec, const cannelloni::Key* key = nullptr);
  static Result<std::unique_ptr<UdpTunnel>> open(const Options& options);
  static Result<std::unique_ptr<UdpTunnel>> open(const Options& options, const Link& link);
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
    faults_ = cannelloni::FaultyLink({loss, 0, 0, 0, seed});
  }
  // Fault injection on the packets this end sends (drop is set_loss's loss).
  void set_faults(const cannelloni::Faults& faults) {
    options_.loss = faults.drop;
    faults_ = cannelloni::FaultyLink(faults);
  }
  uint64_t packets_sent() const { return packets_sent_; }
  // The address and port the tunnel is bound to, as "ADDR:PORT".
  std::string local_address() const;
  bool authenticated() const { return auth_ != nullptr; }
  // The epoch this end seals its packets with (its start time, ns since 1970).
  uint64_t epoch() const { return epoch_; }

 private:
  UdpTunnel(int fd, Options options, const sockaddr_in& local, const sockaddr_in& peer);
  bool read_packet(int64_t timeout_ns);
  // An authentic, new packet: its frames' size; 0 when it was dropped (counted).
  std::size_t check_sealed(const uint8_t* packet, std::size_t size);

  int fd_;
  Options options_;
  sockaddr_in local_{};  // as bound
  sockaddr_in peer_{};
  std::unique_ptr<cannelloni::Authenticator> auth_;
  cannelloni::ReplayWindow window_;
  uint64_t epoch_ = 0, counter_out_ = 0;
  std::vector<Frame> outgoing_, incoming_;
  std::size_t outgoing_bytes_ = cannelloni::kHeaderSize;  // the packet outgoing_ would make
  std::size_t incoming_next_ = 0;
  std::vector<uint8_t> packet_;
  uint8_t seq_out_ = 0;
  int next_seq_in_ = -1;
  uint64_t packets_sent_ = 0;
  BusCounters counters_;
  FilterSet filters_;
  cannelloni::FaultyLink faults_;
  std::string last_error_;
};

}  // namespace saccade::can
