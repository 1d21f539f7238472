#pragma once
// The CANopen master of the head's drives, one control cycle at a time: it
// configures each drive by SDO (profile position mode, profile velocity and
// acceleration, following-error window and time, heartbeat time), starts it
// (NMT), walks the CiA 402 state machine to operation enabled, streams
// set-points with the new-set-point / acknowledge handshake, sends SYNC, and
// turns TPDOs into joint positions and velocities (units: encoder counts per
// radian and a zero offset per joint). It supervises heartbeats and process
// data (a drive silent beyond its timeout is reported), reports drive faults
// (statusword, emergency) and clears them when asked. Non-blocking: nothing
// waits except the optional first receive of a cycle.
//
// Set-points follow the CiA 402 handshake, checked on the statusword: bit 4
// (new set-point) rises only once a statusword read after its last fall shows
// the acknowledge (bit 12) low, and falls only once one shows it high; a drive
// gets at most one set-point per SYNC period, and at the cycle (routine
// streaming) one every second period. Between cycles (command()) new targets
// go out at once to every drive whose handshake allows it; SYNC is sent only
// by cycle(), so the drives' SYNC period stays constant. With the statusword
// on change (TPDO1 event-driven, the default) the handshake completes within
// a period and a drive is nearly always ready for a new set-point.
#include <cstdint>
#include <string>
#include <vector>

#include "bus.hpp"
#include "canopen.hpp"

namespace saccade::can {

struct JointDrive {
  std::string name;
  int node = 1;
  double counts_per_rad = 10000.0;  // negative: the encoder counts the other way
  int32_t zero_counts = 0;          // encoder reading at joint angle 0
};

struct MasterConfig {
  std::vector<JointDrive> joints;
  double profile_velocity = 8.0;        // rad/s, written to 0x6081
  double profile_acceleration = 400.0;  // rad/s^2, 0x6083 / 0x6084
  double following_error_window = 0.1;  // rad, 0x6065 (the drive's own check)
  uint16_t following_error_timeout_ms = 50;
  uint16_t heartbeat_ms = 20;                  // producer time written to 0x1017
  int64_t heartbeat_timeout_ns = 100'000'000;  // no heartbeat this long: silent
  int64_t feedback_timeout_ns = 50'000'000;    // no TPDO2 this long: silent
  int64_t sdo_timeout_ns = 50'000'000;
  int sdo_attempts = 3;
  // Configure TPDO1 (statusword) as event-driven (0x1800 sub 2 = 255): the
  // handshake's answers arrive at once instead of on the next SYNC.
  bool statusword_on_change = true;
};

enum class DriveHealth : uint8_t { kStarting, kReady, kFault, kSilent };

struct JointFeedback {
  double position = 0, velocity = 0;  // rad, rad/s
  DriveHealth health = DriveHealth::kStarting;
  DriveState state = DriveState::kUnknown;
  int64_t updated_ns = -1;  // when TPDO2 last arrived (bus clock)
  uint16_t error_code = 0;  // last emergency code
};

class Master {
 public:
  Master(Bus& bus, MasterConfig config);

  // One control cycle at `now_ns`: reads what arrived (waiting up to
  // `wait_ns` for the first frame), supervises, advances configuration and
  // enabling, sends the set-points (`targets` in rad, one per joint; null:
  // none, the drives keep their last), then SYNC. `reset` changes when the
  // head asks for faults to be cleared. Fills `feedback` (one per joint).
  // `serial` names the targets (any increasing number); commanded() tells
  // when every running drive has been sent them.
  void cycle(int64_t now_ns, const double* targets, int64_t reset, std::vector<JointFeedback>& feedback,
             int64_t wait_ns = 0, int64_t serial = 0);

  // Between cycles, without SYNC: reads what has arrived (waiting up to
  // `wait_ns` for the first frame), completes handshakes (bit 4 low once
  // acknowledged) and, when `targets` is given, sends them at once to every
  // running drive ready for a new set-point that has not had these (`serial`)
  // yet. Returns how many drives it sent a set-point.
  int command(int64_t now_ns, const double* targets, int64_t serial, int64_t wait_ns = 0);
  // True when every running drive (at least one) has been sent targets of `serial` or later.
  bool commanded(int64_t serial) const;
  // The joints as last read (as cycle() fills them).
  void feedback(std::vector<JointFeedback>& out) const;

  // The first problem in words ("tilt_left (node 3): drive fault, emergency 0x8611"), empty when all are ready.
  const std::string& problem() const { return problem_; }
  bool all_ready() const;
  struct Stats {
    int64_t cycles = 0, set_points = 0, acknowledged = 0, sdo_timeouts = 0, emergencies = 0;
    int bits_last_cycle = 0;  // frames sent and received in the last cycle, on the wire (no stuffing)
  };
  const Stats& stats() const { return stats_; }

 private:
  enum class Phase : uint8_t { kConfigure, kEnable, kRun, kSilent };
  struct Write {
    uint16_t index;
    uint8_t sub;
    uint32_t value;
    uint8_t size;
  };
  struct Drive {
    JointDrive joint;
    std::vector<Write> writes;  // its configuration, in its own units
    Phase phase = Phase::kConfigure;
    std::size_t step = 0;  // configuration write in progress
    int64_t sdo_sent_ns = -1, configured_ns = -1;
    int attempts = 0;
    DriveState state = DriveState::kUnknown;
    uint16_t statusword = 0, error_code = 0;
    int32_t position = 0, velocity = 0;
    int64_t heartbeat_ns = -1, updated_ns = -1;
    int64_t status_ns = -1, restarted_ns = -1;  // the last statusword; the last NMT start sent again
    bool set_point_high = false, reset_sent = false;
    bool ack_low_seen = true;      // a statusword read since bit 4 fell shows the acknowledge low
    int64_t set_point_cycle = -2;  // the SYNC period (cycles sent) of the last set-point
    int64_t serial = 0;            // the targets it was last sent
    std::string problem;
  };
  void receive(const Frame& f, int64_t now_ns);
  void drain(int64_t now_ns, int64_t wait_ns);
  bool running(const Drive& d) const;
  // The handshake's next step for a running drive: bit 4 low once acknowledged
  // (or the acknowledge is lost); with `target`, a set-point when allowed
  // (`routine`: at most one every second SYNC period).
  bool set_point(Drive& d, const double* target, int64_t serial, bool routine);
  JointFeedback joint_feedback(const Drive& d) const;
  void restart_configuration(Drive& d);
  void send(const Frame& f);
  void run_drive(Drive& d, int64_t now_ns, const double* target, bool reset, int64_t serial);
  void enable(Drive& d, int64_t now_ns);
  std::string who(const Drive& d) const;

  Bus& bus_;
  MasterConfig config_;
  std::vector<Drive> drives_;
  int64_t reset_seen_ = 0;
  bool first_cycle_ = true;
  std::string problem_;
  Stats stats_;
};

const char* to_string(DriveHealth h);

}  // namespace saccade::can
