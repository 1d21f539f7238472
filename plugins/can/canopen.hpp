#pragma once
// CAN frames, CANopen addressing and the CiA 402 drive profile: the power
// state machine (statusword decoding, controlword commands), the process
// data the head uses (RPDO1: controlword + target position; TPDO1:
// statusword + actual position), an in-process virtual bus, and a simulated
// drive that answers like a motor controller. Plain code; the CAN plugin,
// the UDP tunnel and SocketCAN (issue 4) build on it.
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace saccade::can {

struct Frame {
  uint32_t id = 0;  // 11-bit
  uint8_t length = 0;
  std::array<uint8_t, 8> data{};
  bool operator==(const Frame& o) const {
    return id == o.id && length == o.length && std::equal(data.begin(), data.begin() + length, o.data.begin());
  }
};

// CANopen COB-IDs of node n (1..127).
namespace cob {
constexpr uint32_t kNmt = 0x000, kSync = 0x080;
constexpr uint32_t emergency(int n) { return 0x080 + static_cast<uint32_t>(n); }
constexpr uint32_t tpdo1(int n) { return 0x180 + static_cast<uint32_t>(n); }
constexpr uint32_t rpdo1(int n) { return 0x200 + static_cast<uint32_t>(n); }
constexpr uint32_t heartbeat(int n) { return 0x700 + static_cast<uint32_t>(n); }
}  // namespace cob

// CiA 402 power states, decoded from the statusword.
enum class DriveState {
  kNotReadyToSwitchOn, kSwitchOnDisabled, kReadyToSwitchOn, kSwitchedOn, kOperationEnabled, kQuickStopActive,
  kFaultReactionActive, kFault, kUnknown
};
const char* to_string(DriveState s);
DriveState decode_statusword(uint16_t statusword);
uint16_t encode_statusword(DriveState s);  // the state's bits (bit 4 voltage enabled set where the profile has it)

// Controlword commands.
namespace control {
constexpr uint16_t kShutdown = 0x0006, kSwitchOn = 0x0007, kEnableOperation = 0x000F, kDisableVoltage = 0x0000,
                   kQuickStop = 0x0002, kDisableOperation = 0x0007, kFaultReset = 0x0080;
}

// The drive's next state for a controlword (the CiA 402 transitions); the
// state itself where the command does not apply.
DriveState next_state(DriveState s, uint16_t controlword);

// RPDO1 / TPDO1 of the head's drives, little-endian as CANopen is.
Frame rpdo1(int node, uint16_t controlword, int32_t target_position);
Frame tpdo1(int node, uint16_t statusword, int32_t actual_position);
bool parse_pdo(const Frame& f, uint16_t& word, int32_t& position);  // false: wrong length
Frame nmt_start(int node);  // node 0: all
Frame sync_frame();

// An in-process bus: every frame sent by one endpoint is delivered to every
// other endpoint's queue. Thread-safe.
class VirtualBus {
 public:
  int attach();  // a new endpoint's id
  void send(int from, const Frame& f);
  std::optional<Frame> receive(int endpoint);
  std::size_t pending(int endpoint);

 private:
  std::mutex mu_;
  std::vector<std::deque<Frame>> queues_;
};

// A motor controller on the bus: NMT start, the CiA 402 state machine driven
// by RPDO1's controlword, its position following the target at a bounded
// speed while operation is enabled, TPDO1 on every SYNC, and faults on demand.
class SimulatedDrive {
 public:
  SimulatedDrive(VirtualBus& bus, int node, double counts_per_second = 20000);
  // Handles the frames waiting for it, then advances its motion by dt seconds.
  void step(double dt);
  void inject_fault() { fault_ = true; }
  DriveState state() const { return state_; }
  int32_t position() const { return static_cast<int32_t>(position_); }

 private:
  VirtualBus& bus_;
  int endpoint_, node_;
  double speed_;
  bool operational_ = false, fault_ = false;
  DriveState state_ = DriveState::kSwitchOnDisabled;
  double position_ = 0;
  int32_t target_ = 0;
};

}  // namespace saccade::can
