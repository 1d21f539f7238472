#include "rectified.hpp"

#include <algorithm>
#include <cmath>

namespace saccade::retina {

namespace {

cv::Matx33d matrix(const cv::Vec<double, 9>& v) {
  return {v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]};
}

int sub_step(double step) { return std::max(1, static_cast<int>(std::ceil(step / 3.0 - 1e-9))); }

// Bilinear value of channel c at source position (u, v) in OpenCV's pixel
// convention (centres at integers); positions outside take the edge.
template <int kChannels>
double bilinear(const cv::Mat& frame, double u, double v, int c) {
  u = std::clamp(u, 0.0, frame.cols - 1.0);
  v = std::clamp(v, 0.0, frame.rows - 1.0);
  const int x = std::min(static_cast<int>(u), frame.cols - 2 < 0 ? 0 : frame.cols - 2);
  const int y = std::min(static_cast<int>(v), frame.rows - 2 < 0 ? 0 : frame.rows - 2);
  const double a = u - x, b = v - y;
  const int x1 = std::min(x + 1, frame.cols - 1), y1 = std::min(y + 1, frame.rows - 1);
  const uint8_t* r0 = frame.ptr<uint8_t>(y);
  const uint8_t* r1 = frame.ptr<uint8_t>(y1);
  const double top = r0[x * kChannels + c] + a * (r0[x1 * kChannels + c] - r0[x * kChannels + c]);
  const double bottom = r1[x * kChannels + c] + a * (r1[x1 * kChannels + c] - r1[x * kChannels + c]);
  return top + b * (bottom - top);
}

template <int kChannels>
void sample_level_with(const cv::Mat& frame, const RectifiedMap& map, double x0, double y0, double step_x,
                       double step_y, cv::Size size, bool crop, cv::Mat& out) {
  const int sx = sub_step(step_x), sy = sub_step(step_y);
  // The five points' offsets (none when cropping), on the rectified grid.
  const int dx[5] = {0, -sx, sx, 0, 0}, dy[5] = {0, 0, 0, -sy, sy};
  const int points = crop ? 1 : 5;
  for (int j = 0; j < size.height; ++j) {
    const int cy = crop ? static_cast<int>(std::floor(y0)) + j : static_cast<int>(std::floor(y0 + (j + 0.5) * step_y));
    uint8_t* o = out.ptr<uint8_t>(j);
    for (int i = 0; i < size.width; ++i) {
      const int cx = crop ? static_cast<int>(std::floor(x0)) + i : static_cast<int>(std::floor(x0 + (i + 0.5) * step_x));
      double sum[kChannels] = {};
      for (int p = 0; p < points; ++p) {
        cv::Point2d s;
        if (!map.to_source({cx + dx[p] + 0.5, cy + dy[p] + 0.5}, s)) s = {-1e9, -1e9};
        for (int c = 0; c < kChannels; ++c) sum[c] += bilinear<kChannels>(frame, s.x - 0.5, s.y - 0.5, c);
      }
      for (int c = 0; c < kChannels; ++c) {
        // The plain rule's rounding: (sum + 2) / 5, i.e. halves up; a little
        // slack so that sums of exact integers round as the integer rule does.
        const double mean = sum[c] / points;
        o[i * kChannels + c] = cv::saturate_cast<uint8_t>(std::floor(mean + 0.5 + 1e-9));
      }
    }
  }
}

}  // namespace

RectifiedMap::RectifiedMap(const Rectification& rectification) : rectification_(rectification) {
  const cv::Matx33d k = matrix(rectification.camera), r = matrix(rectification.rotation),
                    kr = matrix(rectification.rectified);
  if (std::abs(cv::determinant(k)) < 1e-12 || std::abs(cv::determinant(kr)) < 1e-12 ||
      std::abs(cv::determinant(r)) < 1e-9) {
    problem_ = "a singular camera, rectified camera or rotation matrix";
    return;
  }
  if (rectification.distortion[12] != 0 || rectification.distortion[13] != 0)
    problem_ = "a tilted sensor (distortion coefficients 13 and 14) is not supported";
  ray_from_rectified_ = r.inv() * kr.inv();  // inv, not the transpose: a rotation read from text is not quite orthonormal
  rectified_from_ray_ = kr * r;
  fx_ = k(0, 0), fy_ = k(1, 1), cx_ = k(0, 2), cy_ = k(1, 2), skew_ = k(0, 1);
  for (int i = 0; i < 12; ++i) distorted_ = distorted_ || rectification.distortion[i] != 0;
}

cv::Point2d RectifiedMap::distort(double x, double y) const {
  if (!distorted_) return {x, y};
  const double* k = rectification_.distortion.val;  // k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double radial = (1 + k[0] * r2 + k[1] * r4 + k[4] * r6) / (1 + k[5] * r2 + k[6] * r4 + k[7] * r6);
  return {x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x) + k[8] * r2 + k[9] * r4,
          y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y + k[10] * r2 + k[11] * r4};
}

bool RectifiedMap::to_source(cv::Point2d rectified, cv::Point2d& source) const {
  // OpenCV's convention inside: pixel centres at integers.
  const cv::Vec3d ray = ray_from_rectified_ * cv::Vec3d(rectified.x - 0.5, rectified.y - 0.5, 1.0);
  if (ray[2] <= 1e-12) return false;
  const cv::Point2d d = distort(ray[0] / ray[2], ray[1] / ray[2]);
  source = {fx_ * d.x + skew_ * d.y + cx_ + 0.5, fy_ * d.y + cy_ + 0.5};
  return true;
}

cv::Point2d RectifiedMap::to_rectified(cv::Point2d source) const {
  // Normalised distorted coordinates, the lens model inverted by Newton's
  // method (strong wide-angle lenses defeat OpenCV's fixed-point iteration at
  // the corners), then the rotation.
  const double yd = (source.y - 0.5 - cy_) / fy_;
  const double xd = (source.x - 0.5 - cx_ - skew_ * yd) / fx_;
  double x = xd, y = yd;
  for (int it = 0; distorted_ && it < 20; ++it) {
    const cv::Point2d f = distort(x, y) - cv::Point2d(xd, yd);
    if (std::abs(f.x) + std::abs(f.y) < 1e-14) break;
    const double h = 1e-7;
    const cv::Point2d fx = (distort(x + h, y) - distort(x, y)) / h, fy = (distort(x, y + h) - distort(x, y)) / h;
    const double det = fx.x * fy.y - fy.x * fx.y;
    if (std::abs(det) < 1e-12) break;
    x -= (fy.y * f.x - fy.x * f.y) / det;
    y -= (-fx.y * f.x + fx.x * f.y) / det;
  }
  const cv::Vec3d p = rectified_from_ray_ * cv::Vec3d(x, y, 1.0);
  return {p[0] / p[2] + 0.5, p[1] / p[2] + 0.5};
}

void sample_level(const cv::Mat& frame, const RectifiedMap& map, double x0, double y0, double step_x, double step_y,
                  cv::Size size, bool crop, cv::Mat& out) {
  CV_Assert(frame.depth() == CV_8U && (frame.channels() == 1 || frame.channels() == 3));
  out.create(size, frame.type());
  if (frame.channels() == 1)
    sample_level_with<1>(frame, map, x0, y0, step_x, step_y, size, crop, out);
  else
    sample_level_with<3>(frame, map, x0, y0, step_x, step_y, size, crop, out);
}

std::string sample_rectified(const RetinaConfig& config, const cv::Mat& frame, const RectifiedMap& map,
                             cv::Point2d fovea, Retina& out) {
  if (!map.problem().empty()) return "rectified sampling: " + map.problem();
  if (config.mode != SamplingMode::kFivePoint) return "rectified sampling uses the five-point rule (mode five_point)";
  const cv::Point2d at = map.to_rectified(fovea);
  out.geometry = retina_geometry(config, frame.size(), at);
  out.levels.resize(out.geometry.size());
  for (std::size_t k = 0; k < out.geometry.size(); ++k) {
    const LevelGeometry& g = out.geometry[k];
    sample_level(frame, map, g.region.x, g.region.y, g.step_x, g.step_y, config.size, k + 1 == out.geometry.size(),
                 out.levels[k]);
  }
  out.source_size = frame.size();
  const cv::Rect inner = out.geometry.back().region;
  out.fovea = cv::Point(inner.x + inner.width / 2, inner.y + inner.height / 2);
  out.sampling = Retina::Sampling::kFivePoint;
  out.rectification = map.rectification();
  out.rectification.enabled = true;
  return {};
}

}  // namespace saccade::retina
