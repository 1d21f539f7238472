#pragma once
// Joint trajectories for the head: minimum-jerk moves (quintic polynomials)
// from any state (position, velocity, acceleration) to rest at a target,
// timed so that every joint stays within its velocity and acceleration
// limits and all joints arrive together; re-planned from the current state
// when a new target arrives (smooth pursuit); positions never leave the
// joint limits.
#include <string>
#include <vector>

namespace saccade::head {

struct JointLimit {
  double min = -1.0, max = 1.0;  // position, rad
  double velocity = 3.0;         // rad/s
  double acceleration = 30.0;    // rad/s^2
};

struct JointState {
  double position = 0, velocity = 0, acceleration = 0;
};

// One joint's quintic from a state to rest at `target` over `duration` seconds.
class Quintic {
 public:
  Quintic() = default;
  Quintic(const JointState& from, double target, double duration);
  JointState at(double t) const;  // clamped to [0, duration]
  double duration() const { return duration_; }

 private:
  double c_[6] = {0, 0, 0, 0, 0, 0};
  double duration_ = 0;
};

// All joints, moved together.
class Trajectory {
 public:
  explicit Trajectory(std::vector<JointLimit> limits);
  // Plans from `now` (the joints' states) to `target` (clamped into the
  // limits), taking at least `min_duration` seconds (smooth pursuit asks for
  // a floor; a saccade for none); returns the move's duration (0 when
  // already there).
  double plan(const std::vector<JointState>& now, const std::vector<double>& target, double min_duration = 0);
  // State of every joint `t` seconds after the plan began.
  std::vector<JointState> at(double t) const;
  void at(double t, std::vector<JointState>& out) const;  // into `out`: no allocation once sized
  double duration() const { return duration_; }
  // "" or why `target` had to be clamped (a joint beyond its limit).
  const std::string& clamped() const { return clamped_; }

 private:
  std::vector<JointLimit> limits_;
  std::vector<Quintic> joints_;
  std::vector<Quintic> second_;  // after split_ (>= 0): from rest to the goal, when the first part only brakes
  double split_ = -1;
  double duration_ = 0;
  std::string clamped_;
  // plan()'s scratch, one per joint: a plan allocates nothing (but the message
  // saying why a target had to be clamped).
  std::vector<double> goal_, stop_;
  std::vector<JointState> rest_;
};

}  // namespace saccade::head
