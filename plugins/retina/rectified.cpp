#include "rectified.hpp"

#include <algorithm>
#include <cmath>

namespace saccade::retina {

namespace {

cv::Matx33d matrix(const cv::Vec<double, 9>& v) { return {v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]}; }

int sub_step(double step) { return std::max(1, static_cast<int>(std::ceil(step / 3.0 - 1e-9))); }

// A frame's pixels for bilinear lookups: positions outside take the edge.
template <int kChannels>
struct Pixels {
  explicit Pixels(const cv::Mat& frame)
      : data(frame.data),
        step(static_cast<std::ptrdiff_t>(frame.step[0])),
        max_u(frame.cols - 1.0),
        max_v(frame.rows - 1.0),
        last_x(std::max(frame.cols - 2, 0)),
        last_y(std::max(frame.rows - 2, 0)),
        dx(frame.cols > 1 ? kChannels : 0),
        dy(frame.rows > 1 ? step : 0) {}
  // Channel c at (u, v) in OpenCV's pixel convention (centers at integers).
  double at(double u, double v, int c) const {
    u = std::clamp(u, 0.0, max_u);
    v = std::clamp(v, 0.0, max_v);
    const int x = std::min(static_cast<int>(u), last_x), y = std::min(static_cast<int>(v), last_y);
    const double a = u - x, b = v - y;
    const uint8_t* p = data + y * step + x * kChannels + c;
    const double top = p[0] + a * (p[dx] - p[0]);
    const double bottom = p[dy] + a * (p[dy + dx] - p[dy]);
    return top + b * (bottom - top);
  }
  const uint8_t* data;
  std::ptrdiff_t step;
  double max_u, max_v;
  int last_x, last_y;
  std::ptrdiff_t dx, dy;
};

// The source positions of the cell centers (OpenCV's convention), a row of
// the level after another; scratch kept per thread so that sampling allocates
// nothing in steady state.
struct Scratch {
  std::vector<int> cols, rows;
  std::vector<cv::Point2d> at;
};
Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

// Where a cell's neighbours at +-sub-step lie in the source: the map's
// derivative from the neighbouring cell centers (exact for an affine map, and
// the map bends little over a cell), so that each cell costs one projection,
// not five.
inline cv::Point2d derivative(const cv::Point2d* at, const int* centers, int i, int n, std::ptrdiff_t stride) {
  const int lo = i > 0 ? i - 1 : i, hi = i + 1 < n ? i + 1 : i;
  if (hi == lo || centers[hi] == centers[lo]) return {stride == 1 ? 1.0 : 0.0, stride == 1 ? 0.0 : 1.0};
  return (at[(hi - i) * stride] - at[(lo - i) * stride]) / static_cast<double>(centers[hi] - centers[lo]);
}

template <int kChannels>
void sample_level_with(const cv::Mat& frame, const RectifiedMap& map, double x0, double y0, double step_x,
                       double step_y, cv::Size size, bool crop, cv::Mat& out) {
  const int sx = sub_step(step_x), sy = sub_step(step_y);
  const Pixels<kChannels> pixels(frame);
  Scratch& t = scratch();
  t.cols.resize(static_cast<std::size_t>(size.width));
  t.rows.resize(static_cast<std::size_t>(size.height));
  t.at.resize(static_cast<std::size_t>(size.area()));
  for (int i = 0; i < size.width; ++i)
    t.cols[static_cast<std::size_t>(i)] =
        crop ? static_cast<int>(std::floor(x0)) + i : static_cast<int>(std::floor(x0 + (i + 0.5) * step_x));
  for (int j = 0; j < size.height; ++j)
    t.rows[static_cast<std::size_t>(j)] =
        crop ? static_cast<int>(std::floor(y0)) + j : static_cast<int>(std::floor(y0 + (j + 0.5) * step_y));
  for (int j = 0; j < size.height; ++j)
    for (int i = 0; i < size.width; ++i) {
      cv::Point2d& p = t.at[static_cast<std::size_t>(j * size.width + i)];
      if (!map.to_source({t.cols[static_cast<std::size_t>(i)] + 0.5, t.rows[static_cast<std::size_t>(j)] + 0.5}, p))
        p = {-1e9, -1e9};
      p -= cv::Point2d(0.5, 0.5);
    }
  for (int j = 0; j < size.height; ++j) {
    uint8_t* o = out.ptr<uint8_t>(j);
    const cv::Point2d* row = t.at.data() + static_cast<std::ptrdiff_t>(j) * size.width;
    for (int i = 0; i < size.width; ++i) {
      const cv::Point2d p = row[i];
      if (crop) {
        for (int c = 0; c < kChannels; ++c)
          o[i * kChannels + c] =
              static_cast<uint8_t>(pixels.at(p.x, p.y, c) + 0.5);  // in 0 .. 255.5: truncation rounds
        continue;
      }
      const cv::Point2d dx = derivative(row + i, t.cols.data(), i, size.width, 1) * sx;
      const cv::Point2d dy = derivative(row + i, t.rows.data(), j, size.height, size.width) * sy;
      for (int c = 0; c < kChannels; ++c) {
        const double sum = pixels.at(p.x, p.y, c) + pixels.at(p.x - dx.x, p.y - dx.y, c) +
                           pixels.at(p.x + dx.x, p.y + dx.y, c) + pixels.at(p.x - dy.x, p.y - dy.y, c) +
                           pixels.at(p.x + dy.x, p.y + dy.y, c);
        // The plain rule's rounding, (sum + 2) / 5: halves up; a little slack
        // so that sums of whole numbers round as the integer rule does.
        o[i * kChannels + c] = static_cast<uint8_t>(sum / 5 + 0.5 + 1e-9);
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
    status_ = Status::error("a singular camera, rectified camera or rotation matrix");
    return;
  }
  if (rectification.distortion[12] != 0 || rectification.distortion[13] != 0)
    status_ = Status::error("a tilted sensor (distortion coefficients 13 and 14) is not supported");
  ray_from_rectified_ =
      r.inv() * kr.inv();  // inv, not the transpose: a rotation read from text is not quite orthonormal
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
  // OpenCV's convention inside: pixel centers at integers.
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

Status sample_rectified(const RetinaConfig& config, const cv::Mat& frame, const RectifiedMap& map, cv::Point2d fovea,
                        Retina& out) {
  if (!map.status().ok()) return Status::error("rectified sampling: " + map.status().message());
  if (config.mode != SamplingMode::kFivePoint)
    return Status::error("rectified sampling uses the five-point rule (mode five_point)");
  const cv::Point2d at = map.to_rectified(fovea);
  retina_geometry(config, frame.size(), at, out.geometry);
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
