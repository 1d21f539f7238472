#pragma once
// The rectified geometry of a verging stereo head for its current joints:
// the calibration (intrinsics, distortion, the cameras' relative pose at the
// joints' zero) and the head's kinematics (how each camera has turned since)
// give the cameras' relative pose now, and Bouguet's rectification (OpenCV's)
// the rotations that make the rows epipolar lines.
#include <string>
#include <utility>

#include <opencv2/core.hpp>

#include "camera_calibration.hpp"
#include "kinematics.hpp"
#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::retina {

struct PairRectification {
  Rectification left, right;  // both enabled
  cv::Matx33d rotation;       // right camera from left camera now: x_right = rotation * x_left + translation
  cv::Vec3d translation;
};

// The rotations that rectify a pair (left, right: each camera's frame ->
// the rectified frame) whose right camera sees x_right = rotation * x_left +
// translation: Bouguet's, as cv::stereoRectify computes them, without its
// allocations (the head's joints change every frame).
std::pair<cv::Matx33d, cv::Matx33d> rectifying_rotations(const cv::Matx33d& rotation, const cv::Vec3d& translation);

// The left camera is taken to sit exactly on its chain's optical frame; what
// the calibration's relative pose at zero differs from the model's is put on
// the right camera's mount, and moves with it:
//   T(q) = T_calibration(0) * T_model(0)^-1 * T_model(q),
// with T_model(q) = right(q)^-1 * left(q) from the kinematics. At the joints'
// zero this is the calibration's own pose. The pair's rectification, or an
// error naming the calibration and what is wrong.
Result<PairRectification> rectify_pair(const kinematics::HeadCalibration& calibration,
                                       const kinematics::HeadGeometry& geometry, const kinematics::HeadJoints& joints);

// The head's cameras as the model sees them: pinhole cameras of `focal_px`
// centred on the image, no distortion, their relative pose at zero from the
// kinematics. What capture.sim_head renders with.
kinematics::HeadCalibration model_calibration(cv::Size size, double focal_px, const kinematics::HeadGeometry& geometry);

}  // namespace saccade::retina
