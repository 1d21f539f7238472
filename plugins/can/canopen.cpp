#include "canopen.hpp"

#include <algorithm>
#include <cmath>

namespace saccade::can {

const char* to_string(DriveState s) {
  switch (s) {
    case DriveState::kNotReadyToSwitchOn: return "not ready to switch on";
    case DriveState::kSwitchOnDisabled: return "switch on disabled";
    case DriveState::kReadyToSwitchOn: return "ready to switch on";
    case DriveState::kSwitchedOn: return "switched on";
    case DriveState::kOperationEnabled: return "operation enabled";
    case DriveState::kQuickStopActive: return "quick stop active";
    case DriveState::kFaultReactionActive: return "fault reaction active";
    case DriveState::kFault: return "fault";
    case DriveState::kUnknown: break;
  }
  return "unknown";
}

DriveState decode_statusword(uint16_t sw) {
  // CiA 402: the state is in bits 0-3, 5 and 6 (xxxx xxxx x65x 3210).
  if ((sw & 0x004F) == 0x0000) return DriveState::kNotReadyToSwitchOn;
  if ((sw & 0x004F) == 0x0040) return DriveState::kSwitchOnDisabled;
  if ((sw & 0x006F) == 0x0021) return DriveState::kReadyToSwitchOn;
  if ((sw & 0x006F) == 0x0023) return DriveState::kSwitchedOn;
  if ((sw & 0x006F) == 0x0027) return DriveState::kOperationEnabled;
  if ((sw & 0x006F) == 0x0007) return DriveState::kQuickStopActive;
  if ((sw & 0x004F) == 0x000F) return DriveState::kFaultReactionActive;
  if ((sw & 0x004F) == 0x0008) return DriveState::kFault;
  return DriveState::kUnknown;
}

uint16_t encode_statusword(DriveState s) {
  switch (s) {
    case DriveState::kNotReadyToSwitchOn: return 0x0000;
    case DriveState::kSwitchOnDisabled: return 0x0040;
    case DriveState::kReadyToSwitchOn: return 0x0031;
    case DriveState::kSwitchedOn: return 0x0033;
    case DriveState::kOperationEnabled: return 0x0037;
    case DriveState::kQuickStopActive: return 0x0017;
    case DriveState::kFaultReactionActive: return 0x001F;
    case DriveState::kFault: return 0x0018;
    case DriveState::kUnknown: break;
  }
  return 0xFFFF;
}

DriveState next_state(DriveState s, uint16_t cw) {
  // Commands by their bits (fault reset 7, enable operation 3, quick stop 2,
  // enable voltage 1, switch on 0), as the profile's transitions read them.
  const bool fault_reset = cw & 0x80;
  const bool disable_voltage = (cw & 0x02) == 0;
  const bool quick_stop = (cw & 0x06) == 0x02;
  const bool shutdown = (cw & 0x87) == 0x06;
  const bool switch_on = (cw & 0x8F) == 0x07;
  const bool enable = (cw & 0x8F) == 0x0F;
  switch (s) {
    case DriveState::kFault:
      return fault_reset ? DriveState::kSwitchOnDisabled : s;
    case DriveState::kSwitchOnDisabled:
      return shutdown ? DriveState::kReadyToSwitchOn : s;
    case DriveState::kReadyToSwitchOn:
      if (disable_voltage || quick_stop) return DriveState::kSwitchOnDisabled;
      if (switch_on) return DriveState::kSwitchedOn;
      if (enable) return DriveState::kOperationEnabled;  // 2 and 3 in one
      return s;
    case DriveState::kSwitchedOn:
      if (disable_voltage || quick_stop) return DriveState::kSwitchOnDisabled;
      if (shutdown) return DriveState::kReadyToSwitchOn;
      if (enable) return DriveState::kOperationEnabled;
      return s;
    case DriveState::kOperationEnabled:
      if (disable_voltage) return DriveState::kSwitchOnDisabled;
      if (quick_stop) return DriveState::kQuickStopActive;
      if (shutdown) return DriveState::kReadyToSwitchOn;
      if (switch_on) return DriveState::kSwitchedOn;
      return s;
    case DriveState::kQuickStopActive:
      if (disable_voltage) return DriveState::kSwitchOnDisabled;
      if (enable) return DriveState::kOperationEnabled;
      return s;
    default:
      return s;
  }
}

namespace {

Frame pdo(uint32_t id, uint16_t word, int32_t position) {
  Frame f;
  f.id = id;
  f.length = 6;
  f.data[0] = static_cast<uint8_t>(word & 0xFF);
  f.data[1] = static_cast<uint8_t>(word >> 8);
  const auto p = static_cast<uint32_t>(position);
  for (int i = 0; i < 4; ++i) f.data[static_cast<std::size_t>(2 + i)] = static_cast<uint8_t>(p >> (8 * i));
  return f;
}

}  // namespace

Frame rpdo1(int node, uint16_t controlword, int32_t target) { return pdo(cob::rpdo1(node), controlword, target); }
Frame tpdo1(int node, uint16_t statusword, int32_t actual) { return pdo(cob::tpdo1(node), statusword, actual); }

bool parse_pdo(const Frame& f, uint16_t& word, int32_t& position) {
  if (f.length != 6) return false;
  word = static_cast<uint16_t>(f.data[0] | (f.data[1] << 8));
  uint32_t p = 0;
  for (int i = 0; i < 4; ++i) p |= static_cast<uint32_t>(f.data[static_cast<std::size_t>(2 + i)]) << (8 * i);
  position = static_cast<int32_t>(p);
  return true;
}

Frame nmt_start(int node) {
  Frame f;
  f.id = cob::kNmt;
  f.length = 2;
  f.data[0] = 0x01;
  f.data[1] = static_cast<uint8_t>(node);
  return f;
}

Frame sync_frame() {
  Frame f;
  f.id = cob::kSync;
  return f;
}

int VirtualBus::attach() {
  std::lock_guard lock(mu_);
  queues_.emplace_back();
  return static_cast<int>(queues_.size()) - 1;
}

void VirtualBus::send(int from, const Frame& f) {
  std::lock_guard lock(mu_);
  for (std::size_t i = 0; i < queues_.size(); ++i)
    if (static_cast<int>(i) != from) queues_[i].push_back(f);
}

std::optional<Frame> VirtualBus::receive(int endpoint) {
  std::lock_guard lock(mu_);
  auto& q = queues_.at(static_cast<std::size_t>(endpoint));
  if (q.empty()) return std::nullopt;
  Frame f = q.front();
  q.pop_front();
  return f;
}

std::size_t VirtualBus::pending(int endpoint) {
  std::lock_guard lock(mu_);
  return queues_.at(static_cast<std::size_t>(endpoint)).size();
}

SimulatedDrive::SimulatedDrive(VirtualBus& bus, int node, double counts_per_second)
    : bus_(bus), endpoint_(bus.attach()), node_(node), speed_(counts_per_second) {}

void SimulatedDrive::step(double dt) {
  while (auto f = bus_.receive(endpoint_)) {
    if (f->id == cob::kNmt && f->length == 2 && f->data[0] == 0x01 && (f->data[1] == 0 || f->data[1] == node_)) {
      operational_ = true;
    } else if (f->id == cob::rpdo1(node_) && operational_) {
      uint16_t cw = 0;
      int32_t target = 0;
      if (!parse_pdo(*f, cw, target)) continue;
      state_ = next_state(state_, cw);
      target_ = target;
    } else if (f->id == cob::kSync && operational_) {
      bus_.send(endpoint_, tpdo1(node_, encode_statusword(state_), position()));
    }
  }
  if (fault_ && state_ != DriveState::kFault) {
    state_ = DriveState::kFault;
    fault_ = false;
  }
  if (state_ == DriveState::kOperationEnabled) {
    const double error = target_ - position_;
    const double move = std::clamp(error, -speed_ * dt, speed_ * dt);
    position_ += move;
  }
}

}  // namespace saccade::can
