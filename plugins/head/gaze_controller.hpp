#pragma once
// The head's gaze controller: gaze requests (a 3D point; a direction or a
// pixel from one camera with or without depth; a stereo pixel pair; a turn
// relative to the current gaze) become joint goals by closed-form inverse
// kinematics, then per-joint trajectories at the control rate: the fastest
// minimum-jerk move within the velocity and acceleration limits for a
// saccade, a re-planned smooth move of at least `pursuit_time` for small
// corrections (pursuit). It watches the joints: a drive fault, a silent
// drive, feedback older than the timeout, or a following error beyond the
// window make the head hold where it is, report why, and refuse motion until
// reset. Joint limits are never exceeded, whatever is asked.
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "kinematics.hpp"
#include "saccade/status.hpp"
#include "trajectory.hpp"

namespace saccade::head {

// Joint order everywhere: neck, vergence left, tilt left, vergence right, tilt right.
inline constexpr int kJoints = 5;
const char* joint_name(int j);

struct HeadConfig {
  kinematics::HeadGeometry geometry;
  kinematics::HeadLimits limits;
  double velocity = 3.0;             // rad/s, every joint
  double acceleration = 30.0;        // rad/s^2
  double default_depth = 1.5;        // m, when a request has no depth and no fixation point is known
  double saccade_threshold = 0.035;  // rad: a larger change of any joint is a saccade
  double pursuit_time = 0.12;        // s: the shortest re-planned pursuit move
  double following_error = 0.2;      // rad between commanded and measured
  double feedback_timeout = 0.05;    // s without a new position
  std::vector<JointLimit> joint_limits() const;
};

struct JointReading {
  enum class Health : uint8_t { kStarting, kReady, kFault, kSilent };
  double position = 0, velocity = 0;  // rad, rad/s
  Health health = Health::kStarting;
  int64_t updated_ns = -1;
};

struct HeadCommand {
  std::vector<double> position, velocity;  // per joint
  bool hold = false;
  int64_t reset = 0;  // incremented by reset(): the driver clears the drives' faults
  std::string fault;  // why it holds
};

class GazeController {
 public:
  explicit GazeController(HeadConfig config);

  // Requests; each returns ok when taken, else an error saying why not
  // (holding, the target unreachable, no joint state yet). They use the
  // latest measured joints.
  Status look_at(const Eigen::Vector3d& point);  // base frame, m
  // `direction` in camera `camera`'s optical frame (0 left, 1 right: x right,
  // y down, z forward); `depth` along its optical axis, <= 0: the distance
  // of the current fixation point (the vergence stays), or default_depth.
  Status look_along(int camera, const Eigen::Vector3d& direction, double depth);
  // A pixel of the left image and its disparity (left x - right x) with the
  // cameras' intrinsics: triangulated from the two rays.
  Status look_at_stereo(double u, double v, double disparity, double focal, double cx, double cy);
  Status turn(double azimuth, double elevation);  // right +, up +, radians

  // One control cycle at `now_ns` with the joints' readings; the targets to send.
  const HeadCommand& cycle(int64_t now_ns, const std::vector<JointReading>& joints);
  // Clears a hold: motion resumes (from where the joints are) once every drive is ready again.
  void reset();

  bool holding() const { return command_.hold; }
  const std::string& fault() const { return command_.fault; }
  kinematics::HeadJoints measured() const;
  // The point both optical axes come closest to, from the measured joints.
  kinematics::Fixation fixation() const;
  struct Stats {
    int64_t requests = 0, rejected = 0, saccades = 0, pursuits = 0, clamped = 0, holds = 0;
  };
  const Stats& stats() const { return stats_; }
  const std::string& last_rejection() const { return last_rejection_; }

 private:
  // The checks and inverse kinematics every request ends in; counted by its
  // caller. Ok when the gaze becomes the new goal.
  Status aim(const Eigen::Vector3d& point);
  // The inverse kinematics' joints become the goal; its error is rejected.
  Status accept(const Result<kinematics::HeadJoints>& gaze);
  // Counts and remembers a refused request; the error to return for it.
  Status reject(std::string why);
  void hold(std::string why);

  HeadConfig config_;
  std::vector<JointLimit> limits_;  // config_.joint_limits(), once
  Trajectory trajectory_;
  std::vector<JointReading> readings_;
  std::vector<JointState> commanded_;
  std::vector<double> goal_;
  bool have_goal_ = false, started_ = false, resetting_ = false, have_readings_ = false;
  int64_t plan_start_ns_ = 0;
  HeadCommand command_;
  Stats stats_;
  std::string last_rejection_;
};

}  // namespace saccade::head
