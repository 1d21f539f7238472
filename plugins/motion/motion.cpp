#include "motion.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "saccade/simd.hpp"

namespace saccade::motion {

LevelMotionEstimator::LevelMotionEstimator(MotionConfig config)
    : config_(config), gradient_(config.sigma, config.border) {}

namespace {

// One row against a float (resampled) previous level: d = a - b where seen,
// its mask, and the running sums.
void diff_row(const uint8_t* __restrict a, const float* __restrict b, const uint8_t* __restrict seen, float threshold,
              int w, int y, float* __restrict d, uint8_t* __restrict m, uint8_t* __restrict v, double& sum_sq,
              double& cx, double& cy, int& n_valid, int& n_moving) {
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

// Both levels 8-bit: every difference is a whole number, so its square and
// the centroid's coordinates are summed exactly in integers per row (which
// vectorise; the double sums of the same whole numbers come out identical),
// all rows in one call.
SACCADE_AVX2_CLONE void diff_rows_u8(const uint8_t* __restrict a, std::ptrdiff_t a_step, const uint8_t* __restrict b,
                                     std::ptrdiff_t b_step, const uint8_t* __restrict seen, std::ptrdiff_t seen_step,
                                     float threshold, int w, int h, float* __restrict d, std::ptrdiff_t d_step,
                                     uint8_t* __restrict m, std::ptrdiff_t m_step, uint8_t* __restrict v,
                                     std::ptrdiff_t v_step, double& sum_sq, double& cx, double& cy, int& n_valid,
                                     int& n_moving) {
  for (int y = 0; y < h; ++y) {
    const uint8_t* ar = a + y * a_step;
    const uint8_t* br = b + y * b_step;
    const uint8_t* sr = seen != nullptr ? seen + y * seen_step : nullptr;
    float* dr = d + y * d_step;
    uint8_t* mr = m + y * m_step;
    uint8_t* vr = v + y * v_step;
    int64_t row_sq = 0, row_x = 0;
    int row_valid = 0, row_moving = 0;
    for (int x = 0; x < w; ++x) {
      int diff = static_cast<int>(ar[x]) - static_cast<int>(br[x]);
      const bool in_view = sr == nullptr || sr[x] != 0;
      diff = in_view ? diff : 0;
      const bool moving = std::fabs(static_cast<float>(diff)) > threshold;
      dr[x] = static_cast<float>(diff);
      vr[x] = in_view ? 255 : 0;
      mr[x] = moving ? 255 : 0;
      row_sq += static_cast<int64_t>(diff * diff);
      row_valid += in_view;
      row_moving += moving;
      row_x += moving ? x : 0;
    }
    sum_sq += static_cast<double>(row_sq);
    n_valid += row_valid;
    n_moving += row_moving;
    cx += static_cast<double>(row_x);
    cy += static_cast<double>(y) * row_moving;
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
  if (prev.depth() == CV_8U) {
    diff_rows_u8(cur.ptr<uint8_t>(), static_cast<std::ptrdiff_t>(cur.step), prev.ptr<uint8_t>(),
                 static_cast<std::ptrdiff_t>(prev.step), valid.empty() ? nullptr : valid.ptr<uint8_t>(),
                 valid.empty() ? 0 : static_cast<std::ptrdiff_t>(valid.step), config_.threshold, w, h,
                 out.diff.ptr<float>(), static_cast<std::ptrdiff_t>(out.diff.step1()), out.mask.ptr<uint8_t>(),
                 static_cast<std::ptrdiff_t>(out.mask.step), out.valid.ptr<uint8_t>(),
                 static_cast<std::ptrdiff_t>(out.valid.step), sum_sq, cx, cy, n_valid, n_moving);
  } else {
    for (int y = 0; y < h; ++y)
      diff_row(cur.ptr<uint8_t>(y), prev.ptr<float>(y), valid.empty() ? nullptr : valid.ptr<uint8_t>(y),
               config_.threshold, w, y, out.diff.ptr<float>(y), out.mask.ptr<uint8_t>(y), out.valid.ptr<uint8_t>(y),
               sum_sq, cx, cy, n_valid, n_moving);
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
      int x0 = std::min(static_cast<int>(p.x), w - 2 < 0 ? 0 : w - 2),
          y0 = std::min(static_cast<int>(p.y), h - 2 < 0 ? 0 : h - 2);
      float fx = static_cast<float>(p.x - x0), fy = static_cast<float>(p.y - y0);
      int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
      o[x] = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) + fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1));
      v[x] = 255;
    }
  }
}

}  // namespace saccade::motion
