// CAN frames and filters with the kernel's semantics, the virtual bus with
// its fault injection, the cannelloni codec against the golden vector from
// cannelloni's own encoder, the UDP tunnel on 127.0.0.1 (its bind address,
// its peer check and its authenticated form), and SocketCAN where the kernel
// has it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "bus.hpp"
#include "cannelloni.hpp"
#include "drive_sim.hpp"
#include "socketcan.hpp"
#include "support.hpp"
#include "saccade/message.hpp"
#include "saccade/stats.hpp"
#include "virtual_bus.hpp"

namespace saccade::can {
namespace {

// What an open that must succeed made; on an error, the test fails with it
// and this is empty (nullptr).
template <class T>
T opened(Result<T> result) {
  if (!result.ok()) {
    ADD_FAILURE() << result.error();
    return T();
  }
  return std::move(result).value();
}

Frame data_frame(uint32_t id, std::initializer_list<uint8_t> bytes, bool extended = false) {
  Frame f;
  f.id = id;
  f.extended = extended;
  f.length = static_cast<uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  return f;
}

TEST(CanFrame, RawIdCarriesTheKernelsFlags) {
  Frame f = data_frame(0x12345, {}, true);
  f.rtr = true;
  EXPECT_EQ(f.raw_id(), 0xC0012345u);
  const Frame back = Frame::from_raw_id(0xC0012345u);
  EXPECT_TRUE(back.extended && back.rtr && !back.error);
  EXPECT_EQ(back.id, 0x12345u);
  EXPECT_EQ(Frame::from_raw_id(0x601).id, 0x601u);
  EXPECT_EQ(to_string(data_frame(0x601, {0x40, 0x64})), "601 [2] 40 64");
  EXPECT_EQ(frame_bits(data_frame(0x80, {})), 47);
  EXPECT_EQ(frame_bits(data_frame(0x181, {1, 2, 3, 4, 5, 6, 7, 8})), 111);
}

TEST(CanFilter, TruthTableOfTheKernelsSemantics) {
  const Frame sff = data_frame(0x181, {1});
  const Frame sff_other = data_frame(0x182, {1});
  const Frame eff_same_low_bits = data_frame(0x181, {1}, true);
  Frame rtr = data_frame(0x181, {});
  rtr.rtr = true;
  struct Row {
    Filter filter;
    bool sff, other, eff, rtr;
  };
  const Row rows[] = {
      {{0, 0}, true, true, true, true},                                      // the default: everything
      {{0x181, kSffMask}, true, false, true, true},                          // id only: extended 0x181 matches too
      {Filter::exact(0x181), true, false, false, true},                      // standard format only
      {{0x181, kSffMask | kEffFlag | kRtrFlag}, true, false, false, false},  // data frames only
      {{0x180, 0x7F0}, true, true, true, true},                              // a range: 0x180..0x18F
      {{0x181 | kInvFilter, kSffMask}, false, true, false, false},           // inverted
      {{0x181 | kEffFlag, kEffMask | kEffFlag}, false, false, true, false},  // extended 0x181 only
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(::testing::Message() << std::hex << "filter id " << r.filter.id << " mask " << r.filter.mask);
    EXPECT_EQ(r.filter.matches(sff), r.sff);
    EXPECT_EQ(r.filter.matches(sff_other), r.other);
    EXPECT_EQ(r.filter.matches(eff_same_low_bits), r.eff);
    EXPECT_EQ(r.filter.matches(rtr), r.rtr);
  }
}

TEST(CanFilter, SetsJoinAndErrorMask) {
  FilterSet any;
  any.filters = {Filter::exact(0x181), Filter::exact(0x281)};
  EXPECT_TRUE(any.passes(data_frame(0x281, {})));
  EXPECT_FALSE(any.passes(data_frame(0x381, {})));
  FilterSet join = any;
  join.join = true;
  EXPECT_FALSE(join.passes(data_frame(0x181, {}))) << "joined: every filter must match";
  join.filters = {{0x180, 0x780}, {0x001, 0x07F}};
  EXPECT_TRUE(join.passes(data_frame(0x181, {})));
  EXPECT_FALSE(join.passes(data_frame(0x182, {})));
  FilterSet none;
  none.filters.clear();
  EXPECT_FALSE(none.passes(data_frame(0x181, {}))) << "no filters: no data frames";
  Frame busoff;
  busoff.error = true;
  busoff.id = error_class::kBusOff;
  EXPECT_FALSE(any.passes(busoff)) << "error frames need the error mask";
  any.error_mask = error_class::kBusOff;
  EXPECT_TRUE(any.passes(busoff));
}

TEST(VirtualBus, DeliversToEveryOtherPortThroughItsFilters) {
  auto bus = VirtualBus::create();
  auto a = bus->attach(), b = bus->attach(), c = bus->attach();
  FilterSet only_181;
  only_181.filters = {Filter::exact(0x181)};
  c->set_filters(only_181);
  ASSERT_TRUE(a->send(data_frame(0x181, {7})));
  ASSERT_TRUE(a->send(data_frame(0x281, {8})));
  Frame f;
  EXPECT_FALSE(a->receive(f, 0)) << "a port does not hear itself";
  ASSERT_TRUE(b->receive(f, 0));
  EXPECT_EQ(f, data_frame(0x181, {7}));
  ASSERT_TRUE(b->receive(f, 0));
  EXPECT_EQ(f.id, 0x281u);
  ASSERT_TRUE(c->receive(f, 0));
  EXPECT_EQ(f.id, 0x181u);
  EXPECT_FALSE(c->receive(f, 0));
  EXPECT_EQ(c->counters().filtered, 1u);
  EXPECT_EQ(a->counters().sent, 2u);
}

TEST(VirtualBus, DelaysOnTheSimulatedClockAndDropsWithASeed) {
  auto bus = VirtualBus::create();
  bus->set_time(1'000'000);
  bus->set_faults({0.0, 500'000, 1});
  auto a = bus->attach(), b = bus->attach();
  a->send(data_frame(0x100, {}));
  Frame f;
  EXPECT_FALSE(b->receive(f, 0)) << "not before its delay";
  bus->set_time(1'499'999);
  EXPECT_FALSE(b->receive(f, 0));
  bus->set_time(1'500'000);
  ASSERT_TRUE(b->receive(f, 0));
  EXPECT_EQ(f.timestamp_ns, 1'500'000);

  bus->set_faults({0.3, 0, 42});
  int arrived = 0;
  for (int i = 0; i < 2000; ++i) {
    a->send(data_frame(0x100, {}));
    arrived += b->receive(f, 0) ? 1 : 0;
  }
  EXPECT_NEAR(arrived / 2000.0, 0.7, 0.04);
  EXPECT_EQ(a->counters().dropped, 2000u - static_cast<unsigned>(arrived));
}

TEST(VirtualBus, FramesSentBeforeSimulatedTimeStartsAreDueAtOnce) {
  // Nodes of a real-time graph start on the steady clock; the driver then sets
  // simulated time, which must not strand what was already sent.
  auto bus = VirtualBus::create();
  auto a = bus->attach(), b = bus->attach();
  a->send(data_frame(0x701, {0x00}));
  bus->set_time(0);
  Frame f;
  ASSERT_TRUE(b->receive(f, 0));
  EXPECT_EQ(f.id, 0x701u);
}

TEST(VirtualBus, BusOffAndErrorPassiveReportErrorFrames) {
  auto bus = VirtualBus::create();
  auto a = bus->attach(), b = bus->attach();
  FilterSet with_errors;
  with_errors.error_mask = error_class::kAll;
  a->set_filters(with_errors);
  a->inject_state(BusState::kErrorPassive);
  Frame f;
  ASSERT_TRUE(a->receive(f, 0));
  EXPECT_TRUE(f.error);
  EXPECT_EQ(f.id, error_class::kController);
  EXPECT_EQ(f.data[1], controller_status::kRxPassive | controller_status::kTxPassive);
  EXPECT_TRUE(a->send(data_frame(0x100, {}))) << "error passive still sends";
  EXPECT_TRUE(b->receive(f, 0));
  a->inject_state(BusState::kBusOff);
  ASSERT_TRUE(a->receive(f, 0));
  EXPECT_EQ(f.id, error_class::kBusOff);
  EXPECT_EQ(a->state(), BusState::kBusOff);
  EXPECT_FALSE(a->send(data_frame(0x100, {})));
  EXPECT_EQ(a->counters().send_failed, 1u);
  b->send(data_frame(0x200, {}));
  EXPECT_FALSE(a->receive(f, 0)) << "a bus-off controller hears nothing";
  a->inject_state(BusState::kErrorActive);
  ASSERT_TRUE(a->receive(f, 0));
  EXPECT_TRUE(f.id & error_class::kRestarted);
  EXPECT_TRUE(a->send(data_frame(0x100, {})));
  EXPECT_EQ(b->counters().error_frames, 0u) << "b asked for no error frames";
}

// Captured from cannelloni's encoder: sequence 7, an SDO upload request, an
// extended remote frame and an FD frame with bit-rate switch.
const std::vector<uint8_t> kGolden = {0x02, 0x00, 0x07, 0x00, 0x03,                                   //
                                      0x00, 0x00, 0x06, 0x01, 0x08, 0x40, 0x64, 0x60, 0, 0, 0, 0, 0,  //
                                      0xC0, 0x01, 0x23, 0x45, 0x04,                                   //
                                      0x00, 0x00, 0x01, 0x81, 0x82, 0x01, 0xAA, 0xBB};

std::vector<Frame> golden_frames() {
  Frame sdo = data_frame(0x601, {0x40, 0x64, 0x60, 0, 0, 0, 0, 0});
  Frame remote;
  remote.id = 0x12345;
  remote.extended = remote.rtr = true;
  remote.length = 4;
  Frame fd = data_frame(0x181, {0xAA, 0xBB});
  fd.fd = true;
  fd.fd_flags = 0x01;
  return {sdo, remote, fd};
}

TEST(Cannelloni, EncodesTheGoldenVector) {
  const auto frames = golden_frames();
  std::vector<uint8_t> packet;
  EXPECT_EQ(cannelloni::encode(7, frames.data(), frames.size(), packet), kGolden.size());
  EXPECT_EQ(packet, kGolden);
}

TEST(Cannelloni, DecodesTheGoldenVector) {
  std::vector<Frame> frames;
  uint8_t seq = 0;
  const Status decoded = cannelloni::decode(kGolden.data(), kGolden.size(), seq, frames);
  ASSERT_TRUE(decoded.ok()) << decoded.message();
  EXPECT_EQ(seq, 7);
  ASSERT_EQ(frames.size(), 3u);
  const auto want = golden_frames();
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(frames[i], want[i]) << to_string(frames[i]);
}

TEST(Cannelloni, RejectsMalformedPacketsWithTheReason) {
  struct Case {
    const char* what;
    std::vector<uint8_t> bytes;
    const char* reason;
  };
  std::vector<uint8_t> truncated(kGolden.begin(), kGolden.end() - 1);
  std::vector<uint8_t> trailing = kGolden;
  trailing.push_back(0);
  const std::vector<Case> cases = {
      {"short", {0x02, 0x00}, "shorter than the 5-byte header"},
      {"version 1", {0x01, 0x00, 0x00, 0x00, 0x00}, "version 1, expected 2"},
      {"op code", {0x02, 0x01, 0x00, 0x00, 0x00}, "op code 1"},
      {"truncated data", truncated, "frame 3 of 3: truncated data"},
      {"trailing bytes", trailing, "1 bytes after the last frame"},
      {"count beyond the data",
       {0x02, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x01, 0x00, 0x00},
       "frame 2 of 2: truncated header"},
      {"classic len 9",
       {0x02, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x01, 0x00, 0x09, 1, 2, 3, 4, 5, 6, 7, 8, 9},
       "classic length 9 > 8"},
      {"FD len 65", {0x02, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x01, 0x00, 0x80 | 65, 0x00}, "FD length 65 > 64"},
  };
  for (const Case& c : cases) {
    std::vector<Frame> frames = {Frame{}};
    uint8_t seq = 0;
    const Status decoded = cannelloni::decode(c.bytes.data(), c.bytes.size(), seq, frames);
    EXPECT_FALSE(decoded.ok()) << c.what;
    EXPECT_THAT(decoded.message(), ::testing::HasSubstr(c.reason)) << c.what;
    EXPECT_EQ(frames.size(), 1u) << c.what << ": nothing appended";
  }
  // 64 bytes is a valid FD frame.
  std::vector<uint8_t> fd64 = {0x02, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x01, 0x00, 0x80 | 64, 0x00};
  fd64.resize(fd64.size() + 64, 0x55);
  std::vector<Frame> frames;
  uint8_t seq = 0;
  const Status decoded = cannelloni::decode(fd64.data(), fd64.size(), seq, frames);
  EXPECT_TRUE(decoded.ok()) << decoded.message();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_TRUE(frames[0].fd);
  EXPECT_EQ(frames[0].length, 64);
  EXPECT_EQ(frames[0].data[63], 0x55);
}

TEST(UdpTunnel, CarriesFramesBothWaysPacksACycleAndCountsLoss) {
  const auto [pa, pb] = test::free_udp_ports();
  auto a = opened(UdpTunnel::open(std::to_string(pa) + ":127.0.0.1:" + std::to_string(pb)));
  ASSERT_TRUE(a);
  auto b = opened(UdpTunnel::open(std::to_string(pb) + ":localhost:" + std::to_string(pa)));
  ASSERT_TRUE(b);
  for (const Frame& f : golden_frames()) a->send(f);
  a->flush();
  EXPECT_EQ(a->packets_sent(), 1u) << "one packet per flush";
  Frame f;
  for (const Frame& want : golden_frames()) {
    ASSERT_TRUE(b->receive(f, 200'000'000));
    EXPECT_EQ(f, want);
  }
  b->send(data_frame(0x181, {1, 2}));
  b->flush();
  ASSERT_TRUE(a->receive(f, 200'000'000));
  EXPECT_EQ(f, data_frame(0x181, {1, 2}));

  // Loss: every packet the sender throws away shows as a sequence gap.
  a->set_loss(0.25, 3);
  int got = 0;
  for (int i = 0; i < 400; ++i) {
    a->send(data_frame(0x100, {static_cast<uint8_t>(i)}));
    a->flush();
    if (i % 20 == 19)  // read as we go: a socket buffer holds only so many packets
      while (b->receive(f, 5'000'000)) ++got;
  }
  a->set_loss(0, 3);
  a->send(data_frame(0x7FF, {}));
  a->flush();
  for (;;) {
    ASSERT_TRUE(b->receive(f, 200'000'000));
    if (f.id == 0x7FF) break;
    ++got;
  }
  EXPECT_EQ(static_cast<uint64_t>(got), a->counters().sent - 4);
  EXPECT_EQ(b->counters().lost, a->counters().dropped) << "each lost packet held one frame";
  EXPECT_NEAR(got / 400.0, 0.75, 0.07);

  // A packet from another port than the peer's is counted, not delivered.
  const int raw = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<uint16_t>(pb));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::vector<uint8_t> packet;
  const Frame frame = data_frame(0x181, {1});
  cannelloni::encode(0, &frame, 1, packet);
  ::sendto(raw, packet.data(), packet.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
  ::close(raw);
  EXPECT_FALSE(b->receive(f, 100'000'000));
  EXPECT_EQ(b->counters().foreign, 1u);
  EXPECT_EQ(b->counters().malformed, 0u);
}

// The fault suite's packet faults (cannelloni::FaultyLink): each fault at its
// rate, counted in frames, a held-back packet sent after the next one, the
// same seed the same wire.
TEST(UdpTunnel, FaultInjectionDropsDuplicatesReordersAndCorruptsPackets) {
  auto wire_of = [](uint64_t seed, BusCounters& c) {
    cannelloni::FaultyLink link({0.1, 0.1, 0.1, 0.1, seed});
    std::vector<std::vector<uint8_t>> wire;
    for (int i = 0; i < 2000; ++i)
      link.pass({static_cast<uint8_t>(i & 0xFF), static_cast<uint8_t>(i >> 8), 0x55}, 2, c,
                [&](const std::vector<uint8_t>& p, std::size_t frames) {
                  EXPECT_EQ(frames, 2u);
                  wire.push_back(p);
                });
    return wire;
  };
  BusCounters c;
  const auto wire = wire_of(7, c);
  for (uint64_t n : {c.dropped, c.duplicated, c.reordered, c.corrupted}) {
    EXPECT_GT(n, 2u * 120) << "about 10% of 2000 packets, 2 frames each";
    EXPECT_LT(n, 2u * 280);
  }
  // A held packet goes after the next one; the last may stay held.
  const std::size_t sent = 2000 - c.dropped / 2 + c.duplicated / 2;
  EXPECT_TRUE(wire.size() == sent || wire.size() == sent - 1) << wire.size() << " packets, expected " << sent;
  int late = 0, twice = 0, altered = 0;
  for (std::size_t i = 1; i < wire.size(); ++i) {
    const int a = wire[i - 1][0] | wire[i - 1][1] << 8, b = wire[i][0] | wire[i][1] << 8;
    late += b < a;
    twice += wire[i] == wire[i - 1];
  }
  for (const auto& p : wire) altered += p[2] != 0x55;
  EXPECT_GT(late, 100);
  EXPECT_GT(twice, 100);
  EXPECT_GT(altered, 50) << "a third of the corruptions hit the third byte";
  BusCounters again;
  EXPECT_EQ(wire_of(7, again), wire) << "the same seed, the same wire";
}

TEST(UdpTunnel, BadSpecsSayWhatWasExpected) {
  for (const char* spec : {"20000", "1:2:3:4:5", ":20000:127.0.0.1:20001", "20000::20001", "x:127.0.0.1:20001"}) {
    const auto tunnel = UdpTunnel::open(spec);
    EXPECT_FALSE(tunnel.ok()) << spec;
    EXPECT_THAT(tunnel.error(), ::testing::HasSubstr("expected [BIND_ADDR:]LOCAL_PORT:HOST:PORT")) << spec;
  }
  const auto serial = open_bus("serial:/dev/ttyS0");
  EXPECT_FALSE(serial.ok());
  EXPECT_THAT(serial.error(),
              ::testing::HasSubstr("expected virtual:NAME, udp:[BIND_ADDR:]LOCAL_PORT:HOST:PORT or socketcan:IFNAME"));
  const auto unresolved = UdpTunnel::open("0:no.such.host.invalid:20001");
  EXPECT_FALSE(unresolved.ok());
  EXPECT_THAT(unresolved.error(), ::testing::HasSubstr("cannot resolve"));
  const auto unresolved_bind = UdpTunnel::open("no.such.host.invalid:0:127.0.0.1:20001");
  EXPECT_FALSE(unresolved_bind.ok());
  EXPECT_THAT(unresolved_bind.error(), ::testing::HasSubstr("bind address: cannot resolve"));
  const auto any_peer = UdpTunnel::open("0:0.0.0.0:20001");
  EXPECT_FALSE(any_peer.ok());
  EXPECT_THAT(any_peer.error(), ::testing::HasSubstr("the peer must be one host's address"));
}

// A plain UDP socket on a loopback address standing in for the tunnel's peer,
// or for an intruder.
struct RawEnd {
  int fd = -1;
  sockaddr_in self{};
  explicit RawEnd(int port, const char* address = "127.0.0.1") {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    self.sin_family = AF_INET;
    self.sin_port = htons(static_cast<uint16_t>(port));
    ::inet_pton(AF_INET, address, &self.sin_addr);
    socklen_t size = sizeof self;
    if (::bind(fd, reinterpret_cast<sockaddr*>(&self), sizeof self) != 0 ||
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&self), &size) != 0)
      ADD_FAILURE() << "bind " << address << ":" << port << ": " << std::strerror(errno);
  }
  ~RawEnd() { ::close(fd); }
  RawEnd(const RawEnd&) = delete;
  RawEnd& operator=(const RawEnd&) = delete;
  int port() const { return ntohs(self.sin_port); }
  void send_to(int port, const std::vector<uint8_t>& bytes) const {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(port));
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to),
              static_cast<ssize_t>(bytes.size()));
  }
  // One packet, waiting up to 200 ms; empty when none came.
  std::vector<uint8_t> receive() const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) return {};
    std::vector<uint8_t> bytes(2048);
    const ssize_t got = ::recv(fd, bytes.data(), bytes.size(), 0);
    bytes.resize(got > 0 ? static_cast<std::size_t>(got) : 0);
    return bytes;
  }
};

// A cannelloni packet of one frame, id 0x180 + `n`.
std::vector<uint8_t> plain_packet(uint8_t n) {
  const Frame f = data_frame(0x180 + n, {n});
  std::vector<uint8_t> packet;
  cannelloni::encode(n, &f, 1, packet);
  return packet;
}

cannelloni::Key test_key(uint8_t first) {
  cannelloni::Key key;
  for (std::size_t i = 0; i < key.bytes.size(); ++i) key.bytes[i] = static_cast<uint8_t>(first + i);
  return key;
}

// The tag's view of a link from `from` to the tunnel on 127.0.0.1:`to_port`.
cannelloni::LinkEnds ends(const RawEnd& from, int to_port) {
  return {.from_addr = from.self.sin_addr.s_addr,
          .to_addr = htonl(INADDR_LOOPBACK),
          .from_port = from.self.sin_port,
          .to_port = htons(static_cast<uint16_t>(to_port))};
}

// The id of the next frame `t` delivers within 100 ms; -1 when none.
int next_id(UdpTunnel& t) {
  Frame f;
  return t.receive(f, 100'000'000) ? static_cast<int>(f.id) : -1;
}

TEST(UdpTunnel, BindsLoopbackForALoopbackPeerOrTheAddressGiven) {
  const auto [pa, pb] = test::free_udp_ports();
  auto a = opened(UdpTunnel::open(std::to_string(pa) + ":localhost:" + std::to_string(pb)));
  ASSERT_TRUE(a);
  EXPECT_EQ(a->local_address(), "127.0.0.1:" + std::to_string(pa)) << "loopback, not every interface";
  a.reset();
  // Any 127.x address is this host's loopback on Linux: the tunnel listens there alone.
  auto b = opened(UdpTunnel::open("127.0.0.2:" + std::to_string(pa) + ":127.0.0.1:" + std::to_string(pb)));
  ASSERT_TRUE(b);
  EXPECT_EQ(b->local_address(), "127.0.0.2:" + std::to_string(pa));
  EXPECT_THAT(b->describe(), ::testing::HasSubstr("127.0.0.2:" + std::to_string(pa)));
  // So the same port on 127.0.0.1 is still free.
  auto c = opened(UdpTunnel::open(std::to_string(pa) + ":127.0.0.1:" + std::to_string(pb)));
  EXPECT_TRUE(c);
  // An address of no interface of this host cannot be bound.
  const auto elsewhere = UdpTunnel::open("192.0.2.1:" + std::to_string(pb) + ":127.0.0.1:" + std::to_string(pa));
  EXPECT_FALSE(elsewhere.ok());
  EXPECT_THAT(elsewhere.error(), ::testing::HasSubstr("bind to 192.0.2.1:" + std::to_string(pb)));
}

TEST(UdpTunnel, PacketsFromAnyoneButThePeerAreDroppedAndCounted) {
  const auto [pt, pr] = test::free_udp_ports();
  RawEnd peer(pr), intruder(0), other_address(pr, "127.0.0.2");
  auto t = opened(UdpTunnel::open(std::to_string(pt) + ":127.0.0.1:" + std::to_string(pr)));
  ASSERT_TRUE(t);
  intruder.send_to(pt, plain_packet(1));       // another port
  other_address.send_to(pt, plain_packet(2));  // the peer's port on another address
  peer.send_to(pt, plain_packet(3));
  EXPECT_EQ(next_id(*t), 0x183) << "only the peer's frame";
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(t->counters().foreign, 2u);
  EXPECT_EQ(t->counters().received, 1u);
  peer.send_to(pt, {0x02, 0x00, 0x00, 0x00, 0x01});  // the peer's, malformed
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(t->counters().malformed, 1u);
  EXPECT_EQ(t->counters().foreign, 2u);
}

TEST(UdpTunnel, AKeyedTunnelTakesOnlyAuthenticNewPacketsOfThePeersNewestSession) {
  const auto [pt, pr] = test::free_udp_ports();
  RawEnd peer(pr);
  const cannelloni::Key key = test_key(1);
  auto t = opened(UdpTunnel::open(std::to_string(pt) + ":127.0.0.1:" + std::to_string(pr), &key));
  ASSERT_TRUE(t);
  EXPECT_TRUE(t->authenticated());
  EXPECT_THAT(t->describe(), ::testing::HasSubstr("authenticated"));
  cannelloni::Authenticator sender(key), wrong(test_key(2));
  const cannelloni::LinkEnds link = ends(peer, pt);
  const uint64_t epoch = 1'700'000'000'000'000'000ULL;
  auto sealed = [&](cannelloni::Authenticator& with, uint8_t n, uint64_t e, uint64_t counter,
                    const cannelloni::LinkEnds& l) {
    std::vector<uint8_t> packet = plain_packet(n);
    with.seal(packet, e, counter, l);
    return packet;
  };
  const BusCounters& c = t->counters();

  const std::vector<uint8_t> good = sealed(sender, 1, epoch, 1, link);
  EXPECT_EQ(good.size(), plain_packet(1).size() + cannelloni::kTrailerSize);
  peer.send_to(pt, good);
  EXPECT_EQ(next_id(*t), 0x181);

  std::vector<uint8_t> tampered = sealed(sender, 2, epoch, 2, link);
  tampered[10] ^= 0x01;  // the frame's data byte
  peer.send_to(pt, tampered);
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.unauthenticated, 1u) << "tampered";
  peer.send_to(pt, plain_packet(3));
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.unauthenticated, 2u) << "no tag";
  peer.send_to(pt, sealed(wrong, 4, epoch, 3, link));
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.unauthenticated, 3u) << "another key";
  // Its own packet sent back to it (the tag covers who sent it to whom).
  const cannelloni::LinkEnds reflected{
      .from_addr = link.to_addr, .to_addr = link.from_addr, .from_port = link.to_port, .to_port = link.from_port};
  peer.send_to(pt, sealed(sender, 5, epoch, 4, reflected));
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.unauthenticated, 4u) << "reflected";

  peer.send_to(pt, good);
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.replayed, 1u) << "replayed";
  EXPECT_EQ(c.received, 1u);

  // Reordered within the window: both taken, once each; nothing counted lost.
  peer.send_to(pt, sealed(sender, 6, epoch, 3, link));
  peer.send_to(pt, sealed(sender, 7, epoch, 2, link));
  EXPECT_EQ(next_id(*t), 0x186);
  EXPECT_EQ(next_id(*t), 0x187);
  EXPECT_EQ(c.lost, 0u);
  peer.send_to(pt, sealed(sender, 8, epoch, 10, link));
  EXPECT_EQ(next_id(*t), 0x188);
  EXPECT_EQ(c.lost, 6u) << "counters 4..9 missing";
  // Beyond the window behind the newest: refused as a replay would be.
  peer.send_to(pt, sealed(sender, 9, epoch, 100, link));
  EXPECT_EQ(next_id(*t), 0x189);
  peer.send_to(pt, sealed(sender, 10, epoch, 100 - cannelloni::ReplayWindow::kSize, link));
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.replayed, 2u);

  // The sender restarts: a newer epoch, its counter from 1 again.
  peer.send_to(pt, sealed(sender, 11, epoch + 1'000'000'000, 1, link));
  EXPECT_EQ(next_id(*t), 0x18B) << "a restarted sender is taken";
  peer.send_to(pt, sealed(sender, 12, epoch, 101, link));
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.replayed, 3u) << "the old session's packet is not";

  // Authentic but not a cannelloni packet: malformed.
  std::vector<uint8_t> bad = {0x02, 0x00, 0x00, 0x00, 0x02};
  sender.seal(bad, epoch + 1'000'000'000, 2, link);
  peer.send_to(pt, bad);
  EXPECT_EQ(next_id(*t), -1);
  EXPECT_EQ(c.malformed, 1u);
  EXPECT_EQ(c.received, 6u);
  EXPECT_EQ(c.unauthenticated, 4u);
  EXPECT_EQ(c.foreign, 0u);
}

TEST(UdpTunnel, KeyedTunnelsCarryFramesBothWaysAndARestartedEndIsTaken) {
  const auto [pa, pb] = test::free_udp_ports();
  const cannelloni::Key key = test_key(7);
  const std::string a_spec = std::to_string(pa) + ":127.0.0.1:" + std::to_string(pb);
  auto a = opened(UdpTunnel::open(a_spec, &key));
  ASSERT_TRUE(a);
  auto b = opened(UdpTunnel::open(std::to_string(pb) + ":127.0.0.1:" + std::to_string(pa), &key));
  ASSERT_TRUE(b);
  for (const Frame& f : golden_frames()) a->send(f);
  a->flush();
  Frame f;
  for (const Frame& want : golden_frames()) {
    ASSERT_TRUE(b->receive(f, 200'000'000));
    EXPECT_EQ(f, want);
  }
  b->send(data_frame(0x181, {1, 2}));
  b->flush();
  ASSERT_TRUE(a->receive(f, 200'000'000));
  EXPECT_EQ(f, data_frame(0x181, {1, 2}));
  const uint64_t first_epoch = a->epoch();

  a.reset();  // the robot PC's process restarts
  a = opened(UdpTunnel::open(a_spec, &key));
  ASSERT_TRUE(a);
  EXPECT_GT(a->epoch(), first_epoch);
  a->send(data_frame(0x701, {0x05}));
  a->flush();
  ASSERT_TRUE(b->receive(f, 200'000'000));
  EXPECT_EQ(f, data_frame(0x701, {0x05}));
  EXPECT_EQ(b->counters().replayed + b->counters().unauthenticated + b->counters().lost, 0u);

  // A key-less end (as a real cannelloni bridge) and a keyed one do not talk.
  a.reset();
  auto keyless = opened(UdpTunnel::open(a_spec));
  ASSERT_TRUE(keyless);
  keyless->send(data_frame(0x181, {9}));
  keyless->flush();
  EXPECT_FALSE(b->receive(f, 50'000'000));
  EXPECT_EQ(b->counters().unauthenticated, 1u);
  b->send(data_frame(0x181, {9}));
  b->flush();
  EXPECT_FALSE(keyless->receive(f, 50'000'000));
  EXPECT_EQ(keyless->counters().malformed, 1u) << "the trailer is bytes after the last frame to it";
  // A keyed end refuses to listen on every interface: its tag names its address.
  const auto everywhere = UdpTunnel::open("0.0.0.0:0:127.0.0.1:" + std::to_string(pa), &key);
  EXPECT_FALSE(everywhere.ok());
  EXPECT_THAT(everywhere.error(), ::testing::HasSubstr("not 0.0.0.0"));
}

// A key file in the test's temporary folder, with `mode`.
std::string write_key_file(const std::string& name, const std::string& text, mode_t mode) {
  const std::string path = ::testing::TempDir() + name + "_" + std::to_string(::getpid());
  std::ofstream(path) << text;
  ::chmod(path.c_str(), mode);
  return path;
}

constexpr const char* kKeyHex = "000102030405060708090a0b0c0d0e0f101112131415161718191A1B1C1D1E1F";

TEST(UdpTunnel, AKeyFileIsTheOwnersAloneAndHoldsSixtyFourHexCharacters) {
  const std::string good = write_key_file("can_key_good", std::string(kKeyHex) + "\n", 0600);
  cannelloni::Key key;
  const Status loaded = cannelloni::load_key(good, key);
  ASSERT_TRUE(loaded.ok()) << loaded.message();
  EXPECT_EQ(key.bytes, test_key(0).bytes);

  for (mode_t mode : {0640, 0604, 0620, 0644}) {
    const std::string open_to_others = write_key_file("can_key_open", kKeyHex, mode);
    const Status refused = cannelloni::load_key(open_to_others, key);
    EXPECT_FALSE(refused.ok()) << std::oct << mode;
    EXPECT_THAT(refused.message(), ::testing::HasSubstr("key file '" + open_to_others + "'"));
    EXPECT_THAT(refused.message(), ::testing::HasSubstr("chmod 600 '" + open_to_others + "'"));
    ::unlink(open_to_others.c_str());
  }
  for (const char* text : {"0011", "zz0102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f", ""}) {
    const std::string bad = write_key_file("can_key_bad", text, 0600);
    const Status refused = cannelloni::load_key(bad, key);
    EXPECT_FALSE(refused.ok()) << text;
    EXPECT_THAT(refused.message(), ::testing::HasSubstr("expected 64 hex characters"));
    ::unlink(bad.c_str());
  }
  const Status missing = cannelloni::load_key(good + ".missing", key);
  EXPECT_FALSE(missing.ok());
  EXPECT_THAT(missing.message(), ::testing::HasSubstr("No such file"));
  const Status folder = cannelloni::load_key(::testing::TempDir(), key);
  EXPECT_FALSE(folder.ok());
  EXPECT_THAT(folder.message(), ::testing::HasSubstr("not a regular file"));

  // Through open_bus, as the nodes open it.
  const auto [pa, pb] = test::free_udp_ports();
  auto bus = opened(open_bus("udp:" + std::to_string(pa) + ":127.0.0.1:" + std::to_string(pb), {good}));
  ASSERT_TRUE(bus);
  EXPECT_TRUE(dynamic_cast<UdpTunnel&>(*bus).authenticated());
  const auto keyed_virtual = open_bus("virtual:keyed", {good});
  EXPECT_FALSE(keyed_virtual.ok());
  EXPECT_THAT(keyed_virtual.error(), ::testing::HasSubstr("is for a udp bus only"));
  ::unlink(good.c_str());
}

uint64_t own_counter(const NodeStats& stats, const std::string& name) {
  for (const auto& c : stats.counters)
    if (c->name == name) return c->value.load();
  ADD_FAILURE() << stats.name << " has no counter " << name;
  return 0;
}

// can.tap on a keyed tunnel: what it dropped is in its stats and the run's
// --stats-json, counter by counter.
TEST(CanNodes, TheTunnelsDropsAreInTheNodesStatsAndStatsJson) {
  const std::string key_file = write_key_file("can_key_tap", kKeyHex, 0600);
  const auto [pt, pr] = test::free_udp_ports();
  RawEnd peer(pr), intruder(0);
  auto run = test::open_graph(R"(<graph name="keyed_tap">
    <node name="tap" plugin="can.tap">
      <param name="bus" value="udp:)" +
                              std::to_string(pt) + ":127.0.0.1:" + std::to_string(pr) + R"("/>
      <param name="key_file" value=")" +
                              key_file + R"("/>
      <param name="period_ms" value="20"/>
      <param name="duration" value="0.3"/>
    </node>
    <node name="frames" plugin="util.null"/>
    <edge from="tap.frames" to="frames.in"/>
  </graph>)");
  cannelloni::Authenticator sender(test_key(0));
  std::vector<uint8_t> good = plain_packet(1);
  sender.seal(good, 1, 1, ends(peer, pt));
  peer.send_to(pt, good);
  peer.send_to(pt, good);             // replayed
  peer.send_to(pt, plain_packet(2));  // no tag
  intruder.send_to(pt, good);         // foreign
  ASSERT_TRUE(run->run().ok());
  const NodeStats& tap = run->stats("tap");
  EXPECT_EQ(own_counter(tap, "bus_received"), 1u);
  EXPECT_EQ(own_counter(tap, "bus_replayed"), 1u);
  EXPECT_EQ(own_counter(tap, "bus_unauthenticated"), 1u);
  EXPECT_EQ(own_counter(tap, "bus_foreign"), 1u);
  EXPECT_EQ(own_counter(tap, "bus_malformed"), 0u);
  const std::string json = ::testing::TempDir() + "can_stats_" + std::to_string(::getpid()) + ".json";
  std::ofstream(json) << run->executor->stats_json();
  for (const auto& field : kBusCounterFields)
    EXPECT_GE(test::stats_counter(json, "tap", std::string("bus_") + field.name), 0) << field.name;
  EXPECT_EQ(test::stats_counter(json, "tap", "bus_foreign"), 1);
  EXPECT_EQ(test::stats_counter(json, "tap", "bus_unauthenticated"), 1);
  EXPECT_EQ(test::stats_counter(json, "tap", "bus_replayed"), 1);
  ::unlink(json.c_str());
  ::unlink(key_file.c_str());
}

// can.send seals with its key file; what arrives is authentic for the link.
TEST(CanNodes, CanSendSealsItsPacketsAndCountsThem) {
  const std::string key_file = write_key_file("can_key_send", kKeyHex, 0600);
  const auto [ps, pr] = test::free_udp_ports();
  RawEnd peer(pr);
  auto send = opened(testing::NodeHarness::create(
      "<node plugin=\"can.send\"><param name=\"bus\" value=\"udp:" + std::to_string(ps) +
      ":127.0.0.1:" + std::to_string(pr) + "\"/><param name=\"key_file\" value=\"" + key_file + "\"/></node>"));
  ASSERT_NE(send, nullptr);
  auto out = std::make_shared<CanFrames>();
  CanFrames::Frame m;
  m.can_id = 0x601;
  m.length = 2;
  m.data = {0x40, 0x41};
  out->frames = {m, m};
  send->set("frames", out);
  ASSERT_TRUE(send->process().ok());
  EXPECT_EQ(send->counter("bus_sent"), 2u);
  EXPECT_EQ(send->counter("bus_send_failed"), 0u);
  const std::vector<uint8_t> packet = peer.receive();
  ASSERT_FALSE(packet.empty());
  cannelloni::Authenticator check(test_key(0));
  std::size_t payload = 0;
  uint64_t epoch = 0, counter = 0;
  cannelloni::LinkEnds link{.from_addr = htonl(INADDR_LOOPBACK),
                            .to_addr = peer.self.sin_addr.s_addr,
                            .from_port = htons(static_cast<uint16_t>(ps)),
                            .to_port = peer.self.sin_port};
  ASSERT_TRUE(check.open(packet.data(), packet.size(), link, payload, epoch, counter));
  EXPECT_EQ(counter, 1u);
  EXPECT_GT(epoch, 0u);
  std::vector<Frame> frames;
  uint8_t seq = 0;
  const Status decoded = cannelloni::decode(packet.data(), payload, seq, frames);
  ASSERT_TRUE(decoded.ok()) << decoded.message();
  EXPECT_EQ(frames.size(), 2u);
  // A group-readable key file is refused when the node opens, naming the fix.
  ::chmod(key_file.c_str(), 0640);
  const auto refused = testing::NodeHarness::create(
      "<node plugin=\"can.send\"><param name=\"bus\" value=\"udp:0:127.0.0.1:" + std::to_string(pr) +
      "\"/><param name=\"key_file\" value=\"" + key_file + "\"/></node>");
  EXPECT_FALSE(refused.ok());
  EXPECT_THAT(refused.error(), ::testing::HasSubstr("chmod 600"));
  ::unlink(key_file.c_str());
}

// The master and the drives in one graph on a keyed tunnel: the drives are
// configured and enabled through it, packets from elsewhere are counted, and
// both nodes' stats carry every bus counter.
TEST(CanNodes, TheDriverAndTheDrivesRunOverAKeyedTunnel) {
  const std::string key_file = write_key_file("can_key_loop", kKeyHex, 0600);
  const auto [pa, pb] = test::free_udp_ports();
  RawEnd intruder(0);
  testing::Recorder::instance().clear();
  auto run = test::open_graph(R"(<graph name="keyed_loop">
    <node name="driver" plugin="can.driver">
      <param name="bus" value="udp:)" +
                              std::to_string(pa) + ":127.0.0.1:" + std::to_string(pb) + R"("/>
      <param name="key_file" value=")" +
                              key_file + R"("/>
      <param name="duration" value="2.5"/>
      <param name="wait_ms" value="2"/>
    </node>
    <node name="drives" plugin="can.drives">
      <param name="bus" value="udp:)" +
                              std::to_string(pb) + ":127.0.0.1:" + std::to_string(pa) + R"("/>
      <param name="key_file" value=")" +
                              key_file + R"("/>
      <param name="duration" value="2.5"/>
    </node>
    <node name="state" plugin="util.record"/>
    <node name="truth" plugin="util.null"/>
    <edge from="driver.state" to="state.in"/>
    <edge from="drives.truth" to="truth.in"/>
  </graph>)");
  for (int i = 0; i < 3; ++i) intruder.send_to(pa, plain_packet(static_cast<uint8_t>(i)));
  const Status status = run->run();
  ASSERT_TRUE(status.ok()) << status.message();
  const auto states = test::recorded<JointState>("state");
  ASSERT_FALSE(states.empty());
  EXPECT_TRUE(states.back()->all_ready()) << states.back()->detail;
  const NodeStats& driver = run->stats("driver");
  const NodeStats& drives = run->stats("drives");
  EXPECT_EQ(own_counter(driver, "bus_foreign"), 3u);
  EXPECT_GT(own_counter(driver, "bus_received"), 100u);
  EXPECT_GT(own_counter(drives, "bus_received"), 100u);
  EXPECT_GT(own_counter(drives, "bus_sent"), 100u);
  for (const NodeStats* n : {&driver, &drives})
    for (const char* name : {"bus_unauthenticated", "bus_replayed", "bus_malformed"})
      EXPECT_EQ(own_counter(*n, name), 0u) << n->name << " " << name;
  ::unlink(key_file.c_str());
}

TEST(SocketCan, TalksOnVcan0WhereTheKernelHasCan) {
  auto vcan0 = SocketCan::open("vcan0");
  if (!vcan0.ok())
    GTEST_SKIP() << vcan0.error() << " (create one with: ip link add dev vcan0 type vcan && ip link set up vcan0)";
  auto a = std::move(vcan0).value();
  auto b = opened(SocketCan::open("vcan0"));
  ASSERT_TRUE(b);
  FilterSet only;
  only.filters = {Filter::exact(0x181)};
  b->set_filters(only);
  ASSERT_TRUE(a->send(data_frame(0x281, {9})));
  ASSERT_TRUE(a->send(data_frame(0x181, {1, 2, 3})));
  Frame f;
  ASSERT_TRUE(b->receive(f, 100'000'000));
  EXPECT_EQ(f, data_frame(0x181, {1, 2, 3})) << "the kernel's filter kept 0x281 out";
  EXPECT_GT(f.timestamp_ns, 0) << "kernel timestamp";
  EXPECT_FALSE(a->receive(f, 0)) << "no echo of its own frames";
}

TEST(SocketCan, AMissingInterfaceOrKernelSupportIsAClearError) {
  const auto missing = SocketCan::open("nosuchcan9");
  EXPECT_FALSE(missing.ok());
  EXPECT_THAT(missing.error(), ::testing::HasSubstr("socketcan 'nosuchcan9'"));
  const auto unnamed = SocketCan::open("");
  EXPECT_FALSE(unnamed.ok());
  EXPECT_THAT(unnamed.error(), ::testing::HasSubstr("expected an interface name"));
}

// can.send puts a CanFrames message's frames on a bus; can.tap, on another
// port of that bus, hands them back as one batch: standard, extended, remote
// and FD frames keep their ids, flags and bytes.
TEST(CanNodes, FramesSentByCanSendComeBackFromCanTap) {
  const std::string bus = "virtual:tap_test_" + std::to_string(getpid());
  auto tap = opened(testing::NodeHarness::create("<node plugin=\"can.tap\"><param name=\"bus\" value=\"" + bus +
                                                 "\"/><param name=\"period_ms\" value=\"50\"/></node>"));
  ASSERT_NE(tap, nullptr);
  auto send = opened(
      testing::NodeHarness::create("<node plugin=\"can.send\"><param name=\"bus\" value=\"" + bus + "\"/></node>"));
  ASSERT_NE(send, nullptr);

  auto out = std::make_shared<CanFrames>();
  CanFrames::Frame sdo;
  sdo.can_id = 0x601;
  sdo.length = 8;
  sdo.data = {0x40, 0x64, 0x60, 0x00};
  CanFrames::Frame extended;
  extended.can_id = 0x1234567 | CanFrames::kExtended;
  extended.length = 3;
  extended.data = {1, 2, 3};
  CanFrames::Frame remote;
  remote.can_id = 0x701 | CanFrames::kRemote;
  CanFrames::Frame fd;
  fd.can_id = 0x181;
  fd.flags = CanFrames::kFd | CanFrames::kBitRateSwitch;
  fd.length = 64;
  for (int i = 0; i < 64; ++i) fd.data[static_cast<std::size_t>(i)] = static_cast<uint8_t>(i * 3);
  CanFrames::Frame error_frame;
  error_frame.can_id = 0x040 | CanFrames::kError;  // not sent: only controllers make error frames
  out->frames = {sdo, extended, remote, fd, error_frame};
  send->set("frames", out);
  ASSERT_TRUE(send->process().ok());

  ASSERT_TRUE(tap->process().ok());
  auto batch = tap->last<CanFrames>("frames");
  ASSERT_NE(batch, nullptr);
  EXPECT_EQ(batch->bus, bus);
  ASSERT_EQ(batch->frames.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    CanFrames::Frame got = batch->frames[i];
    got.timestamp_ns = 0;
    EXPECT_EQ(got, out->frames[i]) << "frame " << i;
  }
  // Its counts are in the node's stats.
  EXPECT_EQ(send->counter("sent"), 4u);
  EXPECT_EQ(send->counter("error_frames_skipped"), 1u);
  EXPECT_EQ(send->counter("failed"), 0u);
}

// The trace of a gaze request to the joint command it causes: the head puts
// the request's origin on the targets of the cycle that takes it (they head
// for it already), and the driver times, on the cycle that first commands
// those targets, how long since the camera frame and since the head took it.
TEST(CanNodes, AGazeRequestIsTracedFromItsCameraFrameToTheJointCommand) {
  // The driver node (in the plugin) and the drives (here) meet on a UDP tunnel.
  const auto [pa, pb] = test::free_udp_ports();
  const std::string bus = "udp:" + std::to_string(pa) + ":127.0.0.1:" + std::to_string(pb);
  auto head = opened(testing::NodeHarness::create("<node plugin=\"head\"/>"));
  ASSERT_NE(head, nullptr);
  auto driver = opened(testing::NodeHarness::create("<node plugin=\"can.driver\"><param name=\"bus\" value=\"" + bus +
                                                    "\"/><param name=\"realtime\" value=\"false\"/>"
                                                    "<param name=\"wait_ms\" value=\"5\"/></node>"));
  ASSERT_NE(driver, nullptr);

  auto state = std::make_shared<JointState>();
  const int64_t now = steady_now_ns();
  state->position.assign(5, 0.0);
  state->velocity.assign(5, 0.0);
  state->health.assign(5, JointState::Health::kReady);
  state->updated_ns.assign(5, now);
  state->timestamp_ns = now;
  head->set("state", state);
  auto gaze = std::make_shared<GazeRequest>();
  gaze->kind = GazeRequest::Kind::kDirection;
  gaze->direction = cv::Vec3d(0.2, 0, 1) / cv::norm(cv::Vec3d(0.2, 0, 1));
  gaze->origin_ns = now - 3'000'000;  // its camera frame, 3 ms ago
  head->set("gaze", gaze);

  head->set("gaze", nullptr);
  ASSERT_TRUE(head->process().ok());  // the first state: a request needs one
  head->set("gaze", gaze);
  ASSERT_TRUE(head->process().ok());
  auto answering = head->last<JointTargets>("targets");
  ASSERT_NE(answering, nullptr);
  EXPECT_EQ(answering->cause_origin_ns, gaze->origin_ns) << "this cycle's targets already head for it";
  EXPECT_GE(answering->cause_taken_ns, now);
  ASSERT_EQ(head->timing("gaze_capture_to_taken").count(), 1u);
  EXPECT_GE(head->timing("gaze_capture_to_taken").max(), 3'000'000);
  ASSERT_TRUE(head->process().ok());
  EXPECT_EQ(head->last<JointTargets>("targets")->cause_origin_ns, 0) << "once per request";

  // Five drives on the driver's bus, stepped in the driver's time: timed once
  // every running drive has been sent the answering targets.
  std::vector<DriveConfig> configs;
  for (int n = 1; n <= 5; ++n) {
    DriveConfig c;
    c.node = n;
    c.counts_per_rad = 20000.0;
    configs.push_back(c);
  }
  auto drives_end = opened(UdpTunnel::open(std::to_string(pb) + ":127.0.0.1:" + std::to_string(pa)));
  ASSERT_TRUE(drives_end);
  DriveRack rack(std::move(drives_end), configs);
  auto step = [&](int tick) {
    ASSERT_TRUE(driver->process().ok());
    rack.step(tick * 4'000'000LL, 0.004, 5'000'000);
  };
  for (int tick = 0; tick < 30; ++tick) step(tick);
  auto joints = driver->last<JointState>("state");
  ASSERT_NE(joints, nullptr);
  ASSERT_EQ(joints->health.size(), configs.size());
  for (JointState::Health h : joints->health) ASSERT_EQ(h, JointState::Health::kReady) << joints->detail;
  ASSERT_EQ(driver->timing("gaze_capture_to_command").count(), 0u);
  driver->set("targets", std::const_pointer_cast<JointTargets>(answering));
  for (int tick = 30; tick < 40; ++tick) step(tick);  // the same targets again and again: timed once
  const Histogram& from_capture = driver->timing("gaze_capture_to_command");
  const Histogram& from_taken = driver->timing("gaze_taken_to_command");
  ASSERT_EQ(from_capture.count(), 1u);
  ASSERT_EQ(from_taken.count(), 1u);
  EXPECT_GE(from_capture.max(), 3'000'000) << "at least the 3 ms since the frame";
  EXPECT_LT(from_taken.max(), from_capture.max());
}

}  // namespace
}  // namespace saccade::can
