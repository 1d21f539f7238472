#pragma once
// The simulated stereo head's cameras: a wide scene (a large image of real
// content) on a wall in front of the head, and optionally a textured target
// moving in 3D between head and wall, rendered into the left and right
// cameras for any joint angles by ray casting through the head's kinematics.
// With the joint state fed back from the (simulated) drives, the whole active
// vision loop runs on one machine.
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "kinematics.hpp"

namespace saccade::capture {

struct SimHeadConfig {
  cv::Size size{320, 240};
  double focal_px = 277.0;     // pixels (60 degrees across 320)
  double wall_distance = 2.0;  // m, the scene's plane y = wall_distance
  double wall_width = 4.0;     // m the scene image spans (its height follows its aspect)
  kinematics::HeadGeometry geometry;
  bool target = true;
  double target_radius = 0.08;   // m
  double target_distance = 1.6;  // m: the target moves in the plane y = this
  double target_speed = 0.3;     // m/s sideways, bouncing between +-target_range
  double target_range = 1.5;     // m
  double target_start = 0.0;     // m: x at t = 0
  double target_height = 0.0;    // m above the cameras' height
};

// A camera that stops at `at` (s) and comes back `duration` s later (0:
// never): fault injection for the loop's tests.
struct CameraOutage {
  double at = -1, duration = 0;
  bool covers(double t) const { return at >= 0 && t >= at && (duration <= 0 || t < at + duration); }
};

struct TargetView {
  cv::Point2d center;  // pixels (may be outside the image)
  double radius = 0;   // pixels
  double depth = 0;    // m along the optical axis (<= 0: behind the camera)
  bool visible = false;
};

class SimHead {
 public:
  SimHead(cv::Mat scene, SimHeadConfig config);
  // Camera 0 (left) or 1 (right) at joints `q` and time `t` (s) into `out` (BGR).
  TargetView render(int camera, const kinematics::HeadJoints& q, double t, cv::Mat& out);
  Eigen::Vector3d target_at(double t) const;
  const SimHeadConfig& config() const { return config_; }

 private:
  cv::Mat scene_, target_texture_;
  SimHeadConfig config_;
  cv::Mat map_x_, map_y_, patch_, mask_;
};

}  // namespace saccade::capture
