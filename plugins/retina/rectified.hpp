#pragma once
// Retinas sampled along a stereo pair's rectified geometry: the sampling grid
// is rectified, never the frame. A level pixel's five points are placed on the
// rectified image (the plain rule: integer cell centres) and each is looked up
// in the source frame through the rectifying rotation and the lens model,
// bilinearly. With the identity (same camera matrix, no rotation, no
// distortion) this is the plain retina, which the tests use. Unlike the plain
// rule, centres are not moved in from the rectified image's edge: a verging
// pair's rectified views reach beyond their frames (a near target that both
// cameras fixate lies at a large rectified disparity), and the stereo samples
// the right camera there; samples off the frame take its nearest edge pixel.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "retina.hpp"
#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::retina {

// Where rectified pixels lie in the source frame and back. Coordinates are the
// retina's: pixel k spans [k, k + 1).
class RectifiedMap {
 public:
  explicit RectifiedMap(const Rectification& rectification);
  // Ok, or an error saying why the rectification cannot be sampled (tilted
  // sensor model, a singular matrix).
  const Status& status() const { return status_; }
  // The source position of rectified point p; false when it lies behind the camera.
  bool to_source(cv::Point2d rectified, cv::Point2d& source) const;
  // The rectified position of source point p (the lens model inverted iteratively).
  cv::Point2d to_rectified(cv::Point2d source) const;
  const Rectification& rectification() const { return rectification_; }

 private:
  // The lens model on normalised coordinates (OpenCV's, without the tilt).
  cv::Point2d distort(double x, double y) const;
  Rectification rectification_;
  cv::Matx33d ray_from_rectified_;  // rotation^T * rectified^-1
  cv::Matx33d rectified_from_ray_;  // rectified * rotation
  double fx_ = 1, fy_ = 1, cx_ = 0, cy_ = 0, skew_ = 0;
  bool distorted_ = false;
  Status status_;
};

// One level on the rectified grid, as sample_level does on the plain one:
// pixel (i, j) at the integer cell centre floor(x0 + (i + 0.5) * step_x), ..., or
// with `crop` the rectified pixels from (floor(x0), floor(y0)). 8-bit frames of
// 1 or 3 channels; samples outside the frame take its nearest edge pixel.
void sample_level(const cv::Mat& frame, const RectifiedMap& map, double x0, double y0, double step_x, double step_y,
                  cv::Size size, bool crop, cv::Mat& out);

// A whole retina on the rectified grid: the fovea (source pixels) is mapped to
// the rectified image and the levels laid out around it as the plain retina
// lays them out on the frame. Five-point sampling only. An error says why the
// map or the configuration cannot be sampled.
Status sample_rectified(const RetinaConfig& config, const cv::Mat& frame, const RectifiedMap& map, cv::Point2d fovea,
                        Retina& out);

}  // namespace saccade::retina
