#pragma once
// Simulated CiA 402 drives: what the microcontroller of each joint motor
// does, so the head's whole control path runs without hardware. Each drive
// speaks NMT, heartbeat, expedited SDO on its object dictionary, the default
// PDOs (answering SYNC with TPDO1 + TPDO2), the power state machine and
// profile position mode; behind that a PID position loop with anti-windup
// drives a plant with inertia, viscous and Coulomb friction, within
// velocity, acceleration and torque limits, read by a quantising encoder.
// Faults: following error (window and time from the dictionary), injected
// drive faults, and a silent drive (no heartbeat, no answers). Deterministic:
// time only advances through step(now, dt).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bus.hpp"
#include "canopen.hpp"

namespace saccade::can {

struct MotorModel {
  double inertia = 0.002;                  // kg m^2, at the joint
  double viscous = 0.01;                   // N m s / rad
  double coulomb = 0.02;                   // N m
  double torque_limit = 1.5;               // N m
  double velocity_limit = 8.0;             // rad/s: the amplifier's
  double kp = 50.0, ki = 400.0, kd = 0.5;  // position PID: N m/rad, N m/(rad s), N m s/rad
  double loop_hz = 4000.0;                 // the drive's own position loop rate
};

struct DriveConfig {
  int node = 1;
  double counts_per_rad = 10000.0;  // encoder resolution at the joint
  double initial_position = 0.0;    // rad
  MotorModel motor;
  // Object dictionary defaults (the master usually writes its own by SDO).
  uint32_t profile_velocity = 60000;        // counts/s
  uint32_t profile_acceleration = 2000000;  // counts/s^2
  uint32_t following_error_window = 2000;   // counts
  uint16_t following_error_timeout_ms = 20;
  uint16_t heartbeat_ms = 0;  // 0: no heartbeat until the master sets 0x1017
  // TPDO1 (statusword): on every SYNC, or on change (0x1800 sub 2).
  uint8_t tpdo1_transmission = transmission::kEverySync;
};

class SimulatedDrive {
 public:
  explicit SimulatedDrive(DriveConfig config);

  // A frame addressed to this drive (or broadcast); answers go to `out`.
  void handle(const Frame& f, Bus& out);
  // Advances by `dt` seconds ending at bus time `now_ns`: heartbeat when due,
  // the profile generator, the position loop and the plant.
  void advance(int64_t now_ns, double dt, Bus& out);

  // Fault injection.
  void inject_fault(uint16_t error_code = emcy::kGeneric) { injected_fault_ = error_code; }
  void set_silent(bool silent) { silent_ = silent; }
  // Off and on again: everything as at construction, so it boots and announces it.
  void power_cycle() { *this = SimulatedDrive(config_); }
  // Its controller restarts (a watchdog, NMT reset node): everything as at
  // power-on but the shaft, which stays where it is; it boots and announces it.
  void reboot();
  void push(double torque) { disturbance_ = torque; }  // an external torque, N m (a hand on the head)

  int node() const { return config_.node; }
  DriveState state() const { return state_; }
  NmtState nmt_state() const { return nmt_; }
  double position() const { return theta_; }  // rad, the shaft's true position
  double velocity() const { return omega_; }
  int32_t encoder() const;
  uint16_t statusword() const;
  uint16_t last_error() const { return error_code_; }

 private:
  void handle_sdo(const Frame& f, Bus& out);
  bool read_object(uint16_t index, uint8_t sub, uint32_t& value, uint8_t& size, uint32_t& abort) const;
  bool write_object(uint16_t index, uint8_t sub, uint32_t value, uint32_t& abort);
  void apply_controlword(uint16_t cw);
  void enter_fault(uint16_t code, Bus& out);
  void substep(double h);
  // An event-driven TPDO1: the statusword whenever it differs from the last one sent.
  void send_status_on_change(Bus& out);

  DriveConfig config_;
  NmtState nmt_ = NmtState::kBootUp;
  bool booted_ = false, silent_ = false;
  DriveState state_ = DriveState::kSwitchOnDisabled;
  uint16_t controlword_ = 0, error_code_ = 0, injected_fault_ = 0;
  int8_t mode_ = kProfilePositionMode;
  bool set_point_ack_ = false, following_error_ = false;
  int32_t target_counts_ = 0, pending_target_ = 0;
  int64_t next_heartbeat_ns_ = 0, following_error_since_ns_ = -1;
  int32_t status_sent_ = -1;  // the statusword last sent by an event-driven TPDO1; -1: none since operational
  // Profile generator (reference), the plant and the loop.
  double reference_ = 0, reference_velocity_ = 0, target_ = 0;
  double theta_ = 0, omega_ = 0, integral_ = 0, disturbance_ = 0;
};

// Drives sharing one bus port, as several microcontrollers on one cable:
// each step drains the port, hands every frame to its drive, advances them
// all and flushes what they answered (one tunnel packet).
class DriveRack {
 public:
  DriveRack(std::unique_ptr<Bus> bus, std::vector<DriveConfig> drives);
  // Handles what has arrived (waiting up to `wait_ns` for the first frame, for
  // a tunnel whose packets are still in flight), then advances every drive.
  void step(int64_t now_ns, double dt, int64_t wait_ns = 0);
  // Between steps: handles frames as they arrive (the first waited for up to
  // `wait_ns`), as a drive's communication does between its control cycles:
  // an RPDO is acted on, an event-driven TPDO answers at once. False when none came.
  bool handle_arrived(int64_t wait_ns);
  SimulatedDrive& drive(std::size_t i) { return drives_[i]; }
  std::size_t size() const { return drives_.size(); }
  Bus& bus() { return *bus_; }

 private:
  std::unique_ptr<Bus> bus_;
  std::vector<SimulatedDrive> drives_;
};

}  // namespace saccade::can
