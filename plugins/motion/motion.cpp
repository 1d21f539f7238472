#include "motion.hpp"

#include <algorithm>
#include <cmath>

namespace saccade::motion {

LevelMotionEstimator::LevelMotionEstimator(MotionConfig config)
    : config_(config), gradient_(config.sigma, config.border) {}

namespace {

// One row: d = a - b where seen, its mask, and the running sums. T, U: the two
// images' pixel types (8-bit levels, or a float resampled previous level).
template <class T, class U>
void diff_row(const T* __restrict a, const U* __restrict b, const uint8_t* __restrict seen, float threshold, int w,
              int y, float* __restrict d, uint8_t* __restrict m, uint8_t* __restrict v, double& sum_sq, double& cx,
              double& cy, int& n_valid, int& n_moving) {
  for (int x = 0; x < w; ++x) d[x] = static_cast<float>(a[x]) - static_cast<float>(b[x]);
  if (seen != nullptr)
    for (int x = 0; x < w; ++x) {
      d[x] = seen[x] ? d[x] : 0.0f;
      v[x] = seen[x] ? 255 : 0;
    }
  else
    for (int x = 0; x < w; ++x) v[x] = 255;
  for (int x = 0; x < w; ++x) m[x] = std::fabs(d[x]) > threshold ? 255 : 0;
  for (int x = 0; x < w; ++x) {
    sum_sq += static_cast<double>(d[x]) * d[x];
    n_valid += v[x] != 0;
    if (m[x]) {
      ++n_moving;
      cx += x;
      cy += y;
    }
  }
}

}  // namespace

void LevelMotionEstimator::run(const cv::Mat& cur, const cv::Mat& prev, const cv::Mat& valid, LevelMotion& out) {
  CV_Assert(cur.size() == prev.size() && cur.type() == CV_8UC1 && prev.channels() == 1 &&
            (prev.depth() == CV_8U || prev.depth() == CV_32F));
  const int w = cur.cols, h = cur.rows;
  out.diff.create(h, w, CV_32F);
  out.mask.create(h, w, CV_8U);
  out.valid.create(h, w, CV_8U);
  double sum_sq = 0, cx = 0, cy = 0;
  int n_valid = 0, n_moving = 0;
  for (int y = 0; y < h; ++y) {
    const uint8_t* seen = valid.empty() ? nullptr : valid.ptr<uint8_t>(y);
    if (prev.depth() == CV_8U)
      diff_row(cur.ptr<uint8_t>(y), prev.ptr<uint8_t>(y), seen, config_.threshold, w, y, out.diff.ptr<float>(y),
               out.mask.ptr<uint8_t>(y), out.valid.ptr<uint8_t>(y), sum_sq, cx, cy, n_valid, n_moving);
    else
      diff_row(cur.ptr<uint8_t>(y), prev.ptr<float>(y), seen, config_.threshold, w, y, out.diff.ptr<float>(y),
               out.mask.ptr<uint8_t>(y), out.valid.ptr<uint8_t>(y), sum_sq, cx, cy, n_valid, n_moving);
  }
  gradient_.run(out.diff, out.mx, out.my);
  out.energy = n_valid > 0 ? sum_sq / n_valid : 0.0;
  out.moving = n_valid > 0 ? static_cast<double>(n_moving) / n_valid : 0.0;
  out.centroid = n_moving > 0 ? cv::Point2d(cx / n_moving, cy / n_moving) : cv::Point2d(-1, -1);
}

void resample_level(const cv::Mat& prev, const LevelGeometry& prev_geometry, const LevelGeometry& geometry,
                    cv::Mat& out, cv::Mat& valid) {
  CV_Assert(prev.channels() == 1);
  out.create(prev.size(), CV_32F);
  valid.create(prev.size(), CV_8U);
  const int w = prev.cols, h = prev.rows;
  auto at = [&](int x, int y) {
    return prev.depth() == CV_8U ? static_cast<float>(prev.ptr<uint8_t>(y)[x]) : prev.ptr<float>(y)[x];
  };
  for (int y = 0; y < h; ++y) {
    float* o = out.ptr<float>(y);
    uint8_t* v = valid.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      cv::Point2d p = prev_geometry.from_source(geometry.to_source(x, y));
      if (p.x < 0 || p.y < 0 || p.x > w - 1 || p.y > h - 1) {
        o[x] = 0;
        v[x] = 0;
        continue;
      }
      int x0 = std::min(static_cast<int>(p.x), w - 2 < 0 ? 0 : w - 2), y0 = std::min(static_cast<int>(p.y), h - 2 < 0 ? 0 : h - 2);
      float fx = static_cast<float>(p.x - x0), fy = static_cast<float>(p.y - y0);
      int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
      o[x] = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) + fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1));
      v[x] = 255;
    }
  }
}

}  // namespace saccade::motion
