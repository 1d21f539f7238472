#include "gaze_controller.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace saccade::head {

using kinematics::HeadJoints;

const char* joint_name(int j) {
  static const char* const names[kJoints] = {"neck", "vergence_left", "tilt_left", "vergence_right", "tilt_right"};
  return j >= 0 && j < kJoints ? names[j] : "?";
}

std::vector<JointLimit> HeadConfig::joint_limits() const {
  const auto limit = [&](double lo, double hi) { return JointLimit{lo, hi, velocity, acceleration}; };
  return {limit(limits.neck_min, limits.neck_max), limit(limits.vergence_min, limits.vergence_max),
          limit(limits.tilt_min, limits.tilt_max), limit(limits.vergence_min, limits.vergence_max),
          limit(limits.tilt_min, limits.tilt_max)};
}

GazeController::GazeController(HeadConfig config)
    : config_(std::move(config)),
      limits_(config_.joint_limits()),
      trajectory_(limits_),
      readings_(kJoints),
      commanded_(kJoints),
      goal_(kJoints) {
  command_.position.assign(kJoints, 0.0);
  command_.velocity.assign(kJoints, 0.0);
}

HeadJoints GazeController::measured() const {
  HeadJoints q;
  q.neck = readings_[0].position;
  q.vergence_left = readings_[1].position;
  q.tilt_left = readings_[2].position;
  q.vergence_right = readings_[3].position;
  q.tilt_right = readings_[4].position;
  return q;
}

kinematics::Fixation GazeController::fixation() const {
  const HeadJoints q = measured();
  const Eigen::Isometry3d l = kinematics::left_camera(config_.geometry, q);
  const Eigen::Isometry3d r = kinematics::right_camera(config_.geometry, q);
  return kinematics::fixation_point(l.translation(), kinematics::optical_axis(l), r.translation(),
                                    kinematics::optical_axis(r));
}

Status GazeController::reject(std::string why) {
  ++stats_.rejected;
  last_rejection_ = why;
  return Status::error(std::move(why));
}

Status GazeController::accept(const Result<HeadJoints>& gaze) {
  if (!gaze.ok()) return reject(gaze.error());
  const HeadJoints& q = *gaze;
  goal_ = {q.neck, q.vergence_left, q.tilt_left, q.vergence_right, q.tilt_right};
  for (std::size_t j = 0; j < goal_.size(); ++j)
    if (goal_[j] < limits_[j].min || goal_[j] > limits_[j].max) {
      ++stats_.clamped;  // the trajectory stops at the limit: as far as the head can turn
      break;
    }
  have_goal_ = true;
  return {};
}

Status GazeController::look_at(const Eigen::Vector3d& point) {
  ++stats_.requests;
  return aim(point);
}

Status GazeController::aim(const Eigen::Vector3d& point) {
  if (!have_readings_) return reject("no joint state yet");
  if (command_.hold) return reject("holding (" + command_.fault + "): reset first");
  // Only the geometry may refuse; joint limits clamp the move instead.
  kinematics::HeadLimits open;
  open.neck_min = open.vergence_min = open.tilt_min = -M_PI;
  open.neck_max = open.vergence_max = open.tilt_max = M_PI;
  return accept(kinematics::gaze_at(point, config_.geometry, open));
}

Status GazeController::look_along(int camera, const Eigen::Vector3d& direction, double depth) {
  ++stats_.requests;
  if (!have_readings_) return reject("no joint state yet");
  const HeadJoints q = measured();
  const Eigen::Isometry3d pose = kinematics::optical_frame(camera == 0 ? kinematics::left_camera(config_.geometry, q)
                                                                       : kinematics::right_camera(config_.geometry, q));
  const Eigen::Vector3d d = direction.normalized();
  if (!(d.z() > 1e-6)) return reject("the direction does not point in front of the camera");
  if (depth <= 0) {
    const kinematics::Fixation f = fixation();
    const double along = f.valid ? (f.point - pose.translation()).dot(pose.linear().col(2)) : -1;
    depth = along > 0 ? along : config_.default_depth;
  }
  return aim(pose.translation() + pose.linear() * (d * (depth / d.z())));
}

Status GazeController::look_at_stereo(double u, double v, double disparity, double focal, double cx, double cy) {
  ++stats_.requests;
  if (!have_readings_) return reject("no joint state yet");
  const HeadJoints q = measured();
  const Eigen::Isometry3d l = kinematics::optical_frame(kinematics::left_camera(config_.geometry, q));
  const Eigen::Isometry3d r = kinematics::optical_frame(kinematics::right_camera(config_.geometry, q));
  const Eigen::Vector3d ray_l = l.linear() * Eigen::Vector3d((u - cx) / focal, (v - cy) / focal, 1.0);
  const Eigen::Vector3d ray_r = r.linear() * Eigen::Vector3d((u - disparity - cx) / focal, (v - cy) / focal, 1.0);
  const kinematics::Fixation f = kinematics::fixation_point(l.translation(), ray_l, r.translation(), ray_r);
  if (!f.valid) return reject(std::string("stereo pixel pair: ") + f.why);
  return aim(f.point);
}

Status GazeController::turn(double azimuth, double elevation) {
  ++stats_.requests;
  if (!have_readings_) return reject("no joint state yet");
  const HeadJoints q = measured();
  const Eigen::Isometry3d l = kinematics::left_camera(config_.geometry, q);
  const Eigen::Isometry3d r = kinematics::right_camera(config_.geometry, q);
  const Eigen::Vector3d center = 0.5 * (l.translation() + r.translation());
  const kinematics::Fixation f = fixation();
  const Eigen::Vector3d p =
      f.valid
          ? f.point
          : center + (kinematics::optical_axis(l) + kinematics::optical_axis(r)).normalized() * config_.default_depth;
  const Eigen::Vector3d v = p - center;
  const double range = v.norm();
  const double az = std::atan2(v.x(), v.y()) + azimuth;
  const double el = std::atan2(v.z(), std::hypot(v.x(), v.y())) + elevation;
  return aim(center + range * Eigen::Vector3d(std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)));
}

void GazeController::hold(std::string why) {
  for (std::size_t j = 0; j < readings_.size(); ++j) {
    command_.position[j] = std::clamp(readings_[j].position, limits_[j].min, limits_[j].max);
    command_.velocity[j] = 0;
  }
  command_.hold = true;
  command_.fault = std::move(why);
  started_ = have_goal_ = false;
  ++stats_.holds;
}

void GazeController::reset() {
  command_.hold = false;
  command_.fault.clear();
  ++command_.reset;
  resetting_ = true;
  started_ = have_goal_ = false;
}

const HeadCommand& GazeController::cycle(int64_t now_ns, const std::vector<JointReading>& joints) {
  for (std::size_t j = 0; j < readings_.size() && j < joints.size(); ++j) readings_[j] = joints[j];
  have_readings_ = joints.size() >= static_cast<std::size_t>(kJoints);
  if (!have_readings_ || command_.hold) return command_;

  // Supervision. After a reset, faults still on their way out count as starting.
  int waiting = 0;
  char buf[160];
  for (int j = 0; j < kJoints; ++j) {
    const JointReading& r = readings_[static_cast<std::size_t>(j)];
    if (r.health == JointReading::Health::kFault || r.health == JointReading::Health::kSilent) {
      if (!resetting_) {
        std::snprintf(buf, sizeof buf, "%s: %s", joint_name(j),
                      r.health == JointReading::Health::kFault ? "drive fault" : "drive silent");
        hold(buf);
        return command_;
      }
      ++waiting;
    } else if (r.health == JointReading::Health::kStarting) {
      ++waiting;
    } else if (static_cast<double>(now_ns - r.updated_ns) > config_.feedback_timeout * 1e9) {
      std::snprintf(buf, sizeof buf, "%s: no feedback for %.0f ms", joint_name(j), (now_ns - r.updated_ns) / 1e6);
      hold(buf);
      return command_;
    }
  }
  if (waiting > 0) {
    // Drives not ready: ask for where they are, so that enabling moves nothing.
    for (std::size_t j = 0; j < readings_.size(); ++j) {
      command_.position[j] = std::clamp(readings_[j].position, limits_[j].min, limits_[j].max);
      command_.velocity[j] = 0;
    }
    started_ = false;
    return command_;
  }
  resetting_ = false;
  if (!started_) {
    // Motion starts from where the joints are.
    std::vector<double> here(kJoints);
    for (std::size_t j = 0; j < here.size(); ++j) {
      here[j] = std::clamp(readings_[j].position, limits_[j].min, limits_[j].max);
      commanded_[j] = {here[j], 0.0, 0.0};
    }
    trajectory_.plan(commanded_, here);
    plan_start_ns_ = now_ns;
    started_ = true;
  }
  if (have_goal_) {
    double largest = 0;
    for (std::size_t j = 0; j < goal_.size(); ++j)
      largest = std::max(largest, std::abs(goal_[j] - commanded_[j].position));
    const bool saccade = largest > config_.saccade_threshold;
    ++(saccade ? stats_.saccades : stats_.pursuits);
    trajectory_.plan(commanded_, goal_, saccade ? 0.0 : config_.pursuit_time);
    plan_start_ns_ = now_ns;
    have_goal_ = false;
  }
  trajectory_.at(static_cast<double>(now_ns - plan_start_ns_) * 1e-9, commanded_);
  for (int j = 0; j < kJoints; ++j) {
    const auto i = static_cast<std::size_t>(j);
    const double error = commanded_[i].position - readings_[i].position;
    if (std::abs(error) > config_.following_error) {
      std::snprintf(buf, sizeof buf, "%s: following error %.3f rad (window %.3f)", joint_name(j), error,
                    config_.following_error);
      hold(buf);
      return command_;
    }
    command_.position[i] = commanded_[i].position;
    command_.velocity[i] = commanded_[i].velocity;
  }
  return command_;
}

}  // namespace saccade::head
