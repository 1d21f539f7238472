#include "sim_head.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "saccade/fill.hpp"
#include "saccade/reuse.hpp"

namespace saccade::capture {

SimHead::SimHead(cv::Mat scene, SimHeadConfig config) : scene_(std::move(scene)), config_(config) {
  // A saturated red disc with a white pattern: salient by colour, textured for the tracker.
  target_texture_.create(64, 64, CV_8UC3);
  target_texture_.setTo(cv::Scalar(30, 30, 220));
  for (int y = 0; y < 64; y += 16)
    for (int x = (y / 16) % 2 * 16; x < 64; x += 32)
      cv::rectangle(target_texture_, {x, y, 16, 16}, cv::Scalar(235, 235, 255), cv::FILLED);
  cv::circle(target_texture_, {32, 32}, 8, cv::Scalar(20, 20, 120), cv::FILLED);
}

Eigen::Vector3d SimHead::target_at(double t) const {
  const double range = config_.target_range, span = 4 * range;
  // A triangle wave: from target_start sideways at target_speed, turning at +-range.
  double s = std::fmod(config_.target_start + range + config_.target_speed * t, span);
  if (s < 0) s += span;
  const double x = s < 2 * range ? s - range : 3 * range - s;
  return {x, config_.target_distance, config_.geometry.l2 + config_.target_height};
}

TargetView SimHead::render(int camera, const kinematics::HeadJoints& q, double t, cv::Mat& out) {
  const cv::Size size = config_.size;
  const Eigen::Isometry3d pose = kinematics::optical_frame(camera == 0 ? kinematics::left_camera(config_.geometry, q)
                                                                       : kinematics::right_camera(config_.geometry, q));
  const Eigen::Matrix3d r = pose.linear();
  const Eigen::Vector3d o = pose.translation();
  const double f = config_.focal_px, cx = size.width / 2.0, cy = size.height / 2.0;
  const double width = config_.wall_width, height = width * scene_.rows / scene_.cols;
  const double sx = scene_.cols / width, sy = scene_.rows / height, center_z = config_.geometry.l2;
  map_x_.create(size, CV_32FC1);
  map_y_.create(size, CV_32FC1);
  for (int v = 0; v < size.height; ++v) {
    auto* mx = map_x_.ptr<float>(v);
    auto* my = map_y_.ptr<float>(v);
    const Eigen::Vector3d row = r * Eigen::Vector3d(-cx / f, (v - cy) / f, 1.0);
    const Eigen::Vector3d step = r.col(0) / f;
    for (int u = 0; u < size.width; ++u) {
      const Eigen::Vector3d d = row + step * u;
      const double s = d.y() > 1e-9 ? (config_.wall_distance - o.y()) / d.y() : -1;
      if (s <= 0) {
        mx[u] = my[u] = -1;
        continue;
      }
      mx[u] = static_cast<float>((o.x() + s * d.x() + width / 2) * sx);
      my[u] = static_cast<float>((center_z + height / 2 - (o.z() + s * d.z())) * sy);
    }
  }
  cv::remap(scene_, out, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(96, 96, 96));

  TargetView view;
  if (!config_.target) return view;
  const Eigen::Vector3d p = pose.inverse() * target_at(t);
  view.depth = p.z();
  if (p.z() <= 0.05) return view;
  view.center = {cx + f * p.x() / p.z(), cy + f * p.y() / p.z()};
  view.radius = f * config_.target_radius / p.z();
  const int size_px = static_cast<int>(std::ceil(2 * view.radius));
  const cv::Rect box(static_cast<int>(std::lround(view.center.x - view.radius)),
                     static_cast<int>(std::lround(view.center.y - view.radius)), size_px, size_px);
  const cv::Rect inside = box & cv::Rect(0, 0, size.width, size.height);
  view.visible = view.center.x >= 0 && view.center.y >= 0 && view.center.x < size.width && view.center.y < size.height;
  if (inside.area() <= 0 || size_px < 2) return view;
  // (In buffers that only grow: the target's size changes with its distance.)
  cv::Mat patch = reuse(patch_, {size_px, size_px}, target_texture_.type());
  cv::Mat mask = reuse(mask_, {size_px, size_px}, CV_8UC1);
  fill(mask, 0);
  cv::resize(target_texture_, patch, {size_px, size_px}, 0, 0, cv::INTER_AREA);
  cv::circle(mask, {size_px / 2, size_px / 2}, size_px / 2, cv::Scalar(255), cv::FILLED);
  const cv::Rect from(inside.x - box.x, inside.y - box.y, inside.width, inside.height);
  patch(from).copyTo(out(inside), mask(from));
  return view;
}

}  // namespace saccade::capture
