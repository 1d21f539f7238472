#include "cannelloni.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace saccade::can {

namespace cannelloni {

std::size_t encoded_size(const Frame& f) { return 4 + 1 + (f.fd ? 1 : 0) + (f.rtr ? 0 : f.length); }

std::size_t encode(uint8_t seq, const Frame* frames, std::size_t n, std::vector<uint8_t>& out) {
  std::size_t size = kHeaderSize;
  for (std::size_t i = 0; i < n; ++i) size += encoded_size(frames[i]);
  out.resize(size);
  uint8_t* p = out.data();
  *p++ = kVersion;
  *p++ = kOpData;
  *p++ = seq;
  *p++ = static_cast<uint8_t>(n >> 8);
  *p++ = static_cast<uint8_t>(n & 0xFF);
  for (std::size_t i = 0; i < n; ++i) {
    const Frame& f = frames[i];
    const uint32_t id = f.raw_id();
    *p++ = static_cast<uint8_t>(id >> 24);
    *p++ = static_cast<uint8_t>(id >> 16);
    *p++ = static_cast<uint8_t>(id >> 8);
    *p++ = static_cast<uint8_t>(id);
    *p++ = static_cast<uint8_t>(f.length | (f.fd ? kFdFlag : 0));
    if (f.fd) *p++ = f.fd_flags;
    if (!f.rtr) {
      std::memcpy(p, f.data.data(), f.length);
      p += f.length;
    }
  }
  return size;
}

bool decode(const uint8_t* packet, std::size_t size, uint8_t& seq, std::vector<Frame>& out, std::string& error) {
  const std::size_t first = out.size();
  const auto fail = [&](std::string why) {
    out.resize(first);
    error = std::move(why);
    return false;
  };
  if (size < kHeaderSize) return fail("packet of " + std::to_string(size) + " bytes: shorter than the 5-byte header");
  if (packet[0] != kVersion) return fail("version " + std::to_string(packet[0]) + ", expected 2");
  if (packet[1] != kOpData) return fail("op code " + std::to_string(packet[1]) + ", expected 0 (data)");
  seq = packet[2];
  const std::size_t count = static_cast<std::size_t>(packet[3]) << 8 | packet[4];
  std::size_t at = kHeaderSize;
  for (std::size_t i = 0; i < count; ++i) {
    const std::string which = "frame " + std::to_string(i + 1) + " of " + std::to_string(count);
    if (at + 5 > size) return fail(which + ": truncated header");
    const uint32_t id = static_cast<uint32_t>(packet[at]) << 24 | static_cast<uint32_t>(packet[at + 1]) << 16 |
                        static_cast<uint32_t>(packet[at + 2]) << 8 | packet[at + 3];
    Frame f = Frame::from_raw_id(id);
    const uint8_t len = packet[at + 4];
    at += 5;
    f.fd = (len & kFdFlag) != 0;
    f.length = static_cast<uint8_t>(len & ~kFdFlag);
    if (f.fd) {
      if (at + 1 > size) return fail(which + ": truncated FD flags");
      f.fd_flags = packet[at++];
      if (f.length > 64) return fail(which + ": FD length " + std::to_string(f.length) + " > 64");
    } else if (f.length > 8) {
      return fail(which + ": classic length " + std::to_string(f.length) + " > 8");
    }
    if (!f.rtr) {
      if (at + f.length > size) return fail(which + ": truncated data");
      std::memcpy(f.data.data(), packet + at, f.length);
      at += f.length;
    }
    out.push_back(f);
  }
  if (at != size) return fail(std::to_string(size - at) + " bytes after the last frame");
  return true;
}

}  // namespace cannelloni

namespace {
int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

std::unique_ptr<UdpTunnel> UdpTunnel::open(const std::string& spec, std::string& error) {
  Options o;
  const auto a = spec.find(':'), b = spec.rfind(':');
  try {
    if (a == std::string::npos || b == a) throw std::invalid_argument("shape");
    std::size_t used = 0;
    o.local_port = std::stoi(spec.substr(0, a), &used);
    if (used != a) throw std::invalid_argument("local port");
    o.peer_host = spec.substr(a + 1, b - a - 1);
    o.peer_port = std::stoi(spec.substr(b + 1), &used);
    if (used != spec.size() - b - 1) throw std::invalid_argument("peer port");
  } catch (const std::exception&) {
    error = "udp bus '" + spec + "': expected LOCAL_PORT:HOST:PORT, e.g. 20000:192.168.1.2:20000";
    return nullptr;
  }
  return open(o, error);
}

std::unique_ptr<UdpTunnel> UdpTunnel::open(const Options& o, std::string& error) {
  const std::string where = "udp bus " + std::to_string(o.local_port) + ":" + o.peer_host + ":" + std::to_string(o.peer_port);
  if (o.local_port < 0 || o.local_port > 65535 || o.peer_port <= 0 || o.peer_port > 65535) {
    error = where + ": ports must be in 1..65535 (local 0: any)";
    return nullptr;
  }
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* peer = nullptr;
  if (int rc = getaddrinfo(o.peer_host.c_str(), std::to_string(o.peer_port).c_str(), &hints, &peer); rc != 0) {
    error = where + ": cannot resolve '" + o.peer_host + "': " + gai_strerror(rc);
    return nullptr;
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    freeaddrinfo(peer);
    error = where + ": socket: " + std::strerror(errno);
    return nullptr;
  }
  sockaddr_in local{};
  local.sin_family = AF_INET;
  local.sin_port = htons(static_cast<uint16_t>(o.local_port));
  local.sin_addr.s_addr = htonl(INADDR_ANY);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) {
    error = where + ": bind to port " + std::to_string(o.local_port) + ": " + std::strerror(errno);
    ::close(fd);
    freeaddrinfo(peer);
    return nullptr;
  }
  std::unique_ptr<UdpTunnel> t(new UdpTunnel(fd, o, peer->ai_addr, peer->ai_addrlen));
  freeaddrinfo(peer);
  return t;
}

UdpTunnel::UdpTunnel(int fd, Options options, const void* peer, std::size_t peer_size)
    : fd_(fd), options_(std::move(options)), peer_size_(std::min(peer_size, sizeof peer_)), rng_(options_.seed) {
  std::memcpy(peer_, peer, peer_size_);
  outgoing_.reserve(64);
  incoming_.reserve(256);
  packet_.reserve(cannelloni::kMaxPacket);
}

UdpTunnel::~UdpTunnel() { ::close(fd_); }

std::string UdpTunnel::describe() const {
  return "udp tunnel " + std::to_string(options_.local_port) + " -> " + options_.peer_host + ":" +
         std::to_string(options_.peer_port);
}

bool UdpTunnel::send(const Frame& f) {
  if (f.length > (f.fd ? 64 : 8)) {
    ++counters_.send_failed;
    return false;
  }
  const std::size_t size = cannelloni::encoded_size(f);
  if (outgoing_bytes_ + size > cannelloni::kMaxPacket) flush();
  outgoing_.push_back(f);
  outgoing_bytes_ += size;
  return true;
}

void UdpTunnel::flush() {
  if (outgoing_.empty()) return;
  const std::size_t n = outgoing_.size();
  cannelloni::encode(seq_out_++, outgoing_.data(), n, packet_);
  outgoing_.clear();
  outgoing_bytes_ = cannelloni::kHeaderSize;
  ++packets_sent_;
  if (options_.loss > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < options_.loss) {
    counters_.dropped += n;
    return;
  }
  const ssize_t sent = ::sendto(fd_, packet_.data(), packet_.size(), 0, reinterpret_cast<const sockaddr*>(peer_),
                                static_cast<socklen_t>(peer_size_));
  if (sent == static_cast<ssize_t>(packet_.size())) {
    counters_.sent += n;
  } else {
    // ENOBUFS / EAGAIN / ECONNREFUSED (nobody listening yet): the cycle's
    // frames are gone; the next cycle sends fresh ones.
    counters_.send_failed += n;
  }
}

bool UdpTunnel::read_packet(int64_t timeout_ns) {
  uint8_t buffer[2048];
  for (;;) {
    const ssize_t got = ::recv(fd_, buffer, sizeof buffer, 0);
    if (got < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) return false;  // e.g. ECONNREFUSED from an earlier send
      if (timeout_ns <= 0) return false;
      pollfd p{fd_, POLLIN, 0};
      const int ms = static_cast<int>((timeout_ns + 999'999) / 1'000'000);
      if (::poll(&p, 1, ms) <= 0) return false;
      timeout_ns = 0;
      continue;
    }
    incoming_.clear();
    incoming_next_ = 0;
    uint8_t seq = 0;
    if (!cannelloni::decode(buffer, static_cast<std::size_t>(got), seq, incoming_, last_error_)) {
      ++counters_.malformed;
      return true;  // read something; the caller looks again
    }
    if (next_seq_in_ >= 0) counters_.lost += static_cast<uint8_t>(seq - next_seq_in_);
    next_seq_in_ = static_cast<uint8_t>(seq + 1);
    const int64_t now = steady_ns();
    for (Frame& f : incoming_) f.timestamp_ns = now;
    return true;
  }
}

bool UdpTunnel::receive(Frame& out, int64_t timeout_ns) {
  const int64_t deadline = steady_ns() + timeout_ns;
  for (;;) {
    while (incoming_next_ < incoming_.size()) {
      const Frame& f = incoming_[incoming_next_++];
      if (!filters_.passes(f)) {
        ++counters_.filtered;
        continue;
      }
      out = f;
      ++counters_.received;
      if (f.error) ++counters_.error_frames;
      return true;
    }
    const int64_t left = timeout_ns > 0 ? deadline - steady_ns() : 0;
    if (!read_packet(left > 0 ? left : 0)) return false;
  }
}

}  // namespace saccade::can
