#pragma once
// Metric depth from disparity: the pinhole of the images the matcher
// compared (the rectified camera of a rectified pair, or a calibration's focal
// length with the principal point at the frame's centre) and the baseline.
#include <opencv2/core.hpp>

#include "retina_stereo.hpp"
#include "saccade/message.hpp"

namespace saccade::stereo {

struct DepthModel {
  double focal = 0, cx = 0, cy = 0;  // pixels, the retina's convention (pixel k spans [k, k + 1))
  double baseline = 0;               // metres
  // The compared images' camera frame -> the left camera's own frame (a
  // rectified pair's rotation undone; the identity otherwise).
  cv::Matx33d to_camera = cv::Matx33d::eye();
  bool valid() const { return focal > 0 && baseline > 0; }
  double depth(double disparity) const { return valid() && disparity > 0 ? focal * baseline / disparity : -1.0; }
};

// The model for a left retina: its rectification when it has one, else the
// calibration (invalid when that has no focal length and baseline).
DepthModel depth_model(const Retina& left, const StereoCalibration& calibration);

struct LocatedPoint {
  bool valid = false;
  double depth = -1;        // metres along the compared images' optical axis
  double depth_sigma = -1;  // one standard deviation, from the disparity's
  cv::Vec3d point;          // metres, the left camera's frame (x right, y down, z ahead)
};

// The point seen at `pixel` with `disparity` (both in the compared images'
// pixels); the depth's deviation is Z^2 / (f B) times the disparity's.
LocatedPoint locate(const DepthModel& model, cv::Point2d pixel, double disparity, double disparity_sigma);

}  // namespace saccade::stereo
