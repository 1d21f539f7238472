// The head's CAN side as nodes: `can.driver` (the CANopen master: joint
// targets in, joint state out, one control cycle per call, SYNC producer and
// so the control loop's clock) and `can.drives` (simulated CiA 402 drives on
// a bus: run in the same graph, or alone in a graph of their own on the
// robot-PC end of a UDP tunnel), and `can.tap` / `can.send`: a bus's frames
// as CanFrames messages, to watch or bridge a bus from another process or PC.
#include <algorithm>
#include <array>
#include <atomic>
#include <iterator>
#include <optional>
#include <sstream>

#include "cannelloni.hpp"
#include "drive_sim.hpp"
#include "master.hpp"
#include "saccade/log.hpp"
#include "saccade/plugin.hpp"
#include "saccade/stats.hpp"
#include "virtual_bus.hpp"

namespace {

using namespace saccade;

// `item` as a number, read as std::stod reads it, with nothing but blanks
// after it; nothing when it is not one.
std::optional<double> number(const std::string& item) {
  try {
    std::size_t used = 0;
    const double value = std::stod(item, &used);
    if (item.find_first_not_of(" \t", used) == std::string::npos) return value;
  } catch (const std::exception&) {  // std::stod's way of saying "not a number" or "out of range"
  }
  return std::nullopt;
}

// "1,2,3" -> numbers; `count` values, or one value repeated (count 0: any
// number of them). The error names the parameter `name` and what is wrong.
Result<std::vector<double>> parse_list(const std::string& text, std::size_t count, const std::string& name) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const std::optional<double> value = number(item);
    if (!value)
      return Status::error(name + ": '" + item + "' is not a number (expected a comma list such as 1,2,3,4,5)");
    out.push_back(*value);
  }
  if (out.size() == 1 && count > 1) out.assign(count, out[0]);
  if (count > 0 && out.size() != count)
    return Status::error(name + ": " + std::to_string(out.size()) + " values, expected " + std::to_string(count) +
                         " (or one for all)");
  return out;
}

constexpr const char* kBusSpecDoc =
    "virtual:NAME (in-process), udp:[BIND_ADDR:]LOCAL_PORT:HOST:PORT (cannelloni tunnel: bound to BIND_ADDR, or "
    "to loopback for a loopback peer, else to the address that routes to the peer; packets from anyone but "
    "HOST:PORT are dropped and counted) or socketcan:IFNAME";
constexpr const char* kKeyFileDoc =
    "udp bus: a file holding the link's shared key (64 hex characters, e.g. from openssl rand -hex 32; readable "
    "by its owner only), the same at both ends: every packet then carries an HMAC-SHA256 tag, the sender's "
    "session and a counter, and packets without a valid tag, replayed or of an earlier session are dropped and "
    "counted. Empty: not authenticated (as a real cannelloni bridge)";

// Every counter of a bus in the node's stats, as bus_<name>, brought up to
// date by publish() (each cycle, and at close).
class BusStats {
 public:
  void open(OpenContext& ctx) {
    for (std::size_t i = 0; i < std::size(can::kBusCounterFields); ++i)
      counters_[i] = &ctx.counter(std::string("bus_") + can::kBusCounterFields[i].name);
  }
  void publish(const can::Bus* bus) {
    if (bus == nullptr || counters_[0] == nullptr) return;
    const can::BusCounters& c = bus->counters();
    for (std::size_t i = 0; i < std::size(can::kBusCounterFields); ++i)
      counters_[i]->store(c.*can::kBusCounterFields[i].field, std::memory_order_relaxed);
  }

 private:
  std::array<std::atomic<uint64_t>*, std::size(can::kBusCounterFields)> counters_{};
};

// Parameters both nodes share: the bus, the joints' nodes and units, the clock.
struct CommonConfig {
  std::string bus = "virtual:head";
  std::string nodes = "1,2,3,4,5";
  std::string counts_per_rad = "20000";
  std::string zero_counts = "0";
  double rate = 250.0;
  bool realtime = true;
  double duration = 0.0;
  double wait_ms = 0.0;
  double loss = 0.0;
  double latency_ms = 0.0;
  double duplicate = 0.0, reorder = 0.0, corrupt = 0.0;
  int fault_seed = 1;
  std::string key_file;
};

void bind_common(ParamBinder<CommonConfig>& b) {
  using C = CommonConfig;
  b.field("bus", kBusSpecDoc, &C::bus)
      .field("nodes", "CANopen node ids of the joints: neck, vergence left, tilt left, vergence right, tilt right",
             &C::nodes)
      .field("counts_per_rad", "encoder counts per radian at the joint (one value, or one per joint)",
             &C::counts_per_rad)
      .field("zero_counts", "encoder reading at joint angle 0 (one value, or one per joint)", &C::zero_counts)
      .field("rate", {1.0, 10000.0}, "control cycles per second", &C::rate)
      .field("realtime", "pace the cycles on the wall clock (false: as fast as the graph runs, simulated time)",
             &C::realtime)
      .field("duration", {0.0, 1e9}, "stop after this many seconds of control time (0: never)", &C::duration)
      .field("wait_ms", {0.0, 1000.0}, "wait this long for the first frame of a cycle (a tunnel's packets in flight)",
             &C::wait_ms)
      .field("loss", {0.0, 1.0}, "fault injection: the probability that a frame (virtual) or packet (udp) is lost",
             &C::loss)
      .field("latency_ms", {0.0, 1000.0}, "fault injection on a virtual bus: every frame arrives this much later",
             &C::latency_ms)
      .field("duplicate", {0.0, 1.0},
             "fault injection on a udp bus: the probability that a packet sent goes twice "
             "(counted in bus_duplicated)",
             &C::duplicate)
      .field("reorder", {0.0, 1.0},
             "fault injection on a udp bus: the probability that a packet sent is held back "
             "to go after the next one (bus_reordered)",
             &C::reorder)
      .field("corrupt", {0.0, 1.0},
             "fault injection on a udp bus: the probability that a packet sent has one byte "
             "altered (bus_corrupted; with a key_file the receiver drops it as unauthenticated)",
             &C::corrupt)
      .field("fault_seed", {0, 1000000000},
             "fault injection: the seed of the loss, duplicate, reorder and corrupt "
             "draws",
             &C::fault_seed)
      .field("key_file", kKeyFileDoc, &C::key_file);
}

struct Clock {
  double period_s = 0.004;
  bool realtime = true;
  int64_t ticks = -1, start_ns = 0, stop_after = 0;
  int64_t time_of(int64_t tick) const { return static_cast<int64_t>(static_cast<double>(tick) * period_s * 1e9); }
  // The steady time the next tick is due (realtime, once started).
  int64_t next_due() const { return start_ns + time_of(ticks + 1); }
  // The next tick's time (ns since the start), after `wait(steady_ns)` has
  // waited for it in realtime (false: stopped); -1 when done.
  template <class Wait>
  int64_t next(Wait&& wait) {
    ++ticks;
    if (stop_after > 0 && ticks >= stop_after) return -1;
    const int64_t t = time_of(ticks);
    if (realtime) {
      if (ticks == 0) start_ns = steady_now_ns();
      if (!wait(start_ns + t)) return -1;
    }
    return t;
  }
  int64_t next(ProcessContext& ctx) {
    return next([&](int64_t steady_ns) { return ctx.sleep_until(steady_ns); });
  }
};

struct Setup {
  std::unique_ptr<can::Bus> bus;
  can::VirtualBus* virtual_bus = nullptr;
  std::vector<double> nodes, counts, zero;
  Clock clock;
  int64_t wait_ns = 0;
};

Status setup(const CommonConfig& c, Setup& s) {
  Result<std::vector<double>> parsed = parse_list(c.nodes, 0, "nodes");
  if (!parsed.ok()) return parsed.status();
  s.nodes = std::move(parsed).value();
  parsed = parse_list(c.counts_per_rad, s.nodes.size(), "counts_per_rad");
  if (!parsed.ok()) return parsed.status();
  s.counts = std::move(parsed).value();
  parsed = parse_list(c.zero_counts, s.nodes.size(), "zero_counts");
  if (!parsed.ok()) return parsed.status();
  s.zero = std::move(parsed).value();
  for (double n : s.nodes)
    if (n < 1 || n > 127 || n != static_cast<int>(n))
      return Status::error("nodes: " + std::to_string(n) + " is not a CANopen node id (1..127)");
  for (double counts : s.counts)
    if (counts == 0) return Status::error("counts_per_rad: 0 counts per radian");
  Result<std::unique_ptr<can::Bus>> bus = can::open_bus(c.bus, {c.key_file});
  if (!bus.ok()) return bus.status();
  s.bus = std::move(bus).value();
  const auto seed = static_cast<uint64_t>(c.fault_seed);
  auto* tunnel = dynamic_cast<can::UdpTunnel*>(s.bus.get());
  if (tunnel != nullptr) {
    tunnel->set_faults({c.loss, c.duplicate, c.reorder, c.corrupt, seed});
  } else if (c.duplicate > 0 || c.reorder > 0 || c.corrupt > 0) {
    return Status::error("duplicate, reorder and corrupt act on a udp bus's packets, not on " + c.bus);
  }
  if (auto* port = dynamic_cast<can::VirtualPort*>(s.bus.get())) {
    s.virtual_bus = &port->bus();
    if (c.loss > 0 || c.latency_ms > 0)
      s.virtual_bus->set_faults({c.loss, static_cast<int64_t>(c.latency_ms * 1e6), seed});
  }
  s.clock.period_s = 1.0 / c.rate;
  s.clock.realtime = c.realtime;
  s.clock.stop_after = static_cast<int64_t>(c.duration * c.rate + 0.5);
  s.wait_ns = static_cast<int64_t>(c.wait_ms * 1e6);
  return {};
}

JointState::Health health(can::DriveHealth h) {
  switch (h) {
    case can::DriveHealth::kReady: return JointState::Health::kReady;
    case can::DriveHealth::kFault: return JointState::Health::kFault;
    case can::DriveHealth::kSilent: return JointState::Health::kSilent;
    case can::DriveHealth::kStarting: break;
  }
  return JointState::Health::kStarting;
}

// The master's settings; its timeouts in the parameters' unit, ms, their
// defaults the master's own.
struct DriverConfig {
  can::MasterConfig master;
  double watch_ms = 0.1;
  double heartbeat_timeout_ms = static_cast<double>(can::MasterConfig{}.heartbeat_timeout_ns) / 1e6;
  double feedback_timeout_ms = static_cast<double>(can::MasterConfig{}.feedback_timeout_ns) / 1e6;
};

class Driver final : public Node {
 public:
  static constexpr const char* kName = "driver";
  static constexpr SideIn<JointTargets> kTargets{"targets", "the head's targets (newest); none yet: the drives hold"};
  static constexpr Out<JointState> kState{"state", "positions, velocities and health of every joint, each cycle"};

  static void bind(ParamBinder<DriverConfig>& b) {
    using C = DriverConfig;
    using M = can::MasterConfig;
    b.field("profile_velocity", {0.01, 1000.0}, "rad/s written to the drives (0x6081)", &C::master,
            &M::profile_velocity)
        .field("profile_acceleration", {0.1, 1e5}, "rad/s^2 written to the drives (0x6083, 0x6084)", &C::master,
               &M::profile_acceleration)
        .field("following_error", {0.001, 10.0}, "rad: the drives' own following-error window (0x6065)", &C::master,
               &M::following_error_window)
        .field("heartbeat_ms", {0, 65535}, "heartbeat time written to the drives (0x1017); 0: none", &C::master,
               &M::heartbeat_ms)
        .field("sdo_attempts", {1, 1000},
               "tries of each SDO configuration write (50 ms apart) before the drive is "
               "reported silent",
               &C::master, &M::sdo_attempts)
        .field("heartbeat_timeout_ms", {1.0, 1e6}, "a drive without heartbeat this long is silent",
               &C::heartbeat_timeout_ms)
        .field("feedback_timeout_ms", {1.0, 1e6}, "a drive without position this long is silent",
               &C::feedback_timeout_ms)
        .field("statusword_on_change",
               "configure the drives' statusword PDO as event-driven (0x1800 sub 2 = 255), "
               "so the set-point handshake completes within a period instead of over two SYNCs",
               &C::master, &M::statusword_on_change)
        .field("watch_ms", {0.0, 100.0},
               "realtime: between cycles, look this often at new targets (sent at once to every drive ready for a "
               "set-point) and at 'wake'; 0: only at each cycle",
               &C::watch_ms);
  }

  static Contract contract() {
    return Contract(
               "The CANopen master of the head's CiA 402 drives: configures them by SDO, enables them, streams "
               "the targets as profile-position set-points, sends SYNC, supervises heartbeats and process data, "
               "and reports the joints. One control cycle per call: the control loop's clock. Between cycles "
               "(realtime) new targets answering a request go out at once where the drives' set-point handshake "
               "allows, and a message on 'wake' makes it report the joints at once (no SYNC).")
        .ports(kTargets)
        .side_input<Message>("wake",
                             "any new message (a gaze request) makes the driver emit the joints' latest "
                             "state at once, between cycles, so that the head plans from it now")
        .ports(kState)
        .params(&bind_common)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    if (Status s = setup(ctx.config(&bind_common), setup_); !s.ok()) return s;
    DriverConfig c = ctx.config(&bind);
    static const char* const names[] = {"neck", "vergence_left", "tilt_left", "vergence_right", "tilt_right"};
    for (std::size_t j = 0; j < setup_.nodes.size(); ++j)
      c.master.joints.push_back({j < 5 ? names[j] : "joint" + std::to_string(j), static_cast<int>(setup_.nodes[j]),
                                 setup_.counts[j], static_cast<int32_t>(setup_.zero[j])});
    c.master.heartbeat_timeout_ns = static_cast<int64_t>(c.heartbeat_timeout_ms * 1e6);
    c.master.feedback_timeout_ns = static_cast<int64_t>(c.feedback_timeout_ms * 1e6);
    master_ = std::make_unique<can::Master>(*setup_.bus, c.master);
    feedback_.reserve(setup_.nodes.size());
    wake_ = ctx.input<Message>("wake");
    watch_ns_ = setup_.clock.realtime ? static_cast<int64_t>(c.watch_ms * 1e6) : 0;
    capture_to_command_ = &ctx.timing("gaze_capture_to_command");
    taken_to_command_ = &ctx.timing("gaze_taken_to_command");
    between_ = &ctx.counter("set_points_between_cycles");
    woken_ = &ctx.counter("woken");
    bus_stats_.open(ctx);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    const Status status = step(ctx);
    bus_stats_.publish(setup_.bus.get());
    return status;
  }
  void close() override { bus_stats_.publish(setup_.bus.get()); }

 private:
  Status step(ProcessContext& ctx) {
    Clock& clock = setup_.clock;
    if (watch_ns_ > 0 && clock.ticks >= 0) {
      // Between cycles: new targets and wake-ups are acted on as they come.
      const int64_t due = clock.next_due();
      for (bool fresh = false;;) {
        if (!fresh && !ctx.sleep_until(0)) return Status::end_of_stream();  // the side inputs' newest
        if (between_cycles(ctx)) return {};
        const int64_t now = steady_now_ns();
        if (now >= due) break;
        if (!ctx.sleep_until(std::min(due, now + watch_ns_))) return Status::end_of_stream();
        fresh = true;
      }
    }
    const int64_t t = clock.next(ctx);
    if (t < 0) return Status::end_of_stream();
    if (setup_.virtual_bus != nullptr) setup_.virtual_bus->set_time(t);
    take_targets(ctx);
    master_->cycle(t, latest_ ? latest_->position.data() : nullptr, latest_ ? latest_->reset : 0, feedback_,
                   setup_.wait_ns, serial_);
    check_commanded();
    emit_state(ctx, t);
    return {};
  }

  // The newest usable targets, numbered; those answering a new request are
  // timed until every running drive has been sent them (or later ones).
  void take_targets(ProcessContext& ctx) {
    auto targets = ctx.get(kTargets);
    if (!targets || targets == seen_) return;
    seen_ = targets;
    if (targets->position.size() != setup_.nodes.size()) {
      if (!warned_)
        log().warn("{}: targets for {} joints, expected {}: ignored", ctx.node_name(), targets->position.size(),
                   setup_.nodes.size());
      warned_ = true;
      return;
    }
    latest_ = targets;
    ++serial_;
    if (targets->cause_origin_ns > 0 && targets->cause_origin_ns != last_cause_) {
      last_cause_ = targets->cause_origin_ns;
      pending_ = {targets->cause_origin_ns, targets->cause_taken_ns, serial_};
    }
  }
  // From the request's camera frame, and from when the head took it, to the
  // moment its set-points are on the bus for every running drive.
  void check_commanded() {
    if (pending_.serial == 0 || !master_->commanded(pending_.serial)) return;
    const int64_t now = steady_now_ns();
    if (now >= pending_.origin_ns) capture_to_command_->record(now - pending_.origin_ns);
    if (pending_.taken_ns > 0 && now >= pending_.taken_ns) taken_to_command_->record(now - pending_.taken_ns);
    pending_ = {};
  }
  // One look between cycles; true when it emitted the joints (woken).
  bool between_cycles(ProcessContext& ctx) {
    const int64_t now = steady_now_ns() - setup_.clock.start_ns;  // control time
    take_targets(ctx);
    const bool urgent = pending_.serial != 0 && latest_;
    if (master_->command(now, urgent ? latest_->position.data() : nullptr, serial_) > 0) bump(*between_);
    check_commanded();
    auto wake = ctx.get(wake_);
    if (!wake || wake == last_wake_) return false;
    last_wake_ = wake;
    bump(*woken_);
    master_->feedback(feedback_);
    emit_state(ctx, now);
    return true;
  }
  void emit_state(ProcessContext& ctx, int64_t t) {
    auto state = ctx.make(kState);
    const std::size_t n = feedback_.size();
    state->position.resize(n);
    state->velocity.resize(n);
    state->health.resize(n);
    state->updated_ns.resize(n);
    state->error_code.resize(n);
    for (std::size_t j = 0; j < n; ++j) {
      state->position[j] = feedback_[j].position;
      state->velocity[j] = feedback_[j].velocity;
      state->health[j] = health(feedback_[j].health);
      state->updated_ns[j] = feedback_[j].updated_ns;
      state->error_code[j] = feedback_[j].error_code;
    }
    state->cycle = setup_.clock.ticks;
    state->detail = master_->problem();
    state->timestamp_ns = t;
    state->origin_ns = steady_now_ns();
    state->frame_id = setup_.clock.ticks;
    ctx.emit(kState, std::move(state));
  }

  Setup setup_;
  BusStats bus_stats_;
  std::unique_ptr<can::Master> master_;
  std::vector<can::JointFeedback> feedback_;
  InputHandle<Message> wake_;
  int64_t watch_ns_ = 0;
  bool warned_ = false;
  std::shared_ptr<const JointTargets> seen_, latest_;
  MessagePtr last_wake_;
  int64_t serial_ = 0, last_cause_ = 0;
  struct Pending {
    int64_t origin_ns = 0, taken_ns = 0, serial = 0;
  } pending_;
  Histogram* capture_to_command_ = nullptr;
  Histogram* taken_to_command_ = nullptr;
  std::atomic<uint64_t>* between_ = nullptr;
  std::atomic<uint64_t>* woken_ = nullptr;
};

// The simulated drives: one motor model for every joint, and the faults to inject.
struct DrivesConfig {
  std::string initial = "0";  // rad, one value or one per joint
  can::MotorModel motor;
  double fault_at = -1.0, silent_at = -1.0;  // s; -1: never
  double silent_for = 0.0;                   // s; 0: for good
  int fault_joint = 0;
};

class Drives final : public Node {
 public:
  static constexpr const char* kName = "drives";
  static constexpr Out<JointState> kTruth{
      "truth", "the shafts' true positions and velocities, each step (for tests and overlays)"};

  static void bind(ParamBinder<DrivesConfig>& b) {
    using C = DrivesConfig;
    using M = can::MotorModel;
    b.field("initial", "joint angles at power-on, rad (one value, or one per joint)", &C::initial)
        .field("inertia", {1e-6, 10.0}, "kg m^2 at each joint", &C::motor, &M::inertia)
        .field("friction", {0.0, 10.0}, "Coulomb friction, N m", &C::motor, &M::coulomb)
        .field("torque_limit", {0.001, 1000.0}, "N m", &C::motor, &M::torque_limit)
        .field("fault_at", {-1.0, 1e9}, "fault injection: this joint's drive faults at this time, s (-1: never)",
               &C::fault_at)
        .field("silent_at", {-1.0, 1e9}, "fault injection: this joint's drive falls silent at this time, s (-1: never)",
               &C::silent_at)
        .field("silent_for", {0.0, 1e9},
               "fault injection: the silent drive's controller restarts after this many seconds (it boots, announces "
               "it, and the master configures it again; its shaft stays where it is); 0: silent for good",
               &C::silent_for)
        .field("fault_joint", {0, 126}, "the joint (index) that faults or falls silent", &C::fault_joint);
  }

  static Contract contract() {
    return Contract(
               "Simulated CiA 402 drives, one per joint, on a bus: NMT, heartbeat, SDO, PDOs, the 402 state "
               "machine and profile position mode over a PID position loop on a plant with inertia and "
               "friction. Alone in a graph on a UDP tunnel they stand in for the robot PC's motors.")
        .ports(kTruth)
        .params(&bind_common)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    if (Status s = setup(ctx.config(&bind_common), setup_); !s.ok()) return s;
    const DrivesConfig c = ctx.config(&bind);
    const Result<std::vector<double>> initial = parse_list(c.initial, setup_.nodes.size(), "initial");
    if (!initial.ok()) return initial.status();
    std::vector<can::DriveConfig> drives;
    for (std::size_t j = 0; j < setup_.nodes.size(); ++j) {
      can::DriveConfig d;
      d.node = static_cast<int>(setup_.nodes[j]);
      d.counts_per_rad = setup_.counts[j];
      d.initial_position = (*initial)[j] + setup_.zero[j] / setup_.counts[j];
      d.motor = c.motor;
      // Gains for the same closed-loop bandwidth whatever the inertia.
      const double scale = d.motor.inertia / can::MotorModel{}.inertia;
      d.motor.kp *= scale;
      d.motor.ki *= scale;
      d.motor.kd *= scale;
      drives.push_back(d);
    }
    fault_at_ = c.fault_at;
    silent_at_ = c.silent_at;
    silent_for_ = c.silent_for;
    fault_joint_ = static_cast<std::size_t>(c.fault_joint);
    if ((fault_at_ >= 0 || silent_at_ >= 0) && fault_joint_ >= drives.size())
      return Status::error("fault_joint " + std::to_string(fault_joint_) + " is beyond the " +
                           std::to_string(drives.size()) + " joints");
    rack_ = std::make_unique<can::DriveRack>(std::move(setup_.bus), std::move(drives));
    bus_stats_.open(ctx);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    const Status status = step(ctx);
    bus_stats_.publish(rack_ ? &rack_->bus() : nullptr);
    return status;
  }
  void close() override { bus_stats_.publish(rack_ ? &rack_->bus() : nullptr); }

 private:
  Status step(ProcessContext& ctx) {
    // In realtime the drives' communication runs between their control
    // steps, as on a drive: an RPDO is acted on, an event-driven TPDO sent, on arrival.
    const int64_t t = setup_.clock.next([&](int64_t steady_ns) {
      for (int64_t now = steady_now_ns(); now < steady_ns; now = steady_now_ns()) {
        if (ctx.stop_requested()) return false;
        rack_->handle_arrived(std::min<int64_t>(steady_ns - now, 1'000'000));
      }
      return !ctx.stop_requested();
    });
    if (t < 0) return Status::end_of_stream();
    const double seconds = static_cast<double>(t) * 1e-9;
    if (fault_at_ >= 0 && seconds >= fault_at_) {
      rack_->drive(fault_joint_).inject_fault(can::emcy::kGeneric);
      fault_at_ = -1;
    }
    if (silent_at_ >= 0 && seconds >= silent_at_) {
      rack_->drive(fault_joint_).set_silent(true);
      if (silent_for_ > 0) back_at_ = silent_at_ + silent_for_;
      silent_at_ = -1;
    }
    if (back_at_ >= 0 && seconds >= back_at_) {
      rack_->drive(fault_joint_).reboot();
      back_at_ = -1;
    }
    rack_->step(t, setup_.clock.period_s, setup_.wait_ns);
    auto truth = ctx.make(kTruth);
    const std::size_t n = rack_->size();
    truth->position.resize(n);
    truth->velocity.resize(n);
    truth->health.assign(n, JointState::Health::kReady);
    truth->updated_ns.assign(n, t);
    truth->error_code.resize(n);
    for (std::size_t j = 0; j < n; ++j) {
      const can::SimulatedDrive& d = rack_->drive(j);
      truth->position[j] = d.position() - setup_.zero[j] / setup_.counts[j];
      truth->velocity[j] = d.velocity();
      truth->error_code[j] = d.last_error();
      if (d.state() == can::DriveState::kFault) truth->health[j] = JointState::Health::kFault;
    }
    truth->cycle = setup_.clock.ticks;
    truth->timestamp_ns = t;
    truth->origin_ns = steady_now_ns();
    truth->frame_id = setup_.clock.ticks;
    ctx.emit(kTruth, std::move(truth));
    return {};
  }

  Setup setup_;
  BusStats bus_stats_;
  std::unique_ptr<can::DriveRack> rack_;
  double fault_at_ = -1, silent_at_ = -1, silent_for_ = 0, back_at_ = -1;
  std::size_t fault_joint_ = 0;
};

// can::Frame's fd_flags and CanFrames' low flag bits are both the kernel's CANFD_BRS / CANFD_ESI.
constexpr uint8_t kFdFlags = CanFrames::kBitRateSwitch | CanFrames::kErrorStateIndicator;

// A bus frame as the CanFrames message carries it (the kernel's can_id and FD flags), and back.
CanFrames::Frame to_message(const can::Frame& f) {
  CanFrames::Frame m;
  m.can_id = f.raw_id();
  m.length = std::min<uint8_t>(f.length, f.fd ? 64 : 8);
  m.flags = static_cast<uint8_t>((f.fd ? CanFrames::kFd : 0) | (f.fd_flags & kFdFlags));
  std::copy_n(f.data.begin(), m.length, m.data.begin());
  m.timestamp_ns = f.timestamp_ns;
  return m;
}

can::Frame from_message(const CanFrames::Frame& m) {
  can::Frame f = can::Frame::from_raw_id(m.can_id);
  f.fd = (m.flags & CanFrames::kFd) != 0;
  f.fd_flags = static_cast<uint8_t>(m.flags & kFdFlags);
  f.length = std::min<uint8_t>(m.length, f.fd ? 64 : 8);
  std::copy_n(m.data.begin(), f.length, f.data.begin());
  f.timestamp_ns = m.timestamp_ns;
  return f;
}

struct TapConfig {
  std::string bus = "virtual:head";
  double period_ms = 10.0;
  int max_frames = 1000;
  bool errors = false;
  double duration = 0.0;  // s; 0: never ends
  std::string key_file;
};

class Tap final : public Node {
 public:
  static constexpr const char* kName = "tap";
  static constexpr Out<CanFrames> kFrames{
      "frames", "the frames of one period, in arrival order (periods without frames emit nothing)"};

  static void bind(ParamBinder<TapConfig>& b) {
    using C = TapConfig;
    b.field("bus", kBusSpecDoc, &C::bus)
        .field("period_ms", {0.1, 60000.0}, "batch period", &C::period_ms)
        .field("max_frames", {1, 1000000}, "a batch ends early when it holds this many frames", &C::max_frames)
        .field("errors", "also deliver error frames (all error classes)", &C::errors)
        .field("duration", {0.0, 1e7}, "end the stream after this many seconds (0: never)", &C::duration)
        .field("key_file", kKeyFileDoc, &C::key_file);
  }

  static Contract contract() {
    return Contract(
               "Every frame a bus delivers, as CanFrames messages of one batch per period (a source, like "
               "candump): to watch the head's bus from another process or PC, or to bridge it (with can.send).")
        .ports(kFrames)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    const TapConfig c = ctx.config(&bind);
    spec_ = c.bus;
    Result<std::unique_ptr<can::Bus>> bus = can::open_bus(spec_, {c.key_file});
    if (!bus.ok()) return bus.status();
    bus_ = std::move(bus).value();
    bus_stats_.open(ctx);
    if (c.errors) {
      can::FilterSet filters;
      filters.error_mask = can::error_class::kAll;
      bus_->set_filters(filters);
    }
    period_ns_ = static_cast<int64_t>(c.period_ms * 1e6);
    max_frames_ = static_cast<std::size_t>(c.max_frames);
    end_ns_ = c.duration > 0 ? steady_now_ns() + static_cast<int64_t>(c.duration * 1e9) : 0;
    return {};
  }
  Status process(ProcessContext& ctx) override {
    for (;; bus_stats_.publish(bus_.get())) {
      const int64_t start = steady_now_ns();
      if ((end_ns_ > 0 && start >= end_ns_) || ctx.stop_requested()) return Status::end_of_stream();
      const int64_t until = end_ns_ > 0 ? std::min(start + period_ns_, end_ns_) : start + period_ns_;
      auto batch = ctx.make(kFrames);
      batch->frames.clear();
      batch->bus = spec_;
      can::Frame f;
      for (int64_t now = start; now < until && batch->frames.size() < max_frames_; now = steady_now_ns())
        if (bus_->receive(f, until - now)) batch->frames.push_back(to_message(f));
      if (batch->frames.empty()) continue;
      batch->timestamp_ns = batch->frames.front().timestamp_ns;
      batch->origin_ns = start;
      batch->frame_id = batches_++;
      ctx.emit(kFrames, std::move(batch));
      bus_stats_.publish(bus_.get());
      return {};
    }
  }
  void close() override { bus_stats_.publish(bus_.get()); }

 private:
  std::unique_ptr<can::Bus> bus_;
  BusStats bus_stats_;
  std::string spec_;
  int64_t period_ns_ = 0, end_ns_ = 0, batches_ = 0;
  std::size_t max_frames_ = 0;
};

class Send final : public Node {
 public:
  static constexpr const char* kName = "send";
  static constexpr In<CanFrames> kFrames{"frames", "the frames to send"};

  static Contract contract() {
    return Contract(
               "Sends every frame of its CanFrames input onto a bus, in order (a sink, like cansend): with "
               "can.tap at the other end, a bus bridged across processes or PCs. Error frames are not sent.")
        .ports(kFrames)
        .param_string("bus", "virtual:head", kBusSpecDoc)
        .param_string("key_file", "", kKeyFileDoc);
  }
  Status open(OpenContext& ctx) override {
    Result<std::unique_ptr<can::Bus>> bus =
        can::open_bus(ctx.params().get_string("bus"), {ctx.params().get_string("key_file")});
    if (!bus.ok()) return bus.status();
    bus_ = std::move(bus).value();
    bus_stats_.open(ctx);
    sent_ = &ctx.counter("sent");
    failed_ = &ctx.counter("failed");
    skipped_ = &ctx.counter("error_frames_skipped");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    for (const CanFrames::Frame& m : ctx.get(kFrames)->frames) {
      const can::Frame f = from_message(m);
      if (f.error) {
        bump(*skipped_);
        continue;
      }
      bump(bus_->send(f) ? *sent_ : *failed_);
    }
    bus_->flush();
    bus_stats_.publish(bus_.get());
    return {};
  }
  void close() override {
    bus_stats_.publish(bus_.get());
    if (failed_ != nullptr && (failed_->load() > 0 || skipped_->load() > 0))
      log().warn("{}: {} frames could not be sent, {} error frames not sent", bus_ ? bus_->describe() : "",
                 failed_->load(), skipped_->load());
  }

 private:
  std::unique_ptr<can::Bus> bus_;
  BusStats bus_stats_;
  std::atomic<uint64_t>* sent_ = nullptr;
  std::atomic<uint64_t>* failed_ = nullptr;
  std::atomic<uint64_t>* skipped_ = nullptr;
};

}  // namespace

SACCADE_PLUGIN("can", Driver, Drives, Tap, Send)
