// CANopen / CiA 402 for the head's drives: statusword and controlword, PDO
// bytes, and a simulated drive enabled, moved, faulted and reset over the
// virtual bus.
#include <gtest/gtest.h>

#include "canopen.hpp"

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
  EXPECT_EQ(next_state(S::kSwitchOnDisabled, control::kEnableOperation), S::kSwitchOnDisabled) << "needs shutdown first";
  EXPECT_EQ(next_state(S::kReadyToSwitchOn, control::kSwitchOn), S::kSwitchedOn);
  EXPECT_EQ(next_state(S::kSwitchedOn, control::kEnableOperation), S::kOperationEnabled);
  EXPECT_EQ(next_state(S::kOperationEnabled, control::kDisableOperation), S::kSwitchedOn);
  EXPECT_EQ(next_state(S::kOperationEnabled, control::kQuickStop), S::kQuickStopActive);
  EXPECT_EQ(next_state(S::kOperationEnabled, control::kDisableVoltage), S::kSwitchOnDisabled);
  EXPECT_EQ(next_state(S::kQuickStopActive, control::kDisableVoltage), S::kSwitchOnDisabled);
  EXPECT_EQ(next_state(S::kFault, control::kEnableOperation), S::kFault) << "a fault holds until reset";
  EXPECT_EQ(next_state(S::kFault, control::kFaultReset), S::kSwitchOnDisabled);
}

TEST(Pdo, LittleEndianBytesOnTheNodesCobId) {
  const Frame f = rpdo1(3, control::kEnableOperation, -2);
  EXPECT_EQ(f.id, 0x203u);
  ASSERT_EQ(f.length, 6);
  const std::array<uint8_t, 6> want = {0x0F, 0x00, 0xFE, 0xFF, 0xFF, 0xFF};
  EXPECT_TRUE(std::equal(want.begin(), want.end(), f.data.begin()));
  uint16_t word = 0;
  int32_t position = 0;
  ASSERT_TRUE(parse_pdo(tpdo1(5, 0x0637, 123456), word, position));
  EXPECT_EQ(word, 0x0637);
  EXPECT_EQ(position, 123456);
  EXPECT_EQ(tpdo1(5, 0, 0).id, 0x185u);
  Frame short_frame;
  short_frame.length = 2;
  EXPECT_FALSE(parse_pdo(short_frame, word, position));
}

// The master's side of one exchange: SYNC, then the drive's TPDO1.
struct Master {
  VirtualBus& bus;
  int endpoint;
  explicit Master(VirtualBus& b) : bus(b), endpoint(b.attach()) {}
  void send(const Frame& f) { bus.send(endpoint, f); }
  std::pair<DriveState, int32_t> poll(SimulatedDrive& drive, double dt) {
    drive.step(dt);
    send(sync_frame());
    drive.step(0);
    std::optional<Frame> f;
    std::pair<DriveState, int32_t> last{DriveState::kUnknown, 0};
    while ((f = bus.receive(endpoint))) {
      uint16_t sw = 0;
      int32_t p = 0;
      if (f->id == cob::tpdo1(4) && parse_pdo(*f, sw, p)) last = {decode_statusword(sw), p};
    }
    return last;
  }
};

TEST(SimulatedDrive, EnablesMovesFaultsAndResetsOverTheVirtualBus) {
  VirtualBus bus;
  SimulatedDrive drive(bus, 4, 20000);
  Master master(bus);
  // Before NMT start the drive is silent.
  EXPECT_EQ(master.poll(drive, 0.01).first, DriveState::kUnknown);
  master.send(nmt_start(4));
  EXPECT_EQ(master.poll(drive, 0.01).first, DriveState::kSwitchOnDisabled);
  for (uint16_t cw : {control::kShutdown, control::kSwitchOn, control::kEnableOperation}) {
    master.send(rpdo1(4, cw, 0));
    master.poll(drive, 0.001);
  }
  EXPECT_EQ(master.poll(drive, 0.001).first, DriveState::kOperationEnabled);
  // A target 1000 counts away at 20000 counts/s: 50 ms, never faster.
  master.send(rpdo1(4, control::kEnableOperation, 1000));
  int32_t previous = 0;
  for (int k = 0; k < 10; ++k) {
    const auto [state, position] = master.poll(drive, 0.005);
    EXPECT_EQ(state, DriveState::kOperationEnabled);
    EXPECT_LE(position - previous, 100 + 1);
    previous = position;
  }
  EXPECT_EQ(master.poll(drive, 0.005).second, 1000);
  // A fault stops it and holds until reset.
  drive.inject_fault();
  master.send(rpdo1(4, control::kEnableOperation, -500));
  EXPECT_EQ(master.poll(drive, 0.01).first, DriveState::kFault);
  EXPECT_EQ(master.poll(drive, 0.01).second, 1000) << "no motion in fault";
  master.send(rpdo1(4, control::kFaultReset, 1000));
  EXPECT_EQ(master.poll(drive, 0.01).first, DriveState::kSwitchOnDisabled);
}

}  // namespace
}  // namespace saccade::can
