#include "tracker.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "saccade/simd.hpp"
#include "saccade/subpixel.hpp"

namespace saccade::fovea {

namespace {

void to_gray(const cv::Mat& in, cv::Mat& out) {
  if (in.channels() == 3)
    cv::cvtColor(in, out, cv::COLOR_BGR2GRAY);
  else
    in.copyTo(out);
}

// The cross terms of every placement: result row y gets, for each template
// pixel (tx, ty), its centred value times the window row y + ty from column
// tx on, 32 or 8 placements at a time (sliding_dots, summed in the same order
// as one placement at a time). One call for all of them: the rows are short,
// and a call per row and template pixel cost more than the products.
// `centred` holds the window less 128 (the template's centred values sum to
// zero, so the offset cancels and the float sums stay small). `rw` a multiple
// of eight.
SACCADE_AVX2_CLONE void cross_terms(float* __restrict result, std::ptrdiff_t result_step, int rw, int rh,
                                    const float* __restrict centered, std::ptrdiff_t window_step,
                                    const float* __restrict templ, std::ptrdiff_t templ_step, int tw, int th,
                                    float t_mean) {
  const auto scale = [&](int ty, int tx) { return templ[ty * templ_step + tx] - t_mean; };
  for (int y = 0; y < rh; ++y) {
    float* out = result + y * result_step;
    const float* w = centered + y * window_step;
    int x = 0;
    for (; x + 32 <= rw; x += 32) sliding_dots<4>(w + x, window_step, th, tw, scale, out + x);
    for (; x < rw; x += 8) sliding_dots<1>(w + x, window_step, th, tw, scale, out + x);
  }
}

// One row of placements from their cross terms (in `out`) and their sums of
// W and W^2: OpenCV's rule, a flat window (or template) scores 0, and a
// numerator rounding past the denominator is clamped to +-1. Without branches
// so that it vectorises; the same operations per placement.
SACCADE_AVX2_CLONE void normalise_row(float* __restrict out, const double* __restrict sum, const double* __restrict sq,
                                      int rw, double n, double t_norm, double min_window_norm) {
  for (int x = 0; x < rw; ++x) {
    const double s = sum[x];
    const double window_norm = std::sqrt(std::max(0.0, sq[x] - s * s / n));
    const double norm = window_norm * t_norm;
    const double num = out[x];
    const double magnitude = std::fabs(num);
    const double clamped = magnitude < norm * 1.125 ? (num > 0 ? 1.0 : -1.0) : 0.0;
    const double score = magnitude < norm ? num / norm : clamped;
    out[x] = static_cast<float>(window_norm >= min_window_norm ? score : 0.0);
  }
}

constexpr int kSlidRows = 4;  // the result rows whose placements' sums are slid along together

// The column sums of W and W^2 over the template's rows moved down a row:
// `add` the row entering, `sub` the row leaving (none while the first rows
// fill the template's height).
SACCADE_AVX2_CLONE void slide_columns(double* __restrict sum, double* __restrict sq, const float* __restrict add,
                                      const float* __restrict sub, int cols) {
  for (int x = 0; x < cols; ++x) {
    sum[x] += add[x];
    sq[x] += static_cast<double>(add[x]) * add[x];
  }
  if (sub == nullptr) return;
  for (int x = 0; x < cols; ++x) {
    sum[x] -= sub[x];
    sq[x] -= static_cast<double>(sub[x]) * sub[x];
  }
}

// The sums of W and W^2 of each placement of `rows` (1 to kSlidRows) result
// rows, from their column sums (`column_sum`, `column_sq`: a row of `cols`
// each): along a row each from the one before, in order; the rows' chains
// side by side (a missing row's lanes repeat the last one's and are not kept).
void slide_rows(const double* column_sum, const double* column_sq, std::size_t cols, int rows, int tw, int rw,
                double* row_sum, double* row_sq) {
  std::array<const double*, kSlidRows> cs, cq;
  std::array<double, kSlidRows> s{}, s2{};
  for (int k = 0; k < kSlidRows; ++k) {
    const std::size_t from = static_cast<std::size_t>(std::min(k, rows - 1)) * cols;
    cs[static_cast<std::size_t>(k)] = column_sum + from;
    cq[static_cast<std::size_t>(k)] = column_sq + from;
  }
  for (std::size_t k = 0; k < kSlidRows; ++k)
    for (int x = 0; x < tw; ++x) {
      s[k] += cs[k][x];
      s2[k] += cq[k][x];
    }
  const auto keep = [&](int x) {
    for (std::size_t k = 0; k < static_cast<std::size_t>(rows); ++k) {
      row_sum[k * static_cast<std::size_t>(rw) + static_cast<std::size_t>(x)] = s[k];
      row_sq[k * static_cast<std::size_t>(rw) + static_cast<std::size_t>(x)] = s2[k];
    }
  };
  keep(0);
  for (int x = 1; x < rw; ++x) {
    for (std::size_t k = 0; k < kSlidRows; ++k) {
      s[k] += cs[k][x + tw - 1] - cs[k][x - 1];
      s2[k] += cq[k][x + tw - 1] - cq[k][x - 1];
    }
    keep(x);
  }
}

}  // namespace

void match_template_normed(const cv::Mat& window, const cv::Mat& templ, cv::Mat& result, CorrelationScratch& scratch,
                           double min_relative_contrast) {
  CV_Assert(window.type() == CV_32F && templ.type() == CV_32F && window.cols >= templ.cols &&
            window.rows >= templ.rows);
  const int tw = templ.cols, th = templ.rows, rw = window.cols - tw + 1, rh = window.rows - th + 1;
  const double n = static_cast<double>(tw) * th;
  result.create(rh, rw, CV_32F);
  // The template less its mean, and its norm.
  double t_sum = 0, t_sq = 0;
  for (int y = 0; y < th; ++y) {
    const float* t = templ.ptr<float>(y);
    for (int x = 0; x < tw; ++x) {
      t_sum += t[x];
      t_sq += static_cast<double>(t[x]) * t[x];
    }
  }
  const double t_mean = t_sum / n, t_norm = std::sqrt(std::max(0.0, t_sq - t_sum * t_mean));
  // Rows padded to whole vectors of eight (zeros beyond the window), so the
  // inner loop has no scalar tail; the padding's results are dropped.
  const int rw8 = (rw + 7) / 8 * 8, cw = rw8 + tw - 1;
  scratch.centered.assign(static_cast<std::size_t>(cw) * static_cast<std::size_t>(window.rows), 0.0f);
  for (int y = 0; y < window.rows; ++y) {
    const float* w = window.ptr<float>(y);
    float* c = scratch.centered.data() + static_cast<std::size_t>(y) * cw;
    for (int x = 0; x < window.cols; ++x) c[x] = w[x] - 128.0f;
  }
  scratch.cross.resize(static_cast<std::size_t>(rw8) * static_cast<std::size_t>(rh));
  cross_terms(scratch.cross.data(), rw8, rw8, rh, scratch.centered.data(), cw, templ.ptr<float>(),
              static_cast<std::ptrdiff_t>(templ.step1()), tw, th, static_cast<float>(t_mean));
  for (int y = 0; y < rh; ++y)
    std::copy_n(scratch.cross.data() + static_cast<std::size_t>(y) * rw8, rw, result.ptr<float>(y));
  // Each placement's sums of W and W^2 from column sums over the template's
  // rows: each row's sums slide along it in order (each from the one before),
  // a chain whose every addition waits on the one before, so the chains of
  // kSlidRows rows run side by side; then their normalisation, which vectorises.
  const auto cols = static_cast<std::size_t>(window.cols);
  scratch.column_sum.assign(cols, 0.0);
  scratch.column_sq.assign(cols, 0.0);
  scratch.block_sum.resize(kSlidRows * cols);
  scratch.block_sq.resize(kSlidRows * cols);
  scratch.row_sum.resize(kSlidRows * static_cast<std::size_t>(rw));
  scratch.row_sq.resize(kSlidRows * static_cast<std::size_t>(rw));
  for (int wy = 0; wy < window.rows; ++wy) {
    slide_columns(scratch.column_sum.data(), scratch.column_sq.data(), window.ptr<float>(wy),
                  wy >= th ? window.ptr<float>(wy - th) : nullptr, window.cols);
    if (wy < th - 1) continue;
    const int row = wy - th + 1, lane = row % kSlidRows;
    std::copy_n(scratch.column_sum.data(), cols, scratch.block_sum.data() + static_cast<std::size_t>(lane) * cols);
    std::copy_n(scratch.column_sq.data(), cols, scratch.block_sq.data() + static_cast<std::size_t>(lane) * cols);
    if (lane < kSlidRows - 1 && row < rh - 1) continue;
    slide_rows(scratch.block_sum.data(), scratch.block_sq.data(), cols, lane + 1, tw, rw, scratch.row_sum.data(),
               scratch.row_sq.data());
    for (int k = 0; k <= lane; ++k)
      normalise_row(result.ptr<float>(row - lane + k), scratch.row_sum.data() + static_cast<std::size_t>(k * rw),
                    scratch.row_sq.data() + static_cast<std::size_t>(k * rw), rw, n, t_norm,
                    min_relative_contrast * t_norm);
  }
}

TemplateTracker::TemplateTracker(TrackerConfig config) : config_(config) {}

void TemplateTracker::reset() { template_.release(); }

bool TemplateTracker::acquire(const Retina& retina, cv::Point2d point) {
  if (retina.levels.empty()) return false;
  const cv::Mat& fovea = retina.levels.back();
  const LevelGeometry& g = retina.geometry.back();
  const cv::Size t = config_.template_size;
  if (fovea.cols < t.width || fovea.rows < t.height) return false;
  const int x =
      std::clamp(static_cast<int>(std::lround(point.x - t.width / 2.0)) - g.region.x, 0, fovea.cols - t.width);
  const int y =
      std::clamp(static_cast<int>(std::lround(point.y - t.height / 2.0)) - g.region.y, 0, fovea.rows - t.height);
  to_gray(fovea(cv::Rect(x, y, t.width, t.height)), window_gray_);
  cv::Scalar mean, stddev;
  cv::meanStdDev(window_gray_, mean, stddev);
  if (stddev[0] < config_.min_contrast) return false;
  window_gray_.convertTo(template_, CV_32F);
  offset_ = point - cv::Point2d(g.region.x + x + t.width / 2.0, g.region.y + y + t.height / 2.0);
  return true;
}

bool TemplateTracker::set_template(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U) return false;
  to_gray(image, window_gray_);
  cv::Scalar mean, stddev;
  cv::meanStdDev(window_gray_, mean, stddev);
  if (stddev[0] < config_.min_contrast) return false;
  window_gray_.convertTo(template_, CV_32F);
  config_.template_size = template_.size();
  offset_ = {};
  return true;
}

cv::Point TemplateTracker::search_window(const Retina& retina) {
  const cv::Size s = config_.search_size;
  if (retina.source && s.width > 0 && s.height > 0) {
    const cv::Mat& frame = retina.source->mat;
    const int w = std::min(s.width, frame.cols), h = std::min(s.height, frame.rows);
    const int x = std::clamp(retina.fovea.x - w / 2, 0, frame.cols - w);
    const int y = std::clamp(retina.fovea.y - h / 2, 0, frame.rows - h);
    to_gray(frame(cv::Rect(x, y, w, h)), window_gray_);
    window_gray_.convertTo(window_f_, CV_32F);
    return {x, y};
  }
  to_gray(retina.levels.back(), window_gray_);
  window_gray_.convertTo(window_f_, CV_32F);
  return retina.geometry.back().region.tl();
}

TemplateTracker::Match TemplateTracker::match(const Retina& retina) {
  Match m;
  if (template_.empty() || retina.levels.empty()) return m;
  const cv::Point origin = search_window(retina);
  if (window_f_.cols < template_.cols || window_f_.rows < template_.rows) return m;
  match_template_normed(window_f_, template_, result_, correlation_);
  double best = 0;
  cv::Point at;
  cv::minMaxLoc(result_, nullptr, &best, nullptr, &at);
  m.score = best;
  if (!(best >= config_.min_score)) return m;
  double dx = 0, dy = 0;
  if (at.x > 0 && at.x + 1 < result_.cols) {
    const float* r = result_.ptr<float>(at.y);
    dx = peak_vertex<double>(r[at.x - 1], r[at.x], r[at.x + 1]);
  }
  if (at.y > 0 && at.y + 1 < result_.rows)
    dy = peak_vertex<double>(result_.at<float>(at.y - 1, at.x), result_.at<float>(at.y, at.x),
                             result_.at<float>(at.y + 1, at.x));
  m.found = true;
  m.point =
      cv::Point2d(origin.x + at.x + dx + template_.cols / 2.0, origin.y + at.y + dy + template_.rows / 2.0) + offset_;
  if (config_.update_rate > 0 && best >= config_.update_min_score) {
    const cv::Mat patch = window_f_(cv::Rect(at, template_.size()));
    cv::addWeighted(template_, 1.0 - config_.update_rate, patch, config_.update_rate, 0.0, template_);
  }
  return m;
}

}  // namespace saccade::fovea
