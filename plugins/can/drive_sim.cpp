#include "drive_sim.hpp"

#include <algorithm>
#include <cmath>

namespace saccade::can {

namespace {
double sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }
}  // namespace

SimulatedDrive::SimulatedDrive(DriveConfig config) : config_(std::move(config)) {
  theta_ = reference_ = target_ = config_.initial_position;
  target_counts_ = pending_target_ = encoder();
}

void SimulatedDrive::reboot() {
  const DriveConfig config = config_;
  const double theta = theta_, omega = omega_;
  *this = SimulatedDrive(config);
  theta_ = reference_ = target_ = theta;  // the shaft does not jump back
  omega_ = omega;
}

int32_t SimulatedDrive::encoder() const { return static_cast<int32_t>(std::lround(theta_ * config_.counts_per_rad)); }

uint16_t SimulatedDrive::statusword() const {
  uint16_t sw = encode_statusword(state_) | pp::kRemote;
  if (state_ == DriveState::kOperationEnabled && std::abs(target_ - theta_) * config_.counts_per_rad <= 2.0 &&
      std::abs(omega_) * config_.counts_per_rad < 50.0)
    sw |= pp::kTargetReached;
  if (set_point_ack_) sw |= pp::kSetPointAcknowledge;
  if (following_error_) sw |= pp::kFollowingError;
  return sw;
}

void SimulatedDrive::send_status_on_change(Bus& out) {
  if (config_.tpdo1_transmission != transmission::kOnChange) return;
  if (nmt_ != NmtState::kOperational || silent_) {
    status_sent_ = -1;  // entering operational sends it again
    return;
  }
  const uint16_t sw = statusword();
  if (static_cast<int32_t>(sw) == status_sent_) return;
  out.send(tpdo1(config_.node, sw, mode_));
  status_sent_ = sw;
}

void SimulatedDrive::handle(const Frame& f, Bus& out) {
  if (silent_ || f.error || f.extended || f.rtr) return;
  const int n = config_.node;
  if (f.id == cob::kNmt) {
    if (f.length != 2 || (f.data[1] != 0 && f.data[1] != n)) return;
    switch (static_cast<NmtCommand>(f.data[0])) {
      case NmtCommand::kStart:
        nmt_ = NmtState::kOperational;
        status_sent_ = -1;  // an event-driven PDO is sent on (re)entering operational
        send_status_on_change(out);
        break;
      case NmtCommand::kStop: nmt_ = NmtState::kStopped; break;
      case NmtCommand::kPreOperational: nmt_ = NmtState::kPreOperational; break;
      case NmtCommand::kResetNode: reboot(); break;
      case NmtCommand::kResetCommunication:
        booted_ = false;
        nmt_ = NmtState::kBootUp;
        break;
    }
    return;
  }
  if (f.id == cob::sdo_request(n)) {
    if (nmt_ == NmtState::kPreOperational || nmt_ == NmtState::kOperational) handle_sdo(f, out);
    send_status_on_change(out);  // a controlword written by SDO
    return;
  }
  if (nmt_ != NmtState::kOperational) return;
  if (f.id == cob::kSync) {
    if (config_.tpdo1_transmission != transmission::kOnChange) out.send(tpdo1(n, statusword(), mode_));
    out.send(tpdo2(n, encoder(), static_cast<int32_t>(std::lround(omega_ * config_.counts_per_rad))));
  } else if (f.id == cob::rpdo2(n)) {
    int32_t target = 0;
    if (parse_rpdo2(f, target)) pending_target_ = target;
  } else if (f.id == cob::rpdo1(n)) {
    uint16_t cw = 0;
    int8_t mode = 0;
    if (!parse_rpdo1(f, cw, mode)) return;
    mode_ = mode;
    apply_controlword(cw);
    send_status_on_change(out);
  }
}

void SimulatedDrive::apply_controlword(uint16_t cw) {
  const uint16_t previous = controlword_;
  controlword_ = cw;
  const DriveState before = state_;
  // Fault reset acts on the bit's rising edge.
  if (state_ == DriveState::kFault) {
    if ((cw & control::kFaultReset) != 0 && (previous & control::kFaultReset) == 0) {
      state_ = DriveState::kSwitchOnDisabled;
      error_code_ = 0;
      following_error_ = false;
    }
    return;
  }
  state_ = next_state(state_, cw);
  if (state_ == DriveState::kOperationEnabled && before != DriveState::kOperationEnabled) {
    // Enabling holds where the shaft is: no jump toward an old target.
    reference_ = target_ = theta_;
    reference_velocity_ = integral_ = 0;
    target_counts_ = pending_target_ = encoder();
    set_point_ack_ = false;
  }
  if (state_ != DriveState::kOperationEnabled) return;
  const bool new_set_point = (cw & pp::kNewSetPoint) != 0;
  if (new_set_point && (previous & pp::kNewSetPoint) == 0 && mode_ == kProfilePositionMode) {
    // Every new set-point is taken at once ("change set immediately" or not:
    // the head streams set-points, it never queues them).
    target_counts_ = (cw & pp::kRelative) != 0 ? target_counts_ + pending_target_ : pending_target_;
    target_ = target_counts_ / config_.counts_per_rad;
    set_point_ack_ = true;
  } else if (!new_set_point) {
    set_point_ack_ = false;
  }
}

void SimulatedDrive::enter_fault(uint16_t code, Bus& out) {
  state_ = DriveState::kFault;
  error_code_ = code;
  if (!silent_) out.send(emergency(config_.node, code, 0x01));
}

void SimulatedDrive::handle_sdo(const Frame& f, Bus& out) {
  Sdo request;
  if (!parse_sdo(f, request)) return;
  Sdo answer;
  answer.index = request.index;
  answer.subindex = request.subindex;
  uint32_t abort = 0;
  if (request.kind == Sdo::Kind::kUploadRequest) {
    if (read_object(request.index, request.subindex, answer.value, answer.size, abort))
      answer.kind = Sdo::Kind::kUploadResponse;
  } else if (request.kind == Sdo::Kind::kDownloadRequest) {
    if (write_object(request.index, request.subindex, request.value, abort)) answer.kind = Sdo::Kind::kDownloadResponse;
  } else {
    abort = sdo_abort::kUnknownCommand;
  }
  if (abort != 0) {
    answer.kind = Sdo::Kind::kAbort;
    answer.value = abort;
  }
  out.send(sdo_frame(cob::sdo_response(config_.node), answer));
}

bool SimulatedDrive::read_object(uint16_t index, uint8_t sub, uint32_t& value, uint8_t& size, uint32_t& abort) const {
  size = 4;
  if (index == object::kTpdo1Communication) {
    size = 1;
    if (sub == 0 || sub == 2) {
      value = sub == 0 ? 2 : config_.tpdo1_transmission;  // sub 0: the highest sub-index
      return true;
    }
    abort = sdo_abort::kNoSubindex;
    return false;
  }
  if (index == object::kSoftwarePositionLimit) {
    if (sub == 0) {
      value = 2;
      size = 1;
      return true;
    }
    abort = sdo_abort::kNoSubindex;
    return false;
  }
  if (sub != 0) {
    abort = sdo_abort::kNoSubindex;
    return false;
  }
  switch (index) {
    case object::kProducerHeartbeatTime:
      value = config_.heartbeat_ms;
      size = 2;
      return true;
    case object::kControlword:
      value = controlword_;
      size = 2;
      return true;
    case object::kStatusword:
      value = statusword();
      size = 2;
      return true;
    case object::kModesOfOperation:
    case object::kModesOfOperationDisplay:
      value = static_cast<uint8_t>(mode_);
      size = 1;
      return true;
    case object::kPositionActual: value = static_cast<uint32_t>(encoder()); return true;
    case object::kVelocityActual:
      value = static_cast<uint32_t>(static_cast<int32_t>(std::lround(omega_ * config_.counts_per_rad)));
      return true;
    case object::kFollowingErrorWindow: value = config_.following_error_window; return true;
    case object::kFollowingErrorTimeout:
      value = config_.following_error_timeout_ms;
      size = 2;
      return true;
    case object::kTargetPosition: value = static_cast<uint32_t>(target_counts_); return true;
    case object::kProfileVelocity: value = config_.profile_velocity; return true;
    case object::kProfileAcceleration:
    case object::kProfileDeceleration: value = config_.profile_acceleration; return true;
    default: abort = sdo_abort::kNoObject; return false;
  }
}

bool SimulatedDrive::write_object(uint16_t index, uint8_t sub, uint32_t value, uint32_t& abort) {
  if (index == object::kTpdo1Communication) {
    // Only the two transmission types simulated: every SYNC, or on change.
    if (sub != 2) {
      abort = sub == 0 ? sdo_abort::kReadOnly : sdo_abort::kNoSubindex;
      return false;
    }
    if (value != transmission::kEverySync && value != transmission::kOnChange) {
      abort = sdo_abort::kValueTooHigh;
      return false;
    }
    config_.tpdo1_transmission = static_cast<uint8_t>(value);
    status_sent_ = -1;
    return true;
  }
  if (sub != 0) {
    abort = index == object::kSoftwarePositionLimit ? sdo_abort::kReadOnly : sdo_abort::kNoSubindex;
    return false;
  }
  switch (index) {
    case object::kProducerHeartbeatTime:
      if (value > 0xFFFF) break;
      config_.heartbeat_ms = static_cast<uint16_t>(value);
      next_heartbeat_ns_ = 0;  // from the next step on
      return true;
    case object::kModesOfOperation:
      if (static_cast<int8_t>(value) != kProfilePositionMode) {
        abort = sdo_abort::kValueTooHigh;  // only profile position is simulated
        return false;
      }
      mode_ = kProfilePositionMode;
      return true;
    case object::kFollowingErrorWindow: config_.following_error_window = value; return true;
    case object::kFollowingErrorTimeout:
      if (value > 0xFFFF) break;
      config_.following_error_timeout_ms = static_cast<uint16_t>(value);
      return true;
    case object::kProfileVelocity:
      if (value == 0) {
        abort = sdo_abort::kValueTooLow;
        return false;
      }
      config_.profile_velocity = value;
      return true;
    case object::kProfileAcceleration:
    case object::kProfileDeceleration:
      if (value == 0) {
        abort = sdo_abort::kValueTooLow;
        return false;
      }
      config_.profile_acceleration = value;
      return true;
    case object::kControlword: apply_controlword(static_cast<uint16_t>(value)); return true;
    case object::kTargetPosition: pending_target_ = static_cast<int32_t>(value); return true;
    case object::kStatusword:
    case object::kModesOfOperationDisplay:
    case object::kPositionActual:
    case object::kVelocityActual: abort = sdo_abort::kReadOnly; return false;
    default: abort = sdo_abort::kNoObject; return false;
  }
  abort = sdo_abort::kValueTooHigh;
  return false;
}

void SimulatedDrive::advance(int64_t now_ns, double dt, Bus& out) {
  if (!booted_) {
    booted_ = true;
    if (nmt_ == NmtState::kBootUp) nmt_ = NmtState::kPreOperational;  // an NMT command may have come first
    if (!silent_) out.send(heartbeat(config_.node, NmtState::kBootUp));
    next_heartbeat_ns_ = 0;
  }
  if (config_.heartbeat_ms > 0 && !silent_) {
    if (next_heartbeat_ns_ == 0) next_heartbeat_ns_ = now_ns;
    if (now_ns >= next_heartbeat_ns_) {
      out.send(heartbeat(config_.node, nmt_));
      next_heartbeat_ns_ += static_cast<int64_t>(config_.heartbeat_ms) * 1'000'000;
      if (next_heartbeat_ns_ <= now_ns)
        next_heartbeat_ns_ = now_ns + static_cast<int64_t>(config_.heartbeat_ms) * 1'000'000;
    }
  }
  if (injected_fault_ != 0 && state_ != DriveState::kFault) {
    enter_fault(injected_fault_, out);
    injected_fault_ = 0;
  }
  const int steps = std::max(1, static_cast<int>(std::lround(dt * config_.motor.loop_hz)));
  for (int i = 0; i < steps; ++i) substep(dt / steps);
  if (state_ == DriveState::kOperationEnabled) {
    const bool beyond = std::abs(reference_ - theta_) * config_.counts_per_rad > config_.following_error_window;
    following_error_ = beyond;
    if (!beyond) {
      following_error_since_ns_ = -1;
    } else if (following_error_since_ns_ < 0) {
      following_error_since_ns_ = now_ns;
    } else if (now_ns - following_error_since_ns_ >=
               static_cast<int64_t>(config_.following_error_timeout_ms) * 1'000'000) {
      enter_fault(emcy::kFollowingError, out);
      following_error_since_ns_ = -1;
    }
  }
  send_status_on_change(out);
}

void SimulatedDrive::substep(double h) {
  const MotorModel& m = config_.motor;
  const bool enabled = state_ == DriveState::kOperationEnabled || state_ == DriveState::kQuickStopActive;
  double torque = 0;
  if (enabled) {
    // The profile generator: toward the target within the profile's velocity
    // and acceleration, braking in time; quick stop and halt brake to rest.
    const double vmax = config_.profile_velocity / config_.counts_per_rad;
    const double amax = config_.profile_acceleration / config_.counts_per_rad;
    const bool stop = state_ == DriveState::kQuickStopActive || (controlword_ & pp::kHalt) != 0;
    const double e = target_ - reference_;
    const double wanted = stop ? 0.0 : sign(e) * std::min(vmax, std::sqrt(2 * amax * std::abs(e)));
    const double dv = std::clamp(wanted - reference_velocity_, -amax * h, amax * h);
    reference_velocity_ += dv;
    reference_ += reference_velocity_ * h;
    if (!stop && std::abs(target_ - reference_) < 0.5 / config_.counts_per_rad &&
        std::abs(reference_velocity_) <= amax * h) {
      reference_ = target_;
      reference_velocity_ = 0;
    }
    if (stop && reference_velocity_ == 0) target_ = reference_;
    // PID on the reference, derivative on the velocity error, with the
    // feed-forward a tuned drive has (inertia, friction); the integral only
    // grows while the output is not saturated in the same direction.
    const double error = reference_ - theta_;
    const double feed_forward =
        m.inertia * dv / h + m.viscous * reference_velocity_ + m.coulomb * sign(reference_velocity_);
    const double unsaturated = feed_forward + m.kp * error + m.ki * integral_ + m.kd * (reference_velocity_ - omega_);
    torque = std::clamp(unsaturated, -m.torque_limit, m.torque_limit);
    if (torque == unsaturated || sign(error) != sign(unsaturated)) integral_ += error * h;
  } else {
    integral_ = 0;
  }
  // The plant: inertia, viscous and Coulomb friction (sticking below it).
  const double drive = torque + disturbance_ - m.viscous * omega_;
  if (omega_ == 0 && std::abs(drive) <= m.coulomb) return;
  const double friction = m.coulomb * sign(omega_ != 0 ? omega_ : drive);
  double omega = omega_ + (drive - friction) / m.inertia * h;
  if (omega_ != 0 && sign(omega) != sign(omega_) && std::abs(drive) <= m.coulomb) omega = 0;
  omega_ = std::clamp(omega, -m.velocity_limit, m.velocity_limit);
  theta_ += omega_ * h;
}

DriveRack::DriveRack(std::unique_ptr<Bus> bus, std::vector<DriveConfig> drives) : bus_(std::move(bus)) {
  drives_.reserve(drives.size());
  for (auto& d : drives) drives_.emplace_back(std::move(d));
  // Only what concerns these drives: NMT, SYNC, and their SDO and RPDOs.
  FilterSet filters;
  filters.filters = {Filter::exact(cob::kNmt), Filter::exact(cob::kSync)};
  for (const auto& d : drives_)
    for (uint32_t id : {cob::sdo_request(d.node()), cob::rpdo1(d.node()), cob::rpdo2(d.node())})
      filters.filters.push_back(Filter::exact(id));
  bus_->set_filters(std::move(filters));
}

void DriveRack::step(int64_t now_ns, double dt, int64_t wait_ns) {
  Frame f;
  bool first = true;
  while (bus_->receive(f, first ? wait_ns : 0)) {
    first = false;
    for (auto& d : drives_) d.handle(f, *bus_);
  }
  for (auto& d : drives_) d.advance(now_ns, dt, *bus_);
  bus_->flush();
}

bool DriveRack::handle_arrived(int64_t wait_ns) {
  Frame f;
  bool any = false;
  while (bus_->receive(f, any ? 0 : wait_ns)) {
    any = true;
    for (auto& d : drives_) d.handle(f, *bus_);
  }
  if (any) bus_->flush();
  return any;
}

}  // namespace saccade::can
