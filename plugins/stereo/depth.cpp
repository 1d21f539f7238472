#include "depth.hpp"

namespace saccade::stereo {

DepthModel depth_model(const Retina& left, const StereoCalibration& calibration) {
  DepthModel m;
  if (left.rectification.enabled) {
    const Rectification& r = left.rectification;
    // OpenCV's principal point has pixel centres at integers: half a pixel on.
    m.focal = r.rectified[0];
    m.cx = r.rectified[2] + 0.5;
    m.cy = r.rectified[5] + 0.5;
    m.baseline = r.baseline;
    m.to_camera = cv::Matx33d(r.rotation.val).inv();
    return m;
  }
  if (!calibration.valid()) return m;
  m.focal = calibration.focal_px;
  m.baseline = calibration.baseline_m;
  m.cx = left.source_size.width / 2.0;
  m.cy = left.source_size.height / 2.0;
  return m;
}

LocatedPoint locate(const DepthModel& model, cv::Point2d pixel, double disparity, double disparity_sigma) {
  LocatedPoint out;
  const double z = model.depth(disparity);
  if (z <= 0) return out;
  out.valid = true;
  out.depth = z;
  out.depth_sigma = disparity_sigma >= 0 ? z * z / (model.focal * model.baseline) * disparity_sigma : -1.0;
  const cv::Vec3d in_compared((pixel.x - model.cx) / model.focal * z, (pixel.y - model.cy) / model.focal * z, z);
  out.point = model.to_camera * in_compared;
  return out;
}

}  // namespace saccade::stereo
