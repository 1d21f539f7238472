// CANopen / CiA 402 for the head's drives: statusword and controlword
// tables, PDO and SDO bytes, the simulated drive (SDO server, heartbeat,
// profile position handshake, the position loop, faults) and the master
// (configuration, enabling, set-points, supervision, reset), all over the
// virtual bus on a simulated clock.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "canopen.hpp"
#include "drive_sim.hpp"
#include "master.hpp"
#include "virtual_bus.hpp"

namespace saccade::can {
namespace {

TEST(Statusword, EveryStateRoundTripsAndRealDriveWordsDecode) {
  for (DriveState s : {DriveState::kNotReadyToSwitchOn, DriveState::kSwitchOnDisabled, DriveState::kReadyToSwitchOn,
                       DriveState::kSwitchedOn, DriveState::kOperationEnabled, DriveState::kQuickStopActive,
                       DriveState::kFaultReactionActive, DriveState::kFault})
    EXPECT_EQ(decode_statusword(encode_statusword(s)), s) << to_string(s);
  // Words as drives send them, with remote (bit 9) and target reached (bit 10) set.
  EXPECT_EQ(decode_statusword(0x0637), DriveState::kOperationEnabled);
  EXPECT_EQ(decode_statusword(0x0250), DriveState::kSwitchOnDisabled);
  EXPECT_EQ(decode_statusword(0x0218), DriveState::kFault);
  EXPECT_EQ(decode_statusword(0x0231), DriveState::kReadyToSwitchOn);
}

TEST(Controlword, TheProfilesTransitions) {
  using S = DriveState;
  EXPECT_EQ(next_state(S::kSwitchOnDisabled, control::kShutdown), S::kReadyToSwitchOn);
  EXPECT_EQ(next_state(S::kSwitchOnDisabled, control::kEnableOperation), S::kSwitchOnDisabled)
      << "needs shutdown first";
  EXPECT_EQ(next_state(S::kReadyToSwitchOn, control::kSwitchOn), S::kSwitchedOn);
  EXPECT_EQ(next_state(S::kSwitchedOn, control::kEnableOperation), S::kOperationEnabled);
  EXPECT_EQ(next_state(S::kOperationEnabled, control::kDisableOperation), S::kSwitchedOn);
  EXPECT_EQ(next_state(S::kOperationEnabled, control::kQuickStop), S::kQuickStopActive);
  EXPECT_EQ(next_state(S::kOperationEnabled, control::kDisableVoltage), S::kSwitchOnDisabled);
  EXPECT_EQ(next_state(S::kQuickStopActive, control::kDisableVoltage), S::kSwitchOnDisabled);
  EXPECT_EQ(next_state(S::kFault, control::kEnableOperation), S::kFault) << "a fault holds until reset";
  EXPECT_EQ(next_state(S::kFault, control::kFaultReset), S::kSwitchOnDisabled);
}

TEST(Pdo, TheDefaultMappingLittleEndian) {
  const Frame r1 = rpdo1(3, control::kEnableOperation | pp::kNewSetPoint);
  EXPECT_EQ(r1.id, 0x203u);
  ASSERT_EQ(r1.length, 3);
  EXPECT_EQ(r1.data[0], 0x1F);
  EXPECT_EQ(r1.data[1], 0x00);
  EXPECT_EQ(r1.data[2], 0x01) << "profile position mode";
  const Frame r2 = rpdo2(3, -2);
  EXPECT_EQ(r2.id, 0x303u);
  ASSERT_EQ(r2.length, 4);
  EXPECT_EQ(r2.data[0], 0xFE);
  EXPECT_EQ(r2.data[3], 0xFF);
  uint16_t word = 0;
  int8_t mode = 0;
  ASSERT_TRUE(parse_tpdo1(tpdo1(5, 0x1637), word, mode));
  EXPECT_EQ(word, 0x1637);
  EXPECT_EQ(mode, 1);
  int32_t position = 0, velocity = 0;
  const Frame t2 = tpdo2(5, 123456, -789);
  EXPECT_EQ(t2.id, 0x285u);
  ASSERT_TRUE(parse_tpdo2(t2, position, velocity));
  EXPECT_EQ(position, 123456);
  EXPECT_EQ(velocity, -789);
  int32_t target = 0;
  EXPECT_FALSE(parse_tpdo2(tpdo1(5, 0), position, velocity)) << "wrong length";
  EXPECT_FALSE(parse_rpdo2(rpdo1(5, 0), target));
}

TEST(Nmt, FramesAndHeartbeats) {
  const Frame start = nmt(NmtCommand::kStart, 0);
  EXPECT_EQ(start.id, 0u);
  EXPECT_EQ(start.length, 2);
  EXPECT_EQ(start.data[0], 0x01);
  EXPECT_EQ(nmt(NmtCommand::kResetNode, 4).data[0], 0x81);
  EXPECT_EQ(nmt(NmtCommand::kResetNode, 4).data[1], 4);
  const Frame hb = heartbeat(7, NmtState::kPreOperational);
  EXPECT_EQ(hb.id, 0x707u);
  EXPECT_EQ(hb.data[0], 0x7F);
  EXPECT_EQ(sync_frame().id, 0x80u);
  EXPECT_EQ(sync_frame().length, 0);
  EXPECT_EQ(emergency(2, emcy::kFollowingError, 1).id, 0x82u);
}

TEST(Sdo, ExpeditedCommandBytes) {
  struct Row {
    Sdo::Kind kind;
    uint8_t size;
    uint8_t command;
  };
  const Row rows[] = {{Sdo::Kind::kDownloadRequest, 4, 0x23}, {Sdo::Kind::kDownloadRequest, 2, 0x2B},
                      {Sdo::Kind::kDownloadRequest, 1, 0x2F}, {Sdo::Kind::kDownloadResponse, 4, 0x60},
                      {Sdo::Kind::kUploadRequest, 4, 0x40},   {Sdo::Kind::kUploadResponse, 4, 0x43},
                      {Sdo::Kind::kUploadResponse, 2, 0x4B},  {Sdo::Kind::kAbort, 4, 0x80}};
  for (const Row& r : rows) {
    Sdo s;
    s.kind = r.kind;
    s.size = r.size;
    s.index = 0x6081;
    s.subindex = 0;
    s.value = 0x11223344;
    const Frame f = sdo_frame(0x605, s);
    EXPECT_EQ(f.data[0], r.command);
    EXPECT_EQ(f.data[1], 0x81);
    EXPECT_EQ(f.data[2], 0x60);
    Sdo back;
    ASSERT_TRUE(parse_sdo(f, back));
    EXPECT_EQ(back.kind, r.kind) << std::hex << int(r.command);
    EXPECT_EQ(back.index, 0x6081);
    if (r.kind == Sdo::Kind::kDownloadRequest || r.kind == Sdo::Kind::kUploadResponse) {
      EXPECT_EQ(back.size, r.size);
      EXPECT_EQ(back.value, r.size == 4 ? 0x11223344u : (r.size == 2 ? 0x3344u : 0x44u));
    }
  }
  Frame segmented;
  segmented.length = 8;
  segmented.data[0] = 0x21;  // download, not expedited
  Sdo s;
  ASSERT_TRUE(parse_sdo(segmented, s));
  EXPECT_EQ(s.kind, Sdo::Kind::kUnsupported);
  EXPECT_EQ(sdo_abort_text(sdo_abort::kNoObject), "object does not exist in the object dictionary");
  EXPECT_EQ(sdo_abort_text(0x12345678), "abort code 0x12345678");
}

// A client on the virtual bus, for talking to one simulated drive by hand.
struct Client {
  std::shared_ptr<VirtualBus> bus = VirtualBus::create();
  std::unique_ptr<VirtualPort> port = bus->attach();
  DriveRack rack;
  int64_t now = 0;
  explicit Client(DriveConfig config) : rack(bus->attach(), {config}) { bus->set_time(0); }
  SimulatedDrive& drive() { return rack.drive(0); }
  void step(double dt = 0.001) {
    now += static_cast<int64_t>(dt * 1e9);
    bus->set_time(now);
    rack.step(now, dt);
  }
  std::vector<Frame> drain() {
    std::vector<Frame> out;
    Frame f;
    while (port->receive(f, 0)) out.push_back(f);
    return out;
  }
  Sdo sdo(Sdo::Kind kind, uint16_t index, uint32_t value = 0, uint8_t size = 4) {
    Sdo s;
    s.kind = kind;
    s.index = index;
    s.value = value;
    s.size = size;
    port->send(sdo_frame(cob::sdo_request(drive().node()), s));
    step();
    for (const Frame& f : drain())
      if (f.id == cob::sdo_response(drive().node()) && parse_sdo(f, s)) return s;
    return {};
  }
  // SYNC; the drive's TPDOs.
  std::pair<uint16_t, int32_t> sync(double dt = 0.001) {
    port->send(sync_frame());
    step(dt);
    std::pair<uint16_t, int32_t> out{0xFFFF, 0};
    for (const Frame& f : drain()) {
      int8_t mode = 0;
      int32_t velocity = 0;
      if (f.id == cob::tpdo1(drive().node())) parse_tpdo1(f, out.first, mode);
      if (f.id == cob::tpdo2(drive().node())) parse_tpdo2(f, out.second, velocity);
    }
    return out;
  }
  void control(uint16_t cw) {
    port->send(rpdo1(drive().node(), cw));
    step();
  }
};

DriveConfig drive_config(int node = 4) {
  DriveConfig c;
  c.node = node;
  c.counts_per_rad = 10000;
  return c;
}

TEST(SimulatedDrive, BootsAndServesItsDictionaryBySdo) {
  Client c(drive_config());
  c.step();
  auto boot = c.drain();
  ASSERT_EQ(boot.size(), 1u);
  EXPECT_EQ(boot[0], heartbeat(4, NmtState::kBootUp));
  EXPECT_EQ(c.drive().nmt_state(), NmtState::kPreOperational);
  const Sdo written = c.sdo(Sdo::Kind::kDownloadRequest, object::kProfileVelocity, 12345);
  EXPECT_EQ(written.kind, Sdo::Kind::kDownloadResponse);
  const Sdo read = c.sdo(Sdo::Kind::kUploadRequest, object::kProfileVelocity);
  EXPECT_EQ(read.kind, Sdo::Kind::kUploadResponse);
  EXPECT_EQ(read.value, 12345u);
  const Sdo unknown = c.sdo(Sdo::Kind::kUploadRequest, 0x2345);
  EXPECT_EQ(unknown.kind, Sdo::Kind::kAbort);
  EXPECT_EQ(unknown.value, sdo_abort::kNoObject);
  const Sdo read_only = c.sdo(Sdo::Kind::kDownloadRequest, object::kPositionActual, 5);
  EXPECT_EQ(read_only.value, sdo_abort::kReadOnly);
  const Sdo velocity_mode = c.sdo(Sdo::Kind::kDownloadRequest, object::kModesOfOperation, 3, 1);
  EXPECT_EQ(velocity_mode.kind, Sdo::Kind::kAbort) << "only profile position is simulated";
  // Heartbeat every 10 ms once 0x1017 says so.
  EXPECT_EQ(c.sdo(Sdo::Kind::kDownloadRequest, object::kProducerHeartbeatTime, 10, 2).kind,
            Sdo::Kind::kDownloadResponse);
  int beats = 0;
  for (int i = 0; i < 100; ++i) {
    c.step();
    for (const Frame& f : c.drain()) beats += f.id == cob::heartbeat(4) && f.data[0] == 0x7F;
  }
  EXPECT_NEAR(beats, 10, 1);
  EXPECT_EQ(c.sync().first, 0xFFFF) << "no PDOs before NMT start";
}

TEST(SimulatedDrive, ProfilePositionHandshakeAndTheLoopReachesTheTarget) {
  Client c(drive_config());
  c.port->send(nmt(NmtCommand::kStart, 0));
  c.step();
  EXPECT_EQ(decode_statusword(c.sync().first), DriveState::kSwitchOnDisabled);
  c.control(control::kEnableOperation);
  EXPECT_EQ(decode_statusword(c.sync().first), DriveState::kSwitchOnDisabled) << "enable needs shutdown first";
  for (uint16_t cw : {control::kShutdown, control::kSwitchOn, control::kEnableOperation}) c.control(cw);
  auto [sw, position] = c.sync();
  EXPECT_EQ(decode_statusword(sw), DriveState::kOperationEnabled);
  EXPECT_EQ(sw & pp::kSetPointAcknowledge, 0);
  // Target 0.3 rad = 3000 counts: the new set-point edge is acknowledged.
  c.port->send(rpdo2(4, 3000));
  c.control(control::kEnableOperation | pp::kNewSetPoint);
  std::tie(sw, position) = c.sync();
  EXPECT_NE(sw & pp::kSetPointAcknowledge, 0);
  EXPECT_EQ(sw & pp::kTargetReached, 0);
  c.control(control::kEnableOperation);
  EXPECT_EQ(c.sync().first & pp::kSetPointAcknowledge, 0) << "bit 4 low: acknowledge low";
  double peak_velocity = 0;
  for (int i = 0; i < 300; ++i) {
    std::tie(sw, position) = c.sync();
    peak_velocity = std::max(peak_velocity, std::abs(c.drive().velocity()));
  }
  EXPECT_NE(sw & pp::kTargetReached, 0);
  EXPECT_NEAR(position, 3000, 2) << "encoder counts";
  EXPECT_NEAR(c.drive().position(), 0.3, 3e-4);
  EXPECT_LE(peak_velocity, 6.0 * 1.05) << "within the profile velocity (60000 counts/s)";
  // Relative set-point: -1000 counts from the last target.
  c.port->send(rpdo2(4, -1000));
  c.control(control::kEnableOperation | pp::kNewSetPoint | pp::kRelative);
  for (int i = 0; i < 300; ++i) c.sync();
  EXPECT_NEAR(c.drive().position(), 0.2, 3e-4);
}

TEST(SimulatedDrive, FollowingErrorFaultsAndHoldsUntilReset) {
  DriveConfig config = drive_config();
  config.motor.torque_limit = 0.05;  // too weak for the push below
  Client c(config);
  c.port->send(nmt(NmtCommand::kStart, 0));
  for (uint16_t cw : {control::kShutdown, control::kSwitchOn, control::kEnableOperation}) c.control(cw);
  c.drive().push(-0.5);  // a hand holding the head back
  c.port->send(rpdo2(4, 5000));
  c.control(control::kEnableOperation | pp::kNewSetPoint);
  bool emergency_seen = false;
  for (int i = 0; i < 200 && !emergency_seen; ++i) {
    c.port->send(sync_frame());
    c.step();
    for (const Frame& f : c.drain())
      if (f.id == cob::emergency(4)) emergency_seen = (f.data[0] | f.data[1] << 8) == emcy::kFollowingError;
  }
  EXPECT_TRUE(emergency_seen);
  EXPECT_EQ(c.drive().state(), DriveState::kFault);
  EXPECT_EQ(c.drive().last_error(), emcy::kFollowingError);
  c.drive().push(0);
  c.control(control::kEnableOperation);
  EXPECT_EQ(c.drive().state(), DriveState::kFault) << "holds until a fault reset";
  c.control(control::kFaultReset);
  EXPECT_EQ(c.drive().state(), DriveState::kSwitchOnDisabled);
  EXPECT_EQ(c.drive().last_error(), 0);
}

// The master with five drives on one virtual bus, stepped in lockstep.
struct Head {
  std::shared_ptr<VirtualBus> bus = VirtualBus::create();
  std::unique_ptr<VirtualPort> port = bus->attach();
  DriveRack rack;
  Master master;
  std::vector<JointFeedback> feedback;
  int64_t now = 0;
  static constexpr double kPeriod = 0.004;
  static std::vector<DriveConfig> drives() {
    std::vector<DriveConfig> d;
    for (int n = 1; n <= 5; ++n) d.push_back(drive_config(n));
    return d;
  }
  static MasterConfig config(bool statusword_on_change) {
    MasterConfig c;
    c.statusword_on_change = statusword_on_change;
    const char* names[] = {"neck", "vergence_left", "tilt_left", "vergence_right", "tilt_right"};
    for (int n = 1; n <= 5; ++n) c.joints.push_back({names[n - 1], n, 10000.0, 0});
    return c;
  }
  explicit Head(bool statusword_on_change = true)
      : rack(bus->attach(), drives()), master(*port, config(statusword_on_change)) {
    bus->set_time(0);
  }
  void cycle(const double* targets, int64_t reset = 0) {
    master.cycle(now, targets, reset, feedback);
    rack.step(now, kPeriod);
    now += static_cast<int64_t>(kPeriod * 1e9);
    bus->set_time(now);
  }
  bool ready() const {
    return !feedback.empty() && std::all_of(feedback.begin(), feedback.end(),
                                            [](const JointFeedback& f) { return f.health == DriveHealth::kReady; });
  }
};

TEST(Master, ConfiguresEnablesAndMovesFiveDrives) {
  Head h;
  int cycles = 0;
  while (!h.ready() && cycles < 100) {
    h.cycle(nullptr);
    ++cycles;
  }
  ASSERT_TRUE(h.ready()) << h.master.problem();
  EXPECT_LT(cycles, 20) << "7 SDO writes, NMT start, 3 state transitions";
  EXPECT_EQ(h.rack.drive(2).nmt_state(), NmtState::kOperational);
  const double targets[5] = {0.2, -0.1, 0.15, 0.1, -0.05};
  for (int i = 0; i < 250; ++i) h.cycle(targets);  // 1 s
  for (int j = 0; j < 5; ++j) {
    EXPECT_NEAR(h.feedback[static_cast<std::size_t>(j)].position, targets[j], 2e-4) << j;
    EXPECT_NEAR(h.rack.drive(static_cast<std::size_t>(j)).position(), targets[j], 2e-4) << j;
  }
  EXPECT_GT(h.master.stats().set_points, 100);
  EXPECT_GE(h.master.stats().acknowledged, h.master.stats().set_points - 6);
  EXPECT_GT(h.master.stats().bits_last_cycle, 0);
  EXPECT_TRUE(h.master.problem().empty()) << h.master.problem();
}

TEST(Master, ReportsAFaultAndClearsItOnReset) {
  Head h;
  for (int i = 0; i < 40; ++i) h.cycle(nullptr);
  ASSERT_TRUE(h.ready());
  h.rack.drive(2).inject_fault(0x2310);  // over-current
  const double targets[5] = {0, 0, 0, 0, 0};
  for (int i = 0; i < 3; ++i) h.cycle(targets);
  EXPECT_EQ(h.feedback[2].health, DriveHealth::kFault);
  EXPECT_EQ(h.feedback[2].error_code, 0x2310);
  EXPECT_EQ(h.master.problem(), "tilt_left (node 3): drive fault, emergency 0x2310");
  for (int i = 0; i < 10; ++i) h.cycle(targets);
  EXPECT_EQ(h.feedback[2].health, DriveHealth::kFault) << "holds until reset";
  for (int i = 0; i < 10; ++i) h.cycle(targets, 1);
  EXPECT_TRUE(h.ready()) << h.master.problem();
}

TEST(Master, ASilentDriveIsReportedAfterTheHeartbeatTimeout) {
  Head h;
  for (int i = 0; i < 40; ++i) h.cycle(nullptr);
  ASSERT_TRUE(h.ready());
  h.rack.drive(4).set_silent(true);
  const double targets[5] = {0, 0, 0, 0, 0};
  int cycles = 0;
  while (h.feedback[4].health != DriveHealth::kSilent && cycles < 100) {
    h.cycle(targets);
    ++cycles;
  }
  EXPECT_EQ(h.feedback[4].health, DriveHealth::kSilent);
  EXPECT_NEAR(cycles * Head::kPeriod, 0.05, 0.01) << "the process-data timeout (50 ms) comes first";
  EXPECT_THAT(h.master.problem(), ::testing::HasSubstr("tilt_right (node 5): no position for"));
  // Back on the bus and reset: configured and enabled again.
  h.rack.drive(4).set_silent(false);
  for (int i = 0; i < 30; ++i) h.cycle(targets, 1);
  EXPECT_TRUE(h.ready()) << h.master.problem();
}

TEST(Master, ADriveThatNeverAnswersSdoIsNamed) {
  Head h;
  h.rack.drive(0).set_silent(true);
  for (int i = 0; i < 60; ++i) h.cycle(nullptr);
  EXPECT_EQ(h.feedback[0].health, DriveHealth::kSilent);
  EXPECT_EQ(h.master.problem(), "neck (node 1): no answer to the SDO write of 0x6060 (3 attempts)");
  EXPECT_EQ(h.feedback[1].health, DriveHealth::kReady) << "the others run";
}

TEST(Master, ADrivePoweredAfterTheMasterGaveUpIsConfiguredWhenItBoots) {
  Head h;
  h.rack.drive(0).set_silent(true);  // no power yet
  for (int i = 0; i < 60; ++i) h.cycle(nullptr);
  ASSERT_EQ(h.feedback[0].health, DriveHealth::kSilent);
  h.rack.drive(0).power_cycle();  // its boot-up message restarts the configuration, no reset needed
  int cycles = 0;
  while (!h.ready() && cycles < 100) {
    h.cycle(nullptr);
    ++cycles;
  }
  EXPECT_TRUE(h.ready()) << h.master.problem();
  EXPECT_LT(cycles, 20);
  EXPECT_TRUE(h.master.problem().empty()) << h.master.problem();
  EXPECT_EQ(h.rack.drive(0).nmt_state(), NmtState::kOperational);
}

TEST(Master, ADriveRebootedWhileRunningIsConfiguredAgain) {
  Head h;
  for (int i = 0; i < 40; ++i) h.cycle(nullptr);
  ASSERT_TRUE(h.ready());
  h.rack.drive(3).power_cycle();  // a watchdog reset: its mode and PDO settings are gone
  const double targets[5] = {0, 0, 0, 0, 0};
  h.cycle(targets);
  h.cycle(targets);
  EXPECT_EQ(h.feedback[3].health, DriveHealth::kStarting);
  int cycles = 0;
  while (!h.ready() && cycles < 100) {
    h.cycle(targets);
    ++cycles;
  }
  EXPECT_TRUE(h.ready()) << h.master.problem();
  EXPECT_EQ(h.rack.drive(3).nmt_state(), NmtState::kOperational);
}

// Every frame on a bus, in the order the bus carried them.
std::vector<Frame> drain(Bus& tap) {
  std::vector<Frame> out;
  Frame f;
  while (tap.receive(f, 0)) out.push_back(f);
  return out;
}

bool rising(const Frame& f, int node) {
  uint16_t cw = 0;
  int8_t mode = 0;
  return f.id == cob::rpdo1(node) && parse_rpdo1(f, cw, mode) && (cw & pp::kNewSetPoint) != 0;
}

TEST(Master, NewTargetsBetweenCyclesGoOutAtOnceWhereTheHandshakeAllows) {
  Head h;
  auto tap = h.bus->attach();
  for (int i = 0; i < 40; ++i) h.cycle(nullptr);
  ASSERT_TRUE(h.ready()) << h.master.problem();
  drain(*tap);

  const double a[5] = {0.1, 0.05, -0.05, 0.05, -0.05};
  EXPECT_EQ(h.master.command(h.now, a, 1), 5) << "every drive is ready for a set-point: all at once";
  EXPECT_TRUE(h.master.commanded(1));
  std::vector<Frame> frames = drain(*tap);
  ASSERT_EQ(frames.size(), 10u) << "target position and controlword per drive";
  for (int n = 1; n <= 5; ++n) {
    EXPECT_EQ(frames[2 * (n - 1)].id, cob::rpdo2(n));
    EXPECT_TRUE(rising(frames[2 * (n - 1) + 1], n));
  }
  for (const Frame& f : frames) EXPECT_NE(f.id, cob::kSync) << "no SYNC between cycles";

  // The drives act on the set-point as it arrives and say so at once (TPDO1 on change).
  h.rack.handle_arrived(0);
  frames = drain(*tap);
  int acknowledged = 0;
  for (const Frame& f : frames) {
    uint16_t sw = 0;
    int8_t mode = 0;
    if (parse_tpdo1(f, sw, mode) && (sw & pp::kSetPointAcknowledge) != 0) ++acknowledged;
  }
  EXPECT_EQ(acknowledged, 5);

  // Newer targets in the same SYNC period: the handshake completes (bit 4 low),
  // but a drive gets one set-point per period.
  const double b[5] = {0.2, 0.1, -0.1, 0.1, -0.1};
  EXPECT_EQ(h.master.command(h.now, b, 2), 0);
  h.rack.handle_arrived(0);
  EXPECT_EQ(h.master.command(h.now, b, 2), 0);
  EXPECT_FALSE(h.master.commanded(2));
  h.master.cycle(h.now, nullptr, 0, h.feedback);  // the SYNC; no targets at the cycle
  h.rack.step(h.now, Head::kPeriod);
  h.now += static_cast<int64_t>(Head::kPeriod * 1e9);
  h.bus->set_time(h.now);
  EXPECT_EQ(h.master.command(h.now, b, 2), 5) << "the next period, between cycles again";
  EXPECT_TRUE(h.master.commanded(2));
  for (int i = 0; i < 250; ++i) h.cycle(nullptr);
  for (int j = 0; j < 5; ++j) EXPECT_NEAR(h.rack.drive(static_cast<std::size_t>(j)).position(), b[j], 2e-4);
}

// Whatever arrives between cycles, every drive sees the CiA 402 handshake:
// bit 4 rises only after a statusword with the acknowledge low (read since it
// last fell), falls only after one with it high, at most once per SYNC period;
// one SYNC per cycle. With the statusword on every SYNC or on change.
TEST(Master, TheSetPointHandshakeHoldsWhateverArrivesBetweenCycles) {
  for (bool on_change : {true, false}) {
    SCOPED_TRACE(on_change ? "statusword on change" : "statusword on every SYNC");
    Head h(on_change);
    auto tap = h.bus->attach();
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> angle(-0.3, 0.3);
    std::vector<Frame> frames;
    double targets[5] = {0, 0, 0, 0, 0};
    int64_t serial = 0, cycles = 0;
    for (; cycles < 400; ++cycles) {
      h.cycle(targets);
      for (const Frame& f : drain(*tap)) frames.push_back(f);
      for (int k = 0; k < 3; ++k) {  // new targets three times between two cycles
        for (double& t : targets) t = angle(rng);
        h.master.command(h.now, targets, ++serial);
        h.rack.handle_arrived(0);
        for (const Frame& f : drain(*tap)) frames.push_back(f);
      }
    }
    int syncs = 0, rises = 0;
    for (int n = 1; n <= 5; ++n) {
      bool high = false, ack_seen = false, ack_low_seen = true;
      int rises_this_period = 0;
      for (const Frame& f : frames) {
        uint16_t word = 0;
        int8_t mode = 0;
        if (f.id == cob::kSync) {
          rises_this_period = 0;
          if (n == 1) ++syncs;
        } else if (f.id == cob::tpdo1(n) && parse_tpdo1(f, word, mode)) {
          if ((word & pp::kSetPointAcknowledge) != 0)
            ack_seen = high;
          else
            ack_low_seen = ack_low_seen || !high;
        } else if (f.id == cob::rpdo1(n) && parse_rpdo1(f, word, mode) &&
                   (word & control::kEnableOperation) == control::kEnableOperation) {
          const bool bit4 = (word & pp::kNewSetPoint) != 0;
          if (bit4 && !high) {
            EXPECT_TRUE(ack_low_seen) << "node " << n << ": a set-point before the acknowledge was seen low";
            EXPECT_EQ(rises_this_period, 0) << "node " << n << ": two set-points in one SYNC period";
            ++rises_this_period;
            ++rises;
            high = true;
            ack_seen = false;
          } else if (!bit4 && high) {
            EXPECT_TRUE(ack_seen) << "node " << n << ": bit 4 low before the acknowledge";
            high = false;
            ack_low_seen = false;
          }
        }
      }
    }
    EXPECT_EQ(syncs, cycles) << "SYNC only at the cycles";
    EXPECT_GT(rises, 5 * 100) << "set-points flow";
  }
}

}  // namespace
}  // namespace saccade::can
