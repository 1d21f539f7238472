#include "cannelloni.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <openssl/core_names.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/params.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <optional>

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

Status decode(const uint8_t* packet, std::size_t size, uint8_t& seq, std::vector<Frame>& out) {
  const std::size_t first = out.size();
  const auto fail = [&](std::string why) {
    out.resize(first);
    return Status::error(std::move(why));
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
  return {};
}

Key::~Key() { OPENSSL_cleanse(bytes.data(), bytes.size()); }

Status load_key(const std::string& path, Key& key) {
  const std::string what = "key file '" + path + "'";
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) return Status::error(what + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return Status::error(what + ": not a regular file");
  }
  if ((st.st_mode & 077) != 0) {
    ::close(fd);
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return Status::error(what + " can be read or written by its group or others (mode " + mode +
                         "): the link's key must be its owner's alone; chmod 600 '" + path + "'");
  }
  char text[256];
  ssize_t got = 0;
  for (;;) {
    got = ::read(fd, text, sizeof text);
    if (got >= 0 || errno != EINTR) break;
  }
  ::close(fd);
  if (got < 0) return Status::error(what + ": " + std::strerror(errno));
  std::size_t n = static_cast<std::size_t>(got), first = 0;
  while (first < n && std::isspace(static_cast<unsigned char>(text[first]))) ++first;
  while (n > first && std::isspace(static_cast<unsigned char>(text[n - 1]))) --n;
  bool hex = n - first == 2 * key.bytes.size();
  for (std::size_t i = 0; hex && i < key.bytes.size(); ++i) {
    unsigned value = 0;
    for (std::size_t k = 0; k < 2; ++k) {
      const char c = text[first + 2 * i + k];
      const int digit = std::isdigit(static_cast<unsigned char>(c)) ? c - '0'
                        : (c >= 'a' && c <= 'f')                    ? c - 'a' + 10
                        : (c >= 'A' && c <= 'F')                    ? c - 'A' + 10
                                                                    : -1;
      if (digit < 0) hex = false;
      value = value << 4 | static_cast<unsigned>(digit & 0xF);
    }
    key.bytes[i] = static_cast<uint8_t>(value);
  }
  OPENSSL_cleanse(text, sizeof text);
  if (!hex) {
    OPENSSL_cleanse(key.bytes.data(), key.bytes.size());
    return Status::error(what + ": expected 64 hex characters (a 256-bit key, e.g. from: openssl rand -hex 32)");
  }
  return {};
}

namespace {
void put_u64(uint8_t* p, uint64_t v) {
  for (int i = 7; i >= 0; --i, v >>= 8) p[i] = static_cast<uint8_t>(v);
}
uint64_t get_u64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = v << 8 | p[i];
  return v;
}
// What the tag covers before the packet: a label of this format and the two ends.
constexpr char kLabel[] = "saccade cannelloni hmac-sha256 v1";
}  // namespace

Authenticator::Authenticator(const Key& key) {
  EVP_MAC* mac = EVP_MAC_fetch(nullptr, "HMAC", nullptr);
  if (mac == nullptr) return;
  ctx_ = EVP_MAC_CTX_new(mac);
  EVP_MAC_free(mac);
  if (ctx_ == nullptr) return;
  char digest[] = "SHA256";
  const OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string(OSSL_MAC_PARAM_DIGEST, digest, 0),
                               OSSL_PARAM_construct_end()};
  if (EVP_MAC_init(ctx_, key.bytes.data(), key.bytes.size(), params) != 1) {
    EVP_MAC_CTX_free(ctx_);
    ctx_ = nullptr;
  }
}

Authenticator::~Authenticator() { EVP_MAC_CTX_free(ctx_); }

bool Authenticator::tag(const uint8_t* data, std::size_t size, const LinkEnds& ends, uint8_t (&out)[32]) {
  uint8_t link[12];
  std::memcpy(link, &ends.from_addr, 4);
  std::memcpy(link + 4, &ends.from_port, 2);
  std::memcpy(link + 6, &ends.to_addr, 4);
  std::memcpy(link + 10, &ends.to_port, 2);
  std::size_t length = 0;
  // EVP_MAC_init without a key starts a new message with the key already set.
  return ctx_ != nullptr && EVP_MAC_init(ctx_, nullptr, 0, nullptr) == 1 &&
         EVP_MAC_update(ctx_, reinterpret_cast<const unsigned char*>(kLabel), sizeof kLabel) == 1 &&
         EVP_MAC_update(ctx_, link, sizeof link) == 1 && EVP_MAC_update(ctx_, data, size) == 1 &&
         EVP_MAC_final(ctx_, out, &length, sizeof out) == 1 && length == sizeof out;
}

void Authenticator::seal(std::vector<uint8_t>& packet, uint64_t epoch, uint64_t counter, const LinkEnds& ends) {
  const std::size_t at = packet.size();
  packet.resize(at + kTrailerSize);
  put_u64(packet.data() + at, epoch);
  put_u64(packet.data() + at + 8, counter);
  uint8_t mac[32];
  if (!tag(packet.data(), at + 16, ends, mac)) std::memset(mac, 0, sizeof mac);  // never authentic
  std::memcpy(packet.data() + at + 16, mac, kTagSize);
}

bool Authenticator::open(const uint8_t* packet, std::size_t size, const LinkEnds& ends, std::size_t& payload_size,
                         uint64_t& epoch, uint64_t& counter) {
  if (size < kHeaderSize + kTrailerSize) return false;
  const std::size_t signed_size = size - kTagSize;
  uint8_t mac[32];
  if (!tag(packet, signed_size, ends, mac) || CRYPTO_memcmp(mac, packet + signed_size, kTagSize) != 0) return false;
  payload_size = size - kTrailerSize;
  epoch = get_u64(packet + payload_size);
  counter = get_u64(packet + payload_size + 8);
  return true;
}

ReplayWindow::Verdict ReplayWindow::accept(uint64_t epoch, uint64_t counter, uint64_t& gap, bool& late) {
  gap = 0;
  late = false;
  if (!started_ || epoch > epoch_) {
    const bool first = !started_;
    started_ = true;
    epoch_ = epoch;
    highest_ = counter;
    seen_ = 1;
    return first ? Verdict::kNew : Verdict::kNewSession;
  }
  if (epoch < epoch_) return Verdict::kStaleSession;
  if (counter > highest_) {
    const uint64_t ahead = counter - highest_;
    seen_ = ahead >= kSize ? 1 : seen_ << ahead | 1;
    gap = ahead - 1;
    highest_ = counter;
    return Verdict::kNew;
  }
  const uint64_t behind = highest_ - counter;
  if (behind >= kSize) return Verdict::kReplayed;
  const uint64_t bit = uint64_t{1} << behind;
  if ((seen_ & bit) != 0) return Verdict::kReplayed;
  seen_ |= bit;
  late = true;
  return Verdict::kNew;
}

}  // namespace cannelloni

namespace {
int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::string to_string(const sockaddr_in& a) {
  char text[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &a.sin_addr, text, sizeof text);
  return std::string(text) + ":" + std::to_string(ntohs(a.sin_port));
}

bool is_loopback(const in_addr& a) { return (ntohl(a.s_addr) >> 24) == 127; }

// The local address the kernel would send to `peer` from (a connected UDP
// socket's own address; nothing is sent), or why there is none.
Result<in_addr> route_source(const sockaddr_in& peer) {
  const int probe = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (probe < 0) return Status::error(std::string("socket: ") + std::strerror(errno));
  sockaddr_in self{};
  socklen_t size = sizeof self;
  const bool ok = ::connect(probe, reinterpret_cast<const sockaddr*>(&peer), sizeof peer) == 0 &&
                  ::getsockname(probe, reinterpret_cast<sockaddr*>(&self), &size) == 0;
  const int failure = errno;  // before close() can change it
  ::close(probe);
  if (!ok) return Status::error(std::strerror(failure));
  return self.sin_addr;
}

Result<sockaddr_in> resolve(const std::string& host, int port) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  if (int rc = getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found); rc != 0)
    return Status::error("cannot resolve '" + host + "': " + gai_strerror(rc));
  sockaddr_in out{};
  std::memcpy(&out, found->ai_addr, sizeof out);
  freeaddrinfo(found);
  return out;
}

// `text` as a whole int, read as std::stoi reads it; nothing when it is not one.
std::optional<int> whole_int(const std::string& text) {
  try {
    std::size_t used = 0;
    const int value = std::stoi(text, &used);
    if (used == text.size()) return value;
  } catch (const std::exception&) {  // std::stoi's way of saying "not a number" or "out of range"
  }
  return std::nullopt;
}
}  // namespace

Result<std::unique_ptr<UdpTunnel>> UdpTunnel::open(const std::string& spec, const cannelloni::Key* key) {
  const Status malformed = Status::error("udp bus '" + spec +
                                         "': expected [BIND_ADDR:]LOCAL_PORT:HOST:PORT, e.g. 20000:192.168.1.2:20000 "
                                         "or 192.168.1.1:20000:192.168.1.2:20000");
  Options o;
  Link link;
  link.key = key;
  std::vector<std::string> parts;
  for (std::size_t at = 0;;) {
    const auto colon = spec.find(':', at);
    parts.push_back(spec.substr(at, colon == std::string::npos ? std::string::npos : colon - at));
    if (colon == std::string::npos) break;
    at = colon + 1;
  }
  if (parts.size() != 3 && parts.size() != 4) return malformed;
  if (parts.size() == 4) {
    link.bind_address = parts[0];
    parts.erase(parts.begin());
    if (link.bind_address.empty()) return malformed;
  }
  const std::optional<int> local_port = whole_int(parts[0]);
  o.peer_host = parts[1];
  const std::optional<int> peer_port = whole_int(parts[2]);
  if (!local_port || o.peer_host.empty() || !peer_port) return malformed;
  o.local_port = *local_port;
  o.peer_port = *peer_port;
  return open(o, link);
}

Result<std::unique_ptr<UdpTunnel>> UdpTunnel::open(const Options& o) { return open(o, Link{}); }

Result<std::unique_ptr<UdpTunnel>> UdpTunnel::open(const Options& o, const Link& link) {
  const std::string where = "udp bus " + (link.bind_address.empty() ? "" : link.bind_address + ":") +
                            std::to_string(o.local_port) + ":" + o.peer_host + ":" + std::to_string(o.peer_port);
  if (o.local_port < 0 || o.local_port > 65535 || o.peer_port <= 0 || o.peer_port > 65535)
    return Status::error(where + ": ports must be in 1..65535 (local 0: any)");
  const Result<sockaddr_in> peer = resolve(o.peer_host, o.peer_port);
  if (!peer.ok()) return Status::error(where + ": " + peer.error());
  if (peer->sin_addr.s_addr == htonl(INADDR_ANY) || peer->sin_addr.s_addr == htonl(INADDR_BROADCAST))
    return Status::error(where + ": the peer must be one host's address, not " + o.peer_host);
  sockaddr_in local{};
  local.sin_family = AF_INET;
  local.sin_port = htons(static_cast<uint16_t>(o.local_port));
  if (!link.bind_address.empty()) {
    const Result<sockaddr_in> bind_to = resolve(link.bind_address, o.local_port);
    if (!bind_to.ok()) return Status::error(where + ": bind address: " + bind_to.error());
    local = *bind_to;
    if (link.key != nullptr && local.sin_addr.s_addr == htonl(INADDR_ANY))
      return Status::error(where +
                           ": an authenticated tunnel binds one address, not 0.0.0.0 (its tag covers both ends' "
                           "addresses)");
  } else if (is_loopback(peer->sin_addr)) {
    local.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  } else {
    const Result<in_addr> source = route_source(*peer);
    if (!source.ok())
      return Status::error(where + ": no route to " + o.peer_host + " (" + source.error() +
                           "); name the local address: udp:ADDR:" + std::to_string(o.local_port) + ":" + o.peer_host +
                           ":" + std::to_string(o.peer_port));
    local.sin_addr = *source;
  }
  std::unique_ptr<cannelloni::Authenticator> auth;
  if (link.key != nullptr) {
    auth = std::make_unique<cannelloni::Authenticator>(*link.key);
    if (!auth->ok()) return Status::error(where + ": OpenSSL has no HMAC-SHA256");
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return Status::error(where + ": socket: " + std::strerror(errno));
  socklen_t size = sizeof local;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&local), sizeof local) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &size) != 0) {
    const int failure = errno;  // before close() can change it
    ::close(fd);
    return Status::error(where + ": bind to " + to_string(local) + ": " + std::strerror(failure));
  }
  std::unique_ptr<UdpTunnel> t(new UdpTunnel(fd, o, local, peer.value()));
  t->auth_ = std::move(auth);
  return t;
}

UdpTunnel::UdpTunnel(int fd, Options options, const sockaddr_in& local, const sockaddr_in& peer)
    : fd_(fd),
      options_(std::move(options)),
      local_(local),
      peer_(peer),
      faults_(cannelloni::Faults{options_.loss, 0, 0, 0, options_.seed}) {
  // This end's session: its start time on the wall clock, so that a restarted
  // sender's packets are newer than every packet of its previous run.
  epoch_ = static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
  outgoing_.reserve(64);
  incoming_.reserve(256);
  packet_.reserve(cannelloni::kMaxPacket);
}

UdpTunnel::~UdpTunnel() { ::close(fd_); }

std::string UdpTunnel::local_address() const { return to_string(local_); }

std::string UdpTunnel::describe() const {
  return "udp tunnel " + to_string(local_) + " -> " + options_.peer_host + ":" + std::to_string(options_.peer_port) +
         (auth_ ? " (authenticated)" : "");
}

bool UdpTunnel::send(const Frame& f) {
  if (f.length > (f.fd ? 64 : 8)) {
    ++counters_.send_failed;
    return false;
  }
  const std::size_t size = cannelloni::encoded_size(f);
  const std::size_t room = cannelloni::kMaxPacket - (auth_ ? cannelloni::kTrailerSize : 0);
  if (outgoing_bytes_ + size > room) flush();
  outgoing_.push_back(f);
  outgoing_bytes_ += size;
  return true;
}

void UdpTunnel::flush() {
  if (outgoing_.empty()) return;
  const std::size_t n = outgoing_.size();
  cannelloni::encode(seq_out_++, outgoing_.data(), n, packet_);
  if (auth_)
    auth_->seal(packet_, epoch_, ++counter_out_,
                {local_.sin_addr.s_addr, peer_.sin_addr.s_addr, local_.sin_port, peer_.sin_port});
  outgoing_.clear();
  outgoing_bytes_ = cannelloni::kHeaderSize;
  ++packets_sent_;
  faults_.pass(packet_, n, counters_, [&](const std::vector<uint8_t>& bytes, std::size_t frames) {
    const ssize_t sent =
        ::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&peer_), sizeof peer_);
    if (sent == static_cast<ssize_t>(bytes.size())) {
      counters_.sent += frames;
    } else {
      // ENOBUFS / EAGAIN / ECONNREFUSED (nobody listening yet): the cycle's
      // frames are gone; the next cycle sends fresh ones.
      counters_.send_failed += frames;
    }
  });
}

std::size_t UdpTunnel::check_sealed(const uint8_t* packet, std::size_t size) {
  std::size_t payload = 0;
  uint64_t epoch = 0, counter = 0;
  if (!auth_->open(packet, size, {peer_.sin_addr.s_addr, local_.sin_addr.s_addr, peer_.sin_port, local_.sin_port},
                   payload, epoch, counter)) {
    ++counters_.unauthenticated;
    return 0;
  }
  uint64_t gap = 0;
  bool late = false;
  switch (window_.accept(epoch, counter, gap, late)) {
    case cannelloni::ReplayWindow::Verdict::kReplayed:
    case cannelloni::ReplayWindow::Verdict::kStaleSession: ++counters_.replayed; return 0;
    case cannelloni::ReplayWindow::Verdict::kNewSession:
    case cannelloni::ReplayWindow::Verdict::kNew: break;
  }
  counters_.lost += gap;
  if (late && counters_.lost > 0) --counters_.lost;  // counted lost when its successor came
  return payload;
}

bool UdpTunnel::read_packet(int64_t timeout_ns) {
  uint8_t buffer[2048];
  for (;;) {
    sockaddr_in from{};
    socklen_t from_size = sizeof from;
    const ssize_t got = ::recvfrom(fd_, buffer, sizeof buffer, 0, reinterpret_cast<sockaddr*>(&from), &from_size);
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
    if (from_size != sizeof from || from.sin_family != AF_INET || from.sin_addr.s_addr != peer_.sin_addr.s_addr ||
        from.sin_port != peer_.sin_port) {
      ++counters_.foreign;
      return true;  // read something; the caller looks again
    }
    std::size_t size = static_cast<std::size_t>(got);
    if (auth_ && (size = check_sealed(buffer, size)) == 0) return true;
    uint8_t seq = 0;
    if (Status decoded = cannelloni::decode(buffer, size, seq, incoming_); !decoded.ok()) {
      last_error_ = decoded.message();
      ++counters_.malformed;
      return true;
    }
    // Keyed, the counter told what was lost; else the 8-bit sequence does. A
    // packet behind the newest (a duplicate, or one overtaken) is no gap: its
    // frames are delivered as they are (cannelloni has no duplicate check).
    if (auth_ || next_seq_in_ < 0) {
      next_seq_in_ = static_cast<uint8_t>(seq + 1);
    } else if (const auto ahead = static_cast<uint8_t>(seq - next_seq_in_); ahead < 128) {
      counters_.lost += ahead;
      next_seq_in_ = static_cast<uint8_t>(seq + 1);
    }
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
