#include "master.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace saccade::can {

const char* to_string(DriveHealth h) {
  switch (h) {
    case DriveHealth::kStarting: return "starting";
    case DriveHealth::kReady: return "ready";
    case DriveHealth::kFault: return "fault";
    case DriveHealth::kSilent: return "silent";
  }
  return "?";
}

namespace {
uint32_t counts(double value, double counts_per_rad) {
  return static_cast<uint32_t>(std::lround(std::abs(value * counts_per_rad)));
}
std::string hex(uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}
}  // namespace

Master::Master(Bus& bus, MasterConfig config) : bus_(bus), config_(std::move(config)) {
  FilterSet filters;
  filters.filters.clear();
  for (const JointDrive& j : config_.joints) {
    Drive d;
    d.joint = j;
    const double cpr = j.counts_per_rad;
    d.writes = {
        {object::kModesOfOperation, 0, static_cast<uint8_t>(kProfilePositionMode), 1},
        {object::kProfileVelocity, 0, counts(config_.profile_velocity, cpr), 4},
        {object::kProfileAcceleration, 0, counts(config_.profile_acceleration, cpr), 4},
        {object::kProfileDeceleration, 0, counts(config_.profile_acceleration, cpr), 4},
        {object::kFollowingErrorWindow, 0, counts(config_.following_error_window, cpr), 4},
        {object::kFollowingErrorTimeout, 0, config_.following_error_timeout_ms, 2},
        {object::kProducerHeartbeatTime, 0, config_.heartbeat_ms, 2},
    };
    if (config_.statusword_on_change) d.writes.push_back({object::kTpdo1Communication, 2, transmission::kOnChange, 1});
    drives_.push_back(std::move(d));
    for (uint32_t id : {cob::tpdo1(j.node), cob::tpdo2(j.node), cob::sdo_response(j.node), cob::heartbeat(j.node),
                        cob::emergency(j.node)})
      filters.filters.push_back(Filter::exact(id));
  }
  bus_.set_filters(std::move(filters));
}

std::string Master::who(const Drive& d) const {
  return (d.joint.name.empty() ? "joint" : d.joint.name) + " (node " + std::to_string(d.joint.node) + ")";
}

bool Master::all_ready() const {
  for (const Drive& d : drives_)
    if (d.phase != Phase::kRun || d.state != DriveState::kOperationEnabled) return false;
  return !drives_.empty();
}

void Master::restart_configuration(Drive& d) {
  d.phase = Phase::kConfigure;
  d.step = 0;
  d.sdo_sent_ns = -1;
  d.attempts = 0;
}

void Master::send(const Frame& f) {
  if (bus_.send(f)) stats_.bits_last_cycle += frame_bits(f);
}

void Master::receive(const Frame& f, int64_t now_ns) {
  stats_.bits_last_cycle += frame_bits(f);
  const int node = cob::node_of(f.id);
  Drive* d = nullptr;
  for (Drive& x : drives_)
    if (x.joint.node == node) d = &x;
  if (d == nullptr) return;
  const uint32_t function = cob::function_of(f.id);
  if (function == 0x700 && f.length >= 1) {
    d->heartbeat_ns = now_ns;
    if (static_cast<NmtState>(f.data[0]) == NmtState::kBootUp) {
      // It (re)booted: power, watchdog, or powered up after we gave up on it.
      // Whatever we had written is gone and its SDO server is listening now.
      if (d->phase != Phase::kConfigure || d->step > 0) d->problem = who(*d) + ": booted, configuring again";
      restart_configuration(*d);
    }
  } else if (f.id == cob::tpdo1(node)) {
    int8_t mode = 0;
    if (parse_tpdo1(f, d->statusword, mode)) {
      d->status_ns = now_ns;
      d->state = decode_statusword(d->statusword);
      if (!d->set_point_high && (d->statusword & pp::kSetPointAcknowledge) == 0) d->ack_low_seen = true;
    }
  } else if (f.id == cob::tpdo2(node)) {
    if (parse_tpdo2(f, d->position, d->velocity)) d->updated_ns = now_ns;
  } else if (f.id == cob::emergency(node) && f.length == 8) {
    d->error_code = static_cast<uint16_t>(f.data[0] | f.data[1] << 8);
    if (d->error_code != emcy::kNoError) ++stats_.emergencies;
  } else if (f.id == cob::sdo_response(node) && d->phase == Phase::kConfigure && d->sdo_sent_ns >= 0) {
    Sdo answer;
    if (!parse_sdo(f, answer) || d->step >= d->writes.size()) return;
    const Write& w = d->writes[d->step];
    if (answer.index != w.index || answer.subindex != w.sub) return;  // a late answer to an earlier request
    if (answer.kind == Sdo::Kind::kDownloadResponse) {
      ++d->step;
      d->sdo_sent_ns = -1;
      d->attempts = 0;
    } else if (answer.kind == Sdo::Kind::kAbort) {
      d->phase = Phase::kSilent;
      d->problem = who(*d) + ": SDO write of " + hex(w.index, 4) + " refused: " + sdo_abort_text(answer.value);
    }
  }
}

// Walks a configured drive's CiA 402 state machine to operation enabled.
void Master::enable(Drive& d, int64_t now_ns) {
  // An event-driven statusword that was lost (or the NMT start itself) is
  // not sent again by itself: with no statusword for an SDO timeout, start
  // the drive again, which makes it report its statusword (harmless when
  // it is operational already).
  if (d.state != DriveState::kFault &&
      now_ns - std::max({d.status_ns, d.configured_ns, d.restarted_ns}) > config_.sdo_timeout_ns) {
    send(nmt(NmtCommand::kStart, d.joint.node));
    d.restarted_ns = now_ns;
    return;
  }
  if (d.reset_sent) {
    send(rpdo1(d.joint.node, control::kDisableVoltage));  // fault reset back to 0 for the next edge
    d.reset_sent = false;
    return;
  }
  switch (d.state) {
    case DriveState::kSwitchOnDisabled: send(rpdo1(d.joint.node, control::kShutdown)); break;
    case DriveState::kReadyToSwitchOn: send(rpdo1(d.joint.node, control::kSwitchOn)); break;
    case DriveState::kSwitchedOn:
    case DriveState::kQuickStopActive: send(rpdo1(d.joint.node, control::kEnableOperation)); break;
    case DriveState::kOperationEnabled:
      d.phase = Phase::kRun;
      d.problem.clear();  // whatever it was (a reboot, a reset fault) is over
      d.set_point_high = false;
      d.ack_low_seen = true;  // enabling clears the acknowledge
      break;
    default: break;  // fault (until reset), or no statusword yet
  }
}

void Master::run_drive(Drive& d, int64_t now_ns, const double* target, bool reset, int64_t serial) {
  if (reset && (d.phase == Phase::kSilent || d.state == DriveState::kFault)) {
    d.problem.clear();
    d.error_code = 0;
    if (d.phase == Phase::kSilent) {
      restart_configuration(d);
      d.heartbeat_ns = d.updated_ns = -1;
    } else {
      send(rpdo1(d.joint.node, control::kFaultReset));  // acts on the bit's rising edge
      d.reset_sent = true;
      d.phase = Phase::kEnable;
      return;
    }
  }
  switch (d.phase) {
    case Phase::kConfigure: {
      if (d.step == d.writes.size()) {
        send(nmt(NmtCommand::kStart, d.joint.node));
        d.phase = Phase::kEnable;
        d.configured_ns = now_ns;
        d.state = DriveState::kUnknown;
        return;
      }
      if (d.sdo_sent_ns >= 0 && now_ns - d.sdo_sent_ns < config_.sdo_timeout_ns) return;
      if (d.sdo_sent_ns >= 0) ++stats_.sdo_timeouts;
      if (d.attempts >= config_.sdo_attempts) {
        d.phase = Phase::kSilent;
        d.problem = who(d) + ": no answer to the SDO write of " + hex(d.writes[d.step].index, 4) + " (" +
                    std::to_string(config_.sdo_attempts) + " attempts)";
        return;
      }
      const Write& w = d.writes[d.step];
      Sdo request;
      request.kind = Sdo::Kind::kDownloadRequest;
      request.index = w.index;
      request.subindex = w.sub;
      request.value = w.value;
      request.size = w.size;
      send(sdo_frame(cob::sdo_request(d.joint.node), request));
      d.sdo_sent_ns = now_ns;
      ++d.attempts;
      return;
    }
    case Phase::kEnable: enable(d, now_ns); return;
    case Phase::kRun: {
      if (d.state != DriveState::kOperationEnabled) {
        if (d.state != DriveState::kFault) d.phase = Phase::kEnable;  // switched off behind our back
        return;
      }
      set_point(d, target, serial, true);
      return;
    }
    case Phase::kSilent: return;
  }
}

bool Master::set_point(Drive& d, const double* target, int64_t serial, bool routine) {
  const uint16_t run = control::kEnableOperation | pp::kChangeSetImmediately;
  const bool lost = stats_.cycles - d.set_point_cycle > 5;  // no answer for 5 periods: go on without it
  if (d.set_point_high) {
    const bool acknowledged = (d.statusword & pp::kSetPointAcknowledge) != 0;
    if (acknowledged || lost) {
      // Bit 4 low, so the next set-point is a new edge; the next rises once
      // the drive shows the acknowledge low again.
      if (acknowledged) ++stats_.acknowledged;
      send(rpdo1(d.joint.node, run));
      d.set_point_high = false;
      d.ack_low_seen = !acknowledged;
    }
    return false;
  }
  if (target == nullptr || (!d.ack_low_seen && !lost)) return false;
  if (stats_.cycles - d.set_point_cycle < (routine ? 2 : 1)) return false;  // one per SYNC period; routine every second
  if (!routine && d.serial >= serial) return false;                         // it has these already
  const double c = std::round(*target * d.joint.counts_per_rad) + d.joint.zero_counts;
  send(rpdo2(d.joint.node, static_cast<int32_t>(std::clamp(c, -2147483648.0, 2147483647.0))));
  send(rpdo1(d.joint.node, run | pp::kNewSetPoint));
  d.set_point_high = true;
  d.set_point_cycle = stats_.cycles;
  d.serial = std::max(d.serial, serial);
  ++stats_.set_points;
  return true;
}

bool Master::running(const Drive& d) const {
  return d.phase == Phase::kRun && d.state == DriveState::kOperationEnabled;
}

void Master::drain(int64_t now_ns, int64_t wait_ns) {
  Frame f;
  bool first = true;
  while (bus_.receive(f, first ? wait_ns : 0)) {
    first = false;
    if (!f.error) receive(f, now_ns);
  }
}

int Master::command(int64_t now_ns, const double* targets, int64_t serial, int64_t wait_ns) {
  drain(now_ns, wait_ns);
  int sent = 0;
  for (std::size_t i = 0; i < drives_.size(); ++i)
    if (running(drives_[i]) && set_point(drives_[i], targets != nullptr ? &targets[i] : nullptr, serial, false)) ++sent;
  bus_.flush();
  return sent;
}

bool Master::commanded(int64_t serial) const {
  bool any = false;
  for (const Drive& d : drives_) {
    if (!running(d)) continue;
    if (d.serial < serial) return false;
    any = true;
  }
  return any;
}

JointFeedback Master::joint_feedback(const Drive& d) const {
  JointFeedback out;
  out.position = (d.position - d.joint.zero_counts) / d.joint.counts_per_rad;
  out.velocity = d.velocity / d.joint.counts_per_rad;
  out.state = d.state;
  out.updated_ns = d.updated_ns;
  out.error_code = d.error_code;
  if (d.phase == Phase::kSilent) {
    out.health = DriveHealth::kSilent;
  } else if (d.state == DriveState::kFault || d.state == DriveState::kFaultReactionActive) {
    out.health = DriveHealth::kFault;
  } else if (d.phase == Phase::kRun && d.state == DriveState::kOperationEnabled && d.updated_ns >= 0) {
    out.health = DriveHealth::kReady;
  } else {
    out.health = DriveHealth::kStarting;
  }
  return out;
}

void Master::feedback(std::vector<JointFeedback>& out) const {
  out.resize(drives_.size());
  for (std::size_t i = 0; i < drives_.size(); ++i) out[i] = joint_feedback(drives_[i]);
}

void Master::cycle(int64_t now_ns, const double* targets, int64_t reset, std::vector<JointFeedback>& feedback,
                   int64_t wait_ns, int64_t serial) {
  stats_.bits_last_cycle = 0;
  drain(now_ns, wait_ns);
  if (first_cycle_) {
    // Whatever state the drives were left in: pre-operational, so SDO works and PDOs wait.
    send(nmt(NmtCommand::kPreOperational, 0));
    first_cycle_ = false;
  }
  const bool do_reset = reset != reset_seen_;
  reset_seen_ = reset;
  feedback.resize(drives_.size());
  problem_.clear();
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    Drive& d = drives_[i];
    // Supervision: heartbeats once configured, process data once running.
    if (d.phase == Phase::kEnable || d.phase == Phase::kRun) {
      const int64_t since = d.heartbeat_ns >= 0 ? d.heartbeat_ns : d.configured_ns;
      if (config_.heartbeat_ms > 0 && now_ns - since > config_.heartbeat_timeout_ns) {
        d.phase = Phase::kSilent;
        d.problem = who(d) + ": no heartbeat for " + std::to_string((now_ns - since) / 1'000'000) + " ms";
      } else if (d.phase == Phase::kRun && d.updated_ns >= 0 && now_ns - d.updated_ns > config_.feedback_timeout_ns) {
        d.phase = Phase::kSilent;
        d.problem = who(d) + ": no position for " + std::to_string((now_ns - d.updated_ns) / 1'000'000) + " ms";
      }
    }
    run_drive(d, now_ns, targets != nullptr ? &targets[i] : nullptr, do_reset, serial);
    JointFeedback& out = feedback[i];
    out = joint_feedback(d);
    if (out.health == DriveHealth::kFault && d.problem.empty())
      d.problem = who(d) + ": drive fault" + (d.error_code ? ", emergency " + hex(d.error_code, 4) : std::string());
    if (problem_.empty() && out.health != DriveHealth::kReady && out.health != DriveHealth::kStarting)
      problem_ = d.problem;
  }
  send(sync_frame());
  bus_.flush();
  ++stats_.cycles;
}

}  // namespace saccade::can
