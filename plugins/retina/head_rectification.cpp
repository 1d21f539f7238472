#include "head_rectification.hpp"

#include <algorithm>

#include <opencv2/calib3d.hpp>

namespace saccade::retina {

namespace {

// A pose x_to = rotation * x_from + translation.
struct Pose {
  cv::Matx33d rotation = cv::Matx33d::eye();
  cv::Vec3d translation;
  Pose operator*(const Pose& b) const { return {rotation * b.rotation, rotation * b.translation + translation}; }
  Pose inverse() const { return {rotation.t(), -(rotation.t() * translation)}; }
};

// The right camera's optical frame from the left's, as the model has them at q.
Pose model_right_from_left(const kinematics::HeadGeometry& g, const kinematics::HeadJoints& q) {
  const Eigen::Isometry3d left = kinematics::optical_frame(kinematics::left_camera(g, q));
  const Eigen::Isometry3d right = kinematics::optical_frame(kinematics::right_camera(g, q));
  const Eigen::Isometry3d t = right.inverse() * left;
  Pose out;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.rotation(r, c) = t.linear()(r, c);
    out.translation[r] = t.translation()[r];
  }
  return out;
}

cv::Vec<double, 9> row_major(const cv::Matx33d& m) {
  return {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
}

// One camera's rectification into `out`; an error when its lens model is not OpenCV's.
Status fill(Rectification& out, const cv::Matx33d& camera, const std::vector<double>& distortion,
            const cv::Matx33d& rotation, const cv::Matx33d& rectified, double baseline, const char* which,
            const std::string& path) {
  if (distortion.size() > 14)
    return Status::error(path + ": the " + which + " camera has " + std::to_string(distortion.size()) +
                         " distortion coefficients; at most 14 (OpenCV's models)");
  out.enabled = true;
  out.camera = row_major(camera);
  out.distortion = {};
  for (std::size_t i = 0; i < distortion.size(); ++i) out.distortion[static_cast<int>(i)] = distortion[i];
  out.rotation = row_major(rotation);
  out.rectified = row_major(rectified);
  out.baseline = baseline;
  return {};
}

cv::Matx33d rodrigues(const cv::Vec3d& v) {
  cv::Matx33d m;
  cv::Rodrigues(v, m);
  return m;
}

}  // namespace

std::pair<cv::Matx33d, cv::Matx33d> rectifying_rotations(const cv::Matx33d& rotation, const cv::Vec3d& translation) {
  // Bouguet's, as cv::stereoRectify: each camera turned by half the relative
  // rotation, so that both face the same way, then both about the axis that
  // lays the baseline along x.
  cv::Vec3d om;
  cv::Rodrigues(rotation, om);
  const cv::Matx33d half = rodrigues(om * -0.5);
  const cv::Vec3d t = half * translation;
  const int along = std::abs(t[0]) > std::abs(t[1]) ? 0 : 1;
  cv::Vec3d axis;
  axis[along] = t[along] > 0 ? 1 : -1;
  cv::Vec3d w = t.cross(axis);
  const double nw = cv::norm(w);
  if (nw > 0) w *= std::acos(std::abs(t[along]) / cv::norm(t)) / nw;
  const cv::Matx33d turn = rodrigues(w);
  return {turn * half.t(), turn * half};
}

Result<PairRectification> rectify_pair(const kinematics::HeadCalibration& calibration,
                                       const kinematics::HeadGeometry& geometry, const kinematics::HeadJoints& joints) {
  if (calibration.image_size.area() <= 0) return Status::error(calibration.path + ": no image size");
  const Pose at_zero{calibration.rotation, calibration.translation};
  const Pose now = at_zero * model_right_from_left(geometry, kinematics::HeadJoints{}).inverse() *
                   model_right_from_left(geometry, joints);
  PairRectification out;
  out.rotation = now.rotation;
  out.translation = now.translation;
  const double baseline = cv::norm(now.translation);
  if (baseline <= 0) return Status::error(calibration.path + ": the cameras' centres coincide (baseline 0)");
  const auto [r1, r2] = rectifying_rotations(now.rotation, now.translation);
  // The camera matrix is not cv::stereoRectify's, which zooms to keep only
  // valid pixels (alpha 0) or shrinks to keep them all: a verging head's
  // would zoom by 2-3x at 20 degrees, pushing a near target's rectified
  // disparity past the frame. Instead: the sources' smallest focal length (the fovea's level pixel
  // stays about one source pixel, never finer than the cameras), and one
  // principal point (zero disparity at infinity) placed so that the mean of
  // the two optical axes lands where the sources' principal points are: each
  // camera's view stays about centred, at any vergence.
  const cv::Matx33d& kl = calibration.left_matrix;
  const cv::Matx33d& kr = calibration.right_matrix;
  const double f = std::min({kl(0, 0), kl(1, 1), kr(0, 0), kr(1, 1)});
  const cv::Vec3d axis_left = r1 * cv::Vec3d(0, 0, 1), axis_right = r2 * cv::Vec3d(0, 0, 1);
  if (axis_left[2] <= 0 || axis_right[2] <= 0)
    return Status::error(calibration.path + ": a camera looks backwards once rectified");
  const double cx = (kl(0, 2) + kr(0, 2)) / 2 - f * (axis_left[0] / axis_left[2] + axis_right[0] / axis_right[2]) / 2;
  const double cy = (kl(1, 2) + kr(1, 2)) / 2 - f * (axis_left[1] / axis_left[2] + axis_right[1] / axis_right[2]) / 2;
  const cv::Matx33d rectified(f, 0, cx, 0, f, cy, 0, 0, 1);
  if (Status left = fill(out.left, calibration.left_matrix, calibration.left_distortion, r1, rectified, baseline,
                         "left", calibration.path);
      !left.ok())
    return left;
  if (Status right = fill(out.right, calibration.right_matrix, calibration.right_distortion, r2, rectified, baseline,
                          "right", calibration.path);
      !right.ok())
    return right;
  return out;
}

kinematics::HeadCalibration model_calibration(cv::Size size, double focal_px,
                                              const kinematics::HeadGeometry& geometry) {
  kinematics::HeadCalibration out;
  out.image_size = size;
  // capture.sim_head renders pixel u (OpenCV's convention, centres at
  // integers) along (u - w / 2) / f: its principal point is (w / 2, h / 2).
  out.left_matrix = {focal_px, 0, size.width / 2.0, 0, focal_px, size.height / 2.0, 0, 0, 1};
  out.right_matrix = out.left_matrix;
  out.left_distortion.assign(5, 0.0);
  out.right_distortion.assign(5, 0.0);
  const Pose zero = model_right_from_left(geometry, kinematics::HeadJoints{});
  out.rotation = zero.rotation;
  out.translation = zero.translation;
  out.path = "the head model";
  return out;
}

}  // namespace saccade::retina
