#include "retina_stereo.hpp"

#include <opencv2/imgproc.hpp>

#include "rectified.hpp"
#include "retina.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "saccade/fill.hpp"
#include "saccade/simd.hpp"
#include "saccade/subpixel.hpp"

namespace saccade::stereo {

namespace {

// The fixation window (ww x wh) against a strip of the right frame at every
// shift j (window column x paired with strip column x + j): the sums of
// products and the strip's column sums and sums of squares, all whole
// numbers summed exactly in integers (at most 255^2 per product: exact for
// windows of up to 33k pixels), in one call per level. The fovea searches the
// whole range (177 shifts at 1024x768), so the shifts are the vector lanes
// (sliding_dots); `strip32` holds the strip as integers, rows of `stride` >=
// ww + count rounded up to eight, zero beyond the strip.
SACCADE_AVX2_CLONE void window_products(const uint8_t* __restrict window, std::ptrdiff_t window_step, int ww, int wh,
                                        const uint8_t* __restrict strip, std::ptrdiff_t strip_step, int strip_cols,
                                        int count, int32_t* __restrict strip32, std::ptrdiff_t stride,
                                        int32_t* __restrict products, int32_t* __restrict column_sum,
                                        int32_t* __restrict column_sq) {
  for (int x = 0; x < strip_cols; ++x) column_sum[x] = column_sq[x] = 0;
  for (int y = 0; y < wh; ++y) {
    const uint8_t* b = strip + y * strip_step;
    int32_t* b32 = strip32 + y * stride;
    for (int x = 0; x < strip_cols; ++x) {
      column_sum[x] += b[x];
      column_sq[x] += b[x] * b[x];
      b32[x] = b[x];
    }
    for (int x = strip_cols; x < stride; ++x) b32[x] = 0;
  }
  const auto pixel = [&](int y, int x) { return static_cast<int32_t>(window[y * window_step + x]); };
  int j = 0;
  for (; j + 32 <= count; j += 32) sliding_dots<4>(strip32 + j, stride, wh, ww, pixel, products + j);
  for (; j < count; j += 8) sliding_dots<1>(strip32 + j, stride, wh, ww, pixel, products + j);
}

// One row of a level's results back to source pixels: (d + offset) * step
// where matched (left to right: and kept by the check), -1 elsewhere, and the
// left pixels' scores where valid. Four pixels at a time (GCC leaves the
// loop scalar: its float -> double -> float steps and selects); the same
// arithmetic as the scalar tail. Returns the valid left pixels.
SACCADE_AVX2_CLONE int to_source_pixels(const float* __restrict d, const float* __restrict d_score,
                                        const float* __restrict r, const float* __restrict r_score,
                                        const uint8_t* __restrict checked, int width, int offset, double step,
                                        float* __restrict forward, float* __restrict reverse, float* __restrict score) {
  typedef float v4f __attribute__((vector_size(16)));
  typedef int v4i __attribute__((vector_size(16)));
  typedef double v4d __attribute__((vector_size(32)));
  const float shift = static_cast<float>(offset);
  const v4f minus_one = v4f{} - 1.0f;
  v4i valid{};
  int x = 0;
  for (; x + 4 <= width; x += 4) {
    v4f vd, vs, vr, vrs;
    std::memcpy(&vd, d + x, sizeof vd);
    std::memcpy(&vs, d_score + x, sizeof vs);
    std::memcpy(&vr, r + x, sizeof vr);
    std::memcpy(&vrs, r_score + x, sizeof vrs);
    const v4i kept = v4i{checked[x], checked[x + 1], checked[x + 2], checked[x + 3]} != 0;
    const v4i dv = (vs > -1.0f) & kept, rv = vrs > -1.0f;
    const v4f fd = __builtin_convertvector(__builtin_convertvector(vd + shift, v4d) * step, v4f);
    const v4f fr = __builtin_convertvector(__builtin_convertvector(vr + shift, v4d) * step, v4f);
    const v4f out_d = dv ? fd : minus_one, out_r = rv ? fr : minus_one, out_s = dv ? vs : minus_one;
    std::memcpy(forward + x, &out_d, sizeof out_d);
    std::memcpy(reverse + x, &out_r, sizeof out_r);
    std::memcpy(score + x, &out_s, sizeof out_s);
    valid -= dv;
  }
  int count = valid[0] + valid[1] + valid[2] + valid[3];
  for (; x < width; ++x) {
    const bool dv = d_score[x] > -1.0f && checked[x];
    const bool rv = r_score[x] > -1.0f;
    forward[x] = dv ? static_cast<float>((d[x] + shift) * step) : -1.0f;
    reverse[x] = rv ? static_cast<float>((r[x] + shift) * step) : -1.0f;
    score[x] = dv ? d_score[x] : -1.0f;
    count += dv;
  }
  return count;
}

}  // namespace

// A padded level without sampling again what a retina's level already holds:
// the level's pixels placed at `at` (any part of them may fall outside), and
// the frame sampled (the level's rule, padded pixel (0, 0) at `origin`) in
// columns cols.start .. cols.end - 1 around them; zero in the other columns,
// where nothing reads.
void RetinaStereo::sample_around_level(const cv::Mat& frame, bool right, const cv::Mat& level, cv::Point2d origin,
                                       const LevelGeometry& g, cv::Point at, cv::Size padded, cv::Range cols, bool crop,
                                       cv::Mat& out) const {
  out.create(padded, CV_8UC1);
  const cv::Rect placed(at, level.size());
  const cv::Rect seen = placed & cv::Rect(cv::Point(), padded);
  if (seen.empty()) {
    sample_frame(frame, right, origin.x, origin.y, g.step_x, g.step_y, padded, crop, out);
    return;
  }
  if (cols.start > 0 || cols.end < padded.width) fill(out, 0);
  level(cv::Rect(seen.tl() - at, seen.size())).copyTo(out(seen));
  const int c0 = cols.start, c1 = cols.end;
  const cv::Rect strips[] = {
      {c0, 0, c1 - c0, seen.y},                                 // above
      {c0, seen.br().y, c1 - c0, padded.height - seen.br().y},  // below
      {c0, seen.y, seen.x - c0, seen.height},                   // left
      {seen.br().x, seen.y, c1 - seen.br().x, seen.height},     // right
  };
  for (const cv::Rect& strip : strips) {
    if (strip.width <= 0 || strip.height <= 0) continue;
    cv::Mat roi = out(strip);
    sample_frame(frame, right, origin.x + strip.x * g.step_x, origin.y + strip.y * g.step_y, g.step_x, g.step_y,
                 strip.size(), crop, roi);
  }
}

void RetinaStereo::sample_frame(const cv::Mat& frame, bool right, double x0, double y0, double step_x, double step_y,
                                cv::Size size, bool crop, cv::Mat& out) const {
  const retina::RectifiedMap* map = right ? right_map_.get() : left_map_.get();
  if (map != nullptr)
    retina::sample_level(frame, *map, x0, y0, step_x, step_y, size, crop, out);
  else
    retina::sample_level(frame, x0, y0, step_x, step_y, size, crop, out);
}

Status RetinaStereo::take_rectification(const Retina& left, const Retina& right) {
  const Rectification& l = left.rectification;
  const Rectification& r = right.rectification;
  if (l.enabled != r.enabled)
    return Status::error(std::string("the ") + (l.enabled ? "left" : "right") +
                         " retina is rectified and the other is not");
  if (!l.enabled) {
    left_map_.reset();
    right_map_.reset();
    return {};
  }
  if (l.rectified != r.rectified || l.baseline != r.baseline)
    return Status::error(
        "the left and right retinas were rectified for different poses (their rectified cameras differ)");
  if (!left_map_ || !(left_map_->rectification() == l)) left_map_ = std::make_shared<retina::RectifiedMap>(l);
  if (!right_map_ || !(right_map_->rectification() == r)) right_map_ = std::make_shared<retina::RectifiedMap>(r);
  if (!left_map_->status().ok()) return Status::error("left retina: " + left_map_->status().message());
  if (!right_map_->status().ok()) return Status::error("right retina: " + right_map_->status().message());
  return {};
}

// Search ranges for level k's left pixels: around the disparity the level
// outside found at the same source point, or the whole range where it found
// none. `offset` is how far left of the left region the right one lies, in
// level pixels: level disparity = source disparity / step - offset.
void RetinaStereo::predict(const std::vector<LevelDisparity>& out, const Retina& left, std::size_t k, int full_lo,
                           int full_hi, int offset, const Span* fixation, bool widen, cv::Mat& lo_out,
                           cv::Mat& hi_out) {
  const cv::Size size = left.levels[k].size();
  fill(lo_out, fixation != nullptr ? fixation->lo : full_lo);
  fill(hi_out, fixation != nullptr ? fixation->hi : full_hi);
  if (!config_.coarse_to_fine || k == 0) return;
  const LevelGeometry& g = left.geometry[k];
  const LevelGeometry& outer = left.geometry[k - 1];
  const double x0 = g.region.x, outer_x0 = outer.region.x;
  const cv::Mat& prev = out[k - 1].disparity;
  // The outer level knows the disparity to about one of its own pixels, which is
  // outer.step / g.step of this level's: the radius is counted in outer pixels.
  const int radius = static_cast<int>(std::ceil(config_.search_radius * outer.step_x / g.step_x));
  // The outer pixel under each column and each row (the mapping is separable).
  outer_col_.resize(static_cast<std::size_t>(size.width));
  for (int x = 0; x < size.width; ++x) {
    const double sx = x0 + (x + 0.5) * g.step_x;
    const int px = static_cast<int>(std::lround((sx - outer_x0) / outer.step_x - 0.5));
    outer_col_[static_cast<std::size_t>(x)] = px >= 0 && px < prev.cols ? px : -1;
  }
  // Each outer pixel's prediction once per outer row (several of this
  // level's pixels lie under each); rows under the same outer row are copies.
  constexpr int kNone = std::numeric_limits<int>::min();
  outer_center_.resize(static_cast<std::size_t>(prev.cols));
  int last_py = -1;
  for (int y = 0; y < size.height; ++y) {
    const double sy = g.region.y + (y + 0.5) * g.step_y;
    const int py = static_cast<int>(std::lround((sy - outer.region.y) / outer.step_y - 0.5));
    if (py < 0 || py >= prev.rows) continue;
    int* lo = lo_out.ptr<int>(y);
    int* hi = hi_out.ptr<int>(y);
    if (py == last_py) {
      std::copy_n(lo_out.ptr<int>(y - 1), size.width, lo);
      std::copy_n(hi_out.ptr<int>(y - 1), size.width, hi);
      continue;
    }
    last_py = py;
    const float* outer_row = prev.ptr<float>(py);
    for (int px = 0; px < prev.cols; ++px) {
      const float d = outer_row[px];
      outer_center_[static_cast<std::size_t>(px)] =
          d < 0 ? kNone : static_cast<int>(std::lround(d / g.step_x)) - offset;
    }
    for (int x = 0; x < size.width; ++x) {
      const int px = outer_col_[static_cast<std::size_t>(x)];
      if (px < 0) continue;
      const int center = outer_center_[static_cast<std::size_t>(px)];
      if (center == kNone) continue;
      lo[x] = std::max(full_lo, center - radius);
      hi[x] = std::min(full_hi, center + radius);
      if (fixation != nullptr && widen) {
        lo[x] = std::min(lo[x], fixation->lo);
        hi[x] = std::max(hi[x], fixation->hi);
      }
    }
  }
}

namespace {

// A `size` view of `buffer`, which only grows (made again only for another
// type): the searches' strips and rows differ in width from one to the next.
cv::Mat grown_view(cv::Mat& buffer, cv::Size size, int type) {
  if (buffer.cols < size.width || buffer.rows < size.height || buffer.type() != type)
    buffer.create(std::max(size.height, buffer.rows), std::max(size.width, buffer.cols), type);
  return buffer(cv::Rect(cv::Point(), size));
}

// The mean and (population) deviation of a window's pixels.
void mean_and_deviation(const cv::Mat& window, double& mean, double& deviation) {
  double sum = 0, sq = 0;
  for (int y = 0; y < window.rows; ++y) {
    const uint8_t* a = window.ptr<uint8_t>(y);
    for (int x = 0; x < window.cols; ++x) {
      sum += a[x];
      sq += static_cast<double>(a[x]) * a[x];
    }
  }
  const double area = static_cast<double>(window.cols) * window.rows;
  mean = sum / area;
  deviation = std::sqrt(std::max(0.0, sq / area - mean * mean));
}

// Where between samples the peak at `best` lies, where both its neighbours
// were measured (> -2); 0 otherwise.
double peak_offset(const std::vector<float>& samples, int best) {
  if (best <= 0 || best + 1 >= static_cast<int>(samples.size())) return 0.0;
  const double a = samples[static_cast<std::size_t>(best - 1)], b = samples[static_cast<std::size_t>(best)],
               c = samples[static_cast<std::size_t>(best + 1)];
  return a > -2 && c > -2 ? peak_vertex(a, b, c) : 0.0;
}

}  // namespace

// The fixation window's NCC (its mean and deviation given) at every shift
// s_lo .. s_hi into samples_ (-2 where the strip is too flat there); returns
// the best shift's index in samples_, or -1. The cross term at a shift is
// the sum of products less the mean times the strip's sum there (the
// window's values less their mean sum to zero).
int RetinaStereo::correlate_window(const cv::Mat& window, const cv::Mat& strip, double wm, double ws, int s_lo,
                                   int s_hi) {
  const int ww = window.cols, wh = window.rows;
  const double area = static_cast<double>(ww) * wh;
  const int count = s_hi - s_lo + 1;
  const int strip_cols = strip.cols;
  samples_.assign(static_cast<std::size_t>(count), -2.0f);
  // Whole vectors of eight shifts; the strip's rows padded for the last one.
  const int count8 = (count + 7) / 8 * 8;
  const std::ptrdiff_t stride = ww + count8;
  products_.resize(static_cast<std::size_t>(count8));
  column_sum_.resize(static_cast<std::size_t>(strip_cols));
  column_sq_.resize(static_cast<std::size_t>(strip_cols));
  strip32_.resize(static_cast<std::size_t>(stride * wh));
  // Shift s pairs window column x with strip column x + s_hi - s.
  window_products(window.ptr<uint8_t>(), static_cast<std::ptrdiff_t>(window.step), ww, wh, strip.ptr<uint8_t>(),
                  static_cast<std::ptrdiff_t>(strip.step), strip_cols, count, strip32_.data(), stride, products_.data(),
                  column_sum_.data(), column_sq_.data());
  int best = -1;
  // The strip's sums over the window's columns, slid one column per shift
  // (whole numbers: exact).
  int64_t sum = 0, sq = 0;
  for (int x = 0; x < ww; ++x) {
    sum += column_sum_[static_cast<std::size_t>(s_hi - s_lo + x)];
    sq += column_sq_[static_cast<std::size_t>(s_hi - s_lo + x)];
  }
  for (int s = s_lo; s <= s_hi; ++s) {
    const int x0s = s_hi - s;
    if (s > s_lo) {
      sum += column_sum_[static_cast<std::size_t>(x0s)] - column_sum_[static_cast<std::size_t>(x0s + ww)];
      sq += column_sq_[static_cast<std::size_t>(x0s)] - column_sq_[static_cast<std::size_t>(x0s + ww)];
    }
    const double om = static_cast<double>(sum) / area;
    const double os = std::sqrt(std::max(0.0, static_cast<double>(sq) / area - om * om));
    if (os < config_.ncc.min_texture) continue;
    const double cross = static_cast<double>(products_[static_cast<std::size_t>(x0s)]) - wm * static_cast<double>(sum);
    const float ncc = static_cast<float>(cross / (area * ws * os));
    samples_[static_cast<std::size_t>(s - s_lo)] = ncc;
    if (best < 0 || ncc > samples_[static_cast<std::size_t>(best)]) best = s - s_lo;
  }
  return best;
}

namespace {

// The fovea's centre in level k's pixels: where every level's fixation is sought.
cv::Point2d fovea_center_in(const Retina& left, std::size_t k) {
  const cv::Rect fovea = left.geometry.back().region;
  return left.geometry[k].from_source(cv::Point2d(fovea.x + fovea.width / 2.0, fovea.y + fovea.height / 2.0));
}

// Level k's window that finds the fixation: the fixation window's size (at
// most the level's), centred on the fovea's centre, inside the level.
cv::Rect fixation_window_of(const Retina& left, std::size_t k, cv::Size size) {
  const cv::Mat& level = left.levels[k];
  const int ww = std::min(size.width, level.cols), wh = std::min(size.height, level.rows);
  const cv::Point2d c = fovea_center_in(left, k);
  return {std::clamp(static_cast<int>(std::lround(c.x - ww / 2.0 + 0.5)), 0, level.cols - ww),
          std::clamp(static_cast<int>(std::lround(c.y - wh / 2.0 + 0.5)), 0, level.rows - wh), ww, wh};
}

// The matched disparities (source pixels) within `radius` level pixels of
// the level pixel under the fovea's centre, sorted.
void disparities_around_center(const Retina& left, std::size_t k, const cv::Mat& disparity, int radius,
                               std::vector<float>& values) {
  const cv::Point2d c = fovea_center_in(left, k);
  const int cx = static_cast<int>(std::floor(c.x)), cy = static_cast<int>(std::floor(c.y));
  values.clear();
  values.reserve(static_cast<std::size_t>((2 * radius + 1) * (2 * radius + 1)));
  for (int y = std::max(0, cy - radius); y <= std::min(disparity.rows - 1, cy + radius); ++y) {
    const float* row = disparity.ptr<float>(y);
    for (int x = std::max(0, cx - radius); x <= std::min(disparity.cols - 1, cx + radius); ++x)
      if (row[x] >= 0) values.push_back(row[x]);
  }
  std::sort(values.begin(), values.end());
}

}  // namespace

void RetinaStereo::find_fixation(const Retina& left, const cv::Mat* left_frame, const cv::Mat& right_frame,
                                 Fixation& out) {
  const std::size_t n = left.levels.size();
  if (level_scratch_.size() < n) level_scratch_.resize(n);
  out.per_level.assign(n, -1.0);
  out.disparity = -1;
  out.score = -1;
  out.confirmed = false;
  // Coarse to fine, the fovea's is found once the level outside it has been
  // matched (fovea_fixation).
  const std::size_t last = config_.coarse_to_fine && n > 1 ? n - 1 : n;
  double previous = -1, previous_step = 0;
  for (std::size_t k = 0; k < last; ++k) {
    const LevelGeometry& g = left.geometry[k];
    // Shifts in level pixels: the whole range on the outermost level, then
    // around the outer level's estimate (its uncertainty, a few of its pixels).
    const int full = static_cast<int>(std::ceil(config_.max_disparity / g.step_x));
    const bool refined = previous >= 0 && k + 1 < n;
    Span span{0, full};
    if (refined) {
      const int center_shift = static_cast<int>(std::lround(previous / g.step_x));
      const int radius = static_cast<int>(std::ceil(2.0 * previous_step / g.step_x));
      span = {std::max(0, center_shift - radius), std::min(full, center_shift + radius)};
    }
    if (!take_fixation(left, k, right_frame, span, refined, out)) continue;
    previous = out.per_level[k];
    previous_step = g.step_x;
  }
  if (last == n) confirm_fixation(left, left_frame, right_frame, out);
}

bool RetinaStereo::take_fixation(const Retina& left, std::size_t k, const cv::Mat& right_frame, Span span,
                                 bool second_guess, Fixation& out) {
  const LevelGeometry& g = left.geometry[k];
  const cv::Rect window = fixation_window_of(left, k, config_.fixation_window);
  const int full = static_cast<int>(std::ceil(config_.max_disparity / g.step_x));
  WindowMatch best = match_window(left, k, window, right_frame, span);
  // A peak at an end of the span, unless the whole range ends there, may be
  // the slope of one beyond it (the outer levels' large windows saw another
  // surface): the span is searched again reaching as far again on that side
  // (not the whole range, whose far peaks on repeated texture coarse to fine
  // keeps away from).
  if (best.score > -2) {
    const int reach = std::max(2, span.hi - span.lo);
    Span wider = span;
    if (best.shift <= span.lo + 0.5 && span.lo > 0) wider.lo = std::max(0, span.lo - reach);
    if (best.shift >= span.hi - 0.5 && span.hi < full) wider.hi = std::min(full, span.hi + reach);
    if (wider.lo != span.lo || wider.hi != span.hi) {
      span = wider;
      best = match_window(left, k, window, right_frame, span);
    }
  }
  // A verging head fixates with its joints: where its optical axes meet is
  // a second guess, which wins where the outer levels' wide windows saw
  // mostly background (a near target smaller than them).
  if (const double prior = vergence_prior(left); prior > 0 && second_guess) {
    const int center_shift = static_cast<int>(std::lround(prior / g.step_x));
    const Span around{std::max(0, center_shift - 2), std::min(full, center_shift + 2)};
    if (around.hi >= around.lo && (around.hi < span.lo || around.lo > span.hi)) {
      const WindowMatch other = match_window(left, k, window, right_frame, around);
      if (other.score > best.score) best = other;
    }
  }
  if (best.score < kMinFixationScore) return false;
  out.per_level[k] = best.shift * g.step_x;
  out.disparity = out.per_level[k];
  out.score = best.score;
  return true;
}

// The fovea's fixation among the surfaces the level outside it matched
// around the fovea's centre: the fovea's window alone, over the full range,
// is fooled by repeated texture (make bench-stereo --verbose: Aloe 6.3 px
// where the truth is 73), and the level outside has matched every pixel
// coarse to fine by then. The full range's peak only where that level saw
// nothing there, or where it correlates clearly better on another surface.
void RetinaStereo::fovea_fixation(const Retina& left, const LevelDisparity& outer, const cv::Mat* left_frame,
                                  const cv::Mat& right_frame, Fixation& out) {
  const std::size_t k = left.levels.size() - 1;
  const LevelGeometry& g = left.geometry[k];
  const int full = static_cast<int>(std::ceil(config_.max_disparity / g.step_x));
  const int radius = static_cast<int>(std::ceil(config_.search_radius * left.geometry[k - 1].step_x / g.step_x));
  const cv::Rect window = fixation_window_of(left, k, config_.fixation_window);
  // The surfaces the level outside saw around the centre (runs of sorted
  // disparities, each within the search radius): each searched around its
  // median by the fovea's window, the best correlation taken.
  disparities_around_center(left, k - 1, outer.disparity, 2, around_center_);
  const std::vector<float>& seen = around_center_;
  WindowMatch best;
  const auto search_around = [&](double disparity, int r) {
    const int center_shift = static_cast<int>(std::lround(disparity / g.step_x));
    const Span span{std::max(0, center_shift - r), std::min(full, center_shift + r)};
    if (span.hi < span.lo) return;
    const WindowMatch match = match_window(left, k, window, right_frame, span);
    if (match.score > best.score) best = match;
  };
  for (std::size_t first = 0; first < seen.size();) {
    std::size_t end = first + 1;
    while (end < seen.size() && seen[end] - seen[first] <= radius * g.step_x) ++end;
    search_around(seen[(first + end) / 2], radius);
    first = end;
  }
  // A verging head's own fixation (where its optical axes meet), as on the other levels.
  if (const double prior = vergence_prior(left); prior > 0 && !seen.empty()) search_around(prior, 2);
  // The fovea's own search over the whole range (the only one where the
  // level outside matched nothing there) wins where it correlates clearly
  // better: a near target smaller than the outer levels' windows is theirs to
  // miss (make bench-verge: the surfaces the level outside saw 0.4-0.6
  // against the target's 1.0), repeated texture the fovea's to be fooled by
  // (make bench-stereo: Aloe at (641, 832), 0.62 at 6.3 px against 0.45 at
  // 74.4, the truth 73). On the same surface the whole-range peak is kept
  // (no span's edge cuts its sub-pixel step short). (The head's own fixation
  // was searched above: the whole range holds it.)
  const bool own = take_fixation(left, k, right_frame, Span{0, full}, /*second_guess=*/false, out);
  const bool other_surface = !own || std::abs(best.shift * g.step_x - out.disparity) > radius * g.step_x;
  if (best.score >= kMinFixationScore && other_surface && (!own || best.score >= out.score - kFullRangeMargin)) {
    out.per_level[k] = best.shift * g.step_x;
    out.disparity = out.per_level[k];
    out.score = best.score;
  }
  confirm_fixation(left, left_frame, right_frame, out);
}

// Repeated texture fools one direction, rarely both: the right frame's
// window at the fixation, matched back over the whole range, lands on the
// fovea's window again (make bench-stereo: every fixation more than 2 px
// from the truth failed this, every one within 2 px passed but Aloe's at
// (641, 832), whose own right window repeats too).
void RetinaStereo::confirm_fixation(const Retina& left, const cv::Mat* left_frame, const cv::Mat& right_frame,
                                    Fixation& out) {
  out.confirmed = false;
  const int found_by = out.level();
  if (found_by < 0) return;
  const auto k = static_cast<std::size_t>(found_by);
  if (left_frame == nullptr) {  // nothing to check against: trusted, as before the check
    out.confirmed = true;
    return;
  }
  const LevelGeometry& g = left.geometry[k];
  const double shift = out.per_level[k] / g.step_x;
  const double back =
      reverse_shift(left, k, fixation_window_of(left, k, config_.fixation_window), *left_frame, right_frame, shift);
  out.confirmed = back >= 0 && std::abs(back - shift) <= kMatchBackTolerance;
}

// Where the right frame's window at `shift` (level pixels) from the fixation
// window matches the left frame best over the whole range (the same shift
// when the pair agrees), < 0 where it cannot be matched.
double RetinaStereo::reverse_shift(const Retina& left, std::size_t k, cv::Rect window, const cv::Mat& left_frame,
                                   const cv::Mat& right_frame, double shift) {
  LevelScratch& ls = level_scratch_[k];
  const LevelGeometry& g = left.geometry[k];
  const bool crop = k + 1 == left.levels.size();
  const int full = static_cast<int>(std::ceil(config_.max_disparity / g.step_x));
  const double x0 = g.region.x + (window.x - std::lround(shift)) * g.step_x, y0 = g.region.y + window.y * g.step_y;
  sample_frame(right_frame, true, x0, y0, g.step_x, g.step_y, window.size(), crop, reverse_window_);
  // The left frame from the right window's place (disparity 0) to the whole range.
  cv::Mat strip = grown_view(ls.strip, cv::Size(window.width + full, window.height), left_frame.type());
  sample_frame(left_frame, false, x0, y0, g.step_x, g.step_y, strip.size(), crop, strip);
  double wm, ws;
  mean_and_deviation(reverse_window_, wm, ws);
  if (ws < config_.ncc.min_texture) return -1;
  // Shift -d pairs window column x with strip column x + d.
  const int best = correlate_window(reverse_window_, strip, wm, ws, -full, 0);
  return best < 0 ? -1 : full - best;
}

RetinaStereo::WindowMatch RetinaStereo::match_window(const Retina& left, std::size_t k, cv::Rect window,
                                                     const cv::Mat& right_frame, Span span) {
  LevelScratch& ls = level_scratch_[k];
  const LevelGeometry& g = left.geometry[k];
  const std::size_t n = left.levels.size();
  // One strip of the right frame covering every shift: strip column j is the
  // right frame at left window column j - span.hi.
  const double x0 = g.region.x + (window.x - span.hi) * g.step_x;
  cv::Mat strip = grown_view(ls.strip, cv::Size(window.width + span.hi - span.lo, window.height), right_frame.type());
  sample_frame(right_frame, true, x0, g.region.y + window.y * g.step_y, g.step_x, g.step_y, strip.size(), k + 1 == n,
               strip);
  const cv::Mat pixels = left.levels[k](window);
  double wm, ws;
  mean_and_deviation(pixels, wm, ws);
  if (ws < config_.ncc.min_texture) return {};
  const int best = correlate_window(pixels, strip, wm, ws, span.lo, span.hi);
  if (best < 0) return {};
  return {best + span.lo + peak_offset(samples_, best), samples_[static_cast<std::size_t>(best)]};
}

double RetinaStereo::vergence_prior(const Retina& left) const {
  if (!left.rectification.enabled || !right_map_) return -1;
  // Each optical axis's rectified pixel; where the axes meet they share a row
  // and their columns differ by the fixated point's disparity.
  const cv::Matx33d k(left.rectification.rectified.val);
  const cv::Vec3d l = k * cv::Matx33d(left.rectification.rotation.val) * cv::Vec3d(0, 0, 1);
  const cv::Vec3d r = k * cv::Matx33d(right_map_->rectification().rotation.val) * cv::Vec3d(0, 0, 1);
  if (l[2] <= 0 || r[2] <= 0) return -1;
  return l[0] / l[2] - r[0] / r[2];
}

int RetinaStereo::around_fixation_range(bool around, int full, bool low) const {
  if (!around) return full;
  return low ? std::max(full, -config_.fovea_radius) : std::min(full, config_.fovea_radius);
}

// One level's matching, as its steps share it.
struct RetinaStereo::LevelPlan {
  std::size_t k = 0;
  bool innermost = false;  // the fovea: cropped from the frames, not sampled
  bool padded = false;     // matched on the frames sampled with a margin around the level
  int region_shift = 0;    // level pixels the right retina's region lies left of the left one's
  // The right retina's level lies on the left one's rows (else, on a rectified
  // pair whose foveae differ in row, the right frame is sampled on the left's).
  bool right_on_left_rows = true;
  int offset = 0;       // level pixels the right image lies left of the left one's (vergence's or the region's)
  double right_x0 = 0;  // source x of the right image's left edge
  bool around_fixation = false;          // the fovea, verged: searched around the fixation disparity
  int full_lo = 0, full_hi = 0;          // level disparities of 0 .. max_disparity source pixels
  int radius_lo = 0, radius_hi = 0;      // fovea_radius around the fixation, within those
  const cv::Mat* right_level = nullptr;  // the right image without a margin
};

// The images matched, their ranges, and where the level lies in them (the
// padded images' levels lie inside larger images).
struct RetinaStereo::LevelImages {
  const cv::Mat *left, *right, *lo, *hi;
  cv::Rect inside;
};

namespace {

const cv::Mat* gray_frame(const Retina& retina, cv::Mat& buffer) {
  if (!retina.source || retina.source->mat.empty()) return nullptr;
  if (retina.source->mat.channels() == 1) return &retina.source->mat;
  cv::cvtColor(retina.source->mat, buffer, cv::COLOR_BGR2GRAY);
  return &buffer;
}

// Ok when level k of the two retinas can be matched, else what is wrong.
Status check_level(const Retina& left, const Retina& right, std::size_t k, int& region_shift,
                   bool& right_on_left_rows) {
  const LevelGeometry& gl = left.geometry[k];
  const LevelGeometry& gr = right.geometry[k];
  if (left.levels[k].size() != right.levels[k].size() || left.levels[k].type() != CV_8UC1 ||
      right.levels[k].type() != CV_8UC1)
    return Status::error("level " + std::to_string(k) + ": expected 8-bit gray levels of one size");
  const double shift = (gl.region.x - gr.region.x) / gl.step_x;
  region_shift = static_cast<int>(std::lround(shift));
  const bool same_rows =
      std::abs(gl.step_x - gr.step_x) <= 1e-9 && gl.region.y == gr.region.y && gl.region.height == gr.region.height;
  right_on_left_rows = same_rows && std::abs(shift - region_shift) <= 1e-6;
  if (right_on_left_rows) return {};
  // A rectified pair's retinas may centre their foveae on different rows (each
  // camera's own fovea, mapped to the rectified image): the right frame is
  // then sampled on the left level's rows instead.
  if (left.rectification.enabled && right.source != nullptr) {
    region_shift = 0;
    return {};
  }
  if (!same_rows)
    return Status::error("level " + std::to_string(k) + ": left and right regions differ in step or rows");
  return Status::error("level " + std::to_string(k) + ": the right region is shifted by a fraction of a level pixel");
}

// Level pixels of margin on each side of the level in its padded images.
struct Margins {
  int left, right, top, bottom;
};

// Only as far as both frames reach: beyond them there is nothing to see.
// Rows: only the window's half height. Matches move along rows, so rows
// beyond the windows' reach would be sampled and never read.
Margins padded_margins(const LevelGeometry& g, cv::Size level, cv::Size frame, double right_x, int reach_left,
                       int reach_right, int half_window) {
  const auto room = [](double pixels, double step) {
    return std::max(0, static_cast<int>(std::floor(pixels / step + 1e-9)));
  };
  const int w = level.width, h = level.height;
  return {.left = std::min({reach_left, room(g.region.x, g.step_x), room(right_x, g.step_x)}),
          .right = std::min({reach_right, room(frame.width - g.region.x - w * g.step_x, g.step_x),
                             room(frame.width - right_x - w * g.step_x, g.step_x)}),
          .top = std::min(half_window, room(g.region.y, g.step_y)),
          .bottom = std::min(half_window, room(frame.height - g.region.y - h * g.step_y, g.step_y))};
}

// The fovea's ranges, when they follow the level outside, may reach right
// pixels beyond the usual margin: the margin then covers them.
void widen_to_ranges(const cv::Mat& lo, const cv::Mat& hi, int half_window, int& reach_left, int& reach_right) {
  const int w = lo.cols, h = lo.rows;
  int left = reach_left, right = reach_right;  // (not through the references, which may alias the ranges)
  for (int y = 0; y < h; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    for (int x = 0; x < w; ++x) {
      if (l[x] > u[x]) continue;
      left = std::max(left, u[x] - x + half_window);              // right pixel x - hi, its window's left column
      right = std::max(right, x - l[x] - (w - 1) + half_window);  // right pixel x - lo past the last column
    }
  }
  reach_left = left;
  reach_right = right;
}

// The matcher's results (views of the level's pixels) back to source pixels;
// returns the matched left pixels.
int to_source_disparities(const cv::Mat& lr, const cv::Mat& lr_score, const cv::Mat& rl, const cv::Mat& rl_score,
                          const cv::Mat& kept, int offset, double step, LevelDisparity& level) {
  const cv::Size size = lr.size();
  level.disparity.create(size, CV_32F);
  level.reverse.create(size, CV_32F);
  level.score.create(size, CV_32F);
  int valid = 0;
  for (int y = 0; y < size.height; ++y)
    valid += to_source_pixels(lr.ptr<float>(y), lr_score.ptr<float>(y), rl.ptr<float>(y), rl_score.ptr<float>(y),
                              kept.ptr<uint8_t>(y), size.width, offset, step, level.disparity.ptr<float>(y),
                              level.reverse.ptr<float>(y), level.score.ptr<float>(y));
  return valid;
}

}  // namespace

// Where the right image lies against the left one and which disparities the
// level searches.
void RetinaStereo::plan_level(const Retina& left, const Retina& right, const cv::Mat* right_frame, LevelPlan& plan,
                              LevelDisparity& level) {
  const std::size_t k = plan.k;
  const LevelGeometry& gl = left.geometry[k];
  // With vergence the right image is where the left level's scene is at the
  // fixation disparity: the left region moved left by it, in whole level pixels.
  const bool verged = config_.vergence && k > 0 && right_frame != nullptr && fixation_.per_level[k] > 0;
  plan.offset = verged ? static_cast<int>(std::lround(fixation_.per_level[k] / gl.step_x)) : plan.region_shift;
  plan.right_x0 = gl.region.x - plan.offset * gl.step_x;
  plan.right_level = &right.levels[k];
  // (The padded images sample it themselves, with their margin.)
  if ((verged || !plan.right_on_left_rows) && !plan.padded) {
    sample_frame(*right_frame, true, plan.right_x0, gl.region.y, gl.step_x, gl.step_y, left.levels[k].size(),
                 plan.innermost, right_level_);
    plan.right_level = &right_level_;
  }
  level.vergence = verged ? plan.offset * gl.step_x : 0;
  // A left level pixel x matches right x - d with d = D / step - offset, D the
  // disparity in source pixels (0 .. max_disparity).
  // The fovea, verged, is searched around the fixation disparity: the outer
  // level's per-pixel estimates are coarser than its whole-window fixation.
  plan.around_fixation = verged && plan.innermost;
  // Disparities within the level's width of the offset (the right image is
  // the level's width unpadded). Around an unconfirmed fixation the padded
  // fovea follows the level outside's predictions wherever they lie in the
  // range (the margin reaches them): that fixation may be far from them.
  const int cols = left.levels[k].cols, offset = plan.offset;
  const int full = static_cast<int>(std::floor(config_.max_disparity / gl.step_x));
  const int reach = plan.padded && plan.around_fixation && !fixation_.confirmed ? full : cols - 1;
  plan.full_lo = std::clamp(-offset, -reach, reach);
  plan.full_hi = std::clamp(full - offset, -reach, reach);
  plan.radius_lo = std::max(plan.full_lo, -config_.fovea_radius);
  plan.radius_hi = std::min(plan.full_hi, config_.fovea_radius);
  level.right_x0 = plan.right_x0;
  level.offset = offset;
  level.range_lo = around_fixation_range(plan.around_fixation, plan.full_lo, true);
  level.range_hi = around_fixation_range(plan.around_fixation, plan.full_hi, false);
}

// Left->right ranges per pixel; right->left searches the same pairs (see
// ncc_match_cross), so one sweep over the left pixels' candidates serves
// both directions and the check.
void RetinaStereo::search_ranges(const LevelPlan& plan, const std::vector<LevelDisparity>& out, const Retina& left,
                                 cv::Mat& lo, cv::Mat& hi) {
  if (!plan.around_fixation) {
    predict(out, left, plan.k, plan.full_lo, plan.full_hi, plan.offset, nullptr, false, lo, hi);
  } else if (config_.fovea_prediction) {
    // An unconfirmed fixation is searched only where the level outside has no prediction.
    const Span fixation{plan.radius_lo, plan.radius_hi};
    predict(out, left, plan.k, plan.full_lo, plan.full_hi, plan.offset, &fixation, fixation_.confirmed, lo, hi);
  } else {
    fill(lo, plan.radius_lo);
    fill(hi, plan.radius_hi);
  }
}

RetinaStereo::LevelImages RetinaStereo::level_images(const LevelPlan& plan, const std::vector<LevelDisparity>& out,
                                                     const Retina& left) {
  const cv::Mat& level = left.levels[plan.k];
  lo_.create(level.size(), CV_32S);
  hi_.create(level.size(), CV_32S);
  search_ranges(plan, out, left, lo_, hi_);
  return {
      .left = &level, .right = plan.right_level, .lo = &lo_, .hi = &hi_, .inside = cv::Rect(cv::Point(), level.size())};
}

// Both frames sampled with a margin around the level, so that windows and
// matches near the level's edges see real pixels instead of none.
RetinaStereo::LevelImages RetinaStereo::padded_images(const LevelPlan& plan, const std::vector<LevelDisparity>& out,
                                                      const Retina& left, const Retina& right,
                                                      const cv::Mat& left_frame, const cv::Mat& right_frame) {
  LevelScratch& ls = level_scratch_[plan.k];
  const LevelGeometry& gl = left.geometry[plan.k];
  const cv::Size size = left.levels[plan.k].size();
  const int half_window = config_.ncc.window / 2;
  int reach_left = half_window + config_.pad, reach_right = reach_left;
  const bool ranges_first = plan.around_fixation && config_.fovea_prediction;
  if (ranges_first) {
    lo_.create(size, CV_32S);
    hi_.create(size, CV_32S);
    search_ranges(plan, out, left, lo_, hi_);
    widen_to_ranges(lo_, hi_, half_window, reach_left, reach_right);
  }
  const Margins m = padded_margins(gl, size, left_frame.size(), plan.right_x0, reach_left, reach_right, half_window);
  const cv::Size padded(size.width + m.left + m.right, size.height + m.top + m.bottom);
  const cv::Rect inside(m.left, m.top, size.width, size.height);
  sample_padded(plan, left, right, left_frame, right_frame, padded, inside, ls);
  // Outside the level nothing is searched left->right.
  ls.lo_padded.create(padded, CV_32S);
  ls.hi_padded.create(padded, CV_32S);
  fill(ls.lo_padded, 1);
  fill(ls.hi_padded, 0);
  cv::Mat lo_inside = ls.lo_padded(inside), hi_inside = ls.hi_padded(inside);
  if (ranges_first) {
    lo_.copyTo(lo_inside);
    hi_.copyTo(hi_inside);
  } else {
    search_ranges(plan, out, left, lo_inside, hi_inside);
  }
  return {
      .left = &ls.left_padded, .right = &ls.right_padded, .lo = &ls.lo_padded, .hi = &ls.hi_padded, .inside = inside};
}

// A retina's level holds its frame's pixels by the same rule on the same grid
// (unless it averaged areas), so the padded images take them instead of
// sampling them again.
void RetinaStereo::sample_padded(const LevelPlan& plan, const Retina& left, const Retina& right,
                                 const cv::Mat& left_frame, const cv::Mat& right_frame, cv::Size padded,
                                 cv::Rect inside, LevelScratch& ls) const {
  const LevelGeometry& gl = left.geometry[plan.k];
  const bool crop = plan.innermost;
  const int mx0 = inside.x, my0 = inside.y, w = inside.width, mr = config_.ncc.window / 2;
  const auto holds_frame_pixels = [&](const Retina& retina, const cv::Mat& frame) {
    return !config_.keep_images && &frame == &retina.source->mat &&
           (crop || retina.sampling == Retina::Sampling::kFivePoint);
  };
  const double top = gl.region.y - my0 * gl.step_y;
  const cv::Point2d left_origin(gl.region.x - mx0 * gl.step_x, top), right_origin(plan.right_x0 - mx0 * gl.step_x, top);
  // Around the left level only the windows' half width is read, as left
  // pixels outside the level search nothing.
  if (holds_frame_pixels(left, left_frame))
    sample_around_level(left_frame, false, left.levels[plan.k], left_origin, gl, cv::Point(mx0, my0), padded,
                        cv::Range(std::max(0, mx0 - mr), std::min(padded.width, mx0 + w + mr)), crop, ls.left_padded);
  else
    sample_frame(left_frame, false, left_origin.x, left_origin.y, gl.step_x, gl.step_y, padded, crop, ls.left_padded);
  // The right retina's level serves where the verged level overlaps it
  // (outer levels verge by a few of their pixels): its pixel x lies at
  // padded column mx0 + x + offset - region_shift.
  if (plan.right_on_left_rows && holds_frame_pixels(right, right_frame))
    sample_around_level(right_frame, true, right.levels[plan.k], right_origin, gl,
                        cv::Point(mx0 + plan.offset - plan.region_shift, my0), padded, cv::Range(0, padded.width), crop,
                        ls.right_padded);
  else
    sample_frame(right_frame, true, right_origin.x, right_origin.y, gl.step_x, gl.step_y, padded, crop,
                 ls.right_padded);
}

namespace {

// fovea_recheck (RetinaStereoConfig): over the matcher's own images (its
// scratch: the images less 128, their window means and deviations), each
// valid left pixel of `inside` at disparity d (right pixel x - d) is dropped
// from `valid` where the right window correlates best with a left window
// more than `tolerance` from d, within d +- radius (radius at most
// kMaxRecheck).
constexpr int kMaxRecheck = 64;
void recheck_matches(const NccScratch& s, const cv::Mat& lr, const cv::Mat& lr_score, cv::Rect inside, int r,
                     int radius, float tolerance, float min_texture, cv::Mat& valid) {
  radius = std::min(radius, kMaxRecheck);
  const int w = s.ref_f.cols, h = s.ref_f.rows;
  const float area = static_cast<float>((2 * r + 1) * (2 * r + 1));
  std::array<float, 2 * kMaxRecheck + 1> sums;
  for (int y = std::max(inside.y, r); y < std::min(inside.br().y, h - r); ++y) {
    const float* d_row = lr.ptr<float>(y);
    const float* s_row = lr_score.ptr<float>(y);
    uint8_t* v_row = valid.ptr<uint8_t>(y);
    for (int x = inside.x; x < inside.br().x; ++x) {
      if (!v_row[x] || !(s_row[x] > -1.0f)) continue;
      const int xr = static_cast<int>(std::lround(x - d_row[x]));
      if (xr < r || xr >= w - r || s.other_std.at<float>(y, xr) < min_texture) continue;
      // Left windows at xr + dd for dd in lo .. hi, inside the image.
      const int centre = static_cast<int>(std::lround(d_row[x]));
      const int lo = std::max(centre - radius, r - xr), hi = std::min(centre + radius, w - 1 - r - xr);
      const int count = hi - lo + 1;
      if (count <= 0) continue;
      std::fill_n(sums.begin(), count, 0.0f);
      for (int j = -r; j <= r; ++j) {
        const float* a = s.ref_f.ptr<float>(y + j) + xr + lo;
        const float* b = s.other_f.ptr<float>(y + j) + xr;
        for (int i = -r; i <= r; ++i)
          for (int k = 0; k < count; ++k) sums[static_cast<std::size_t>(k)] += a[k + i] * b[i];
      }
      const float rm = s.other_mean.at<float>(y, xr), rs = s.other_std.at<float>(y, xr);
      const float* lm = s.ref_mean.ptr<float>(y) + xr + lo;
      const float* ls = s.ref_std.ptr<float>(y) + xr + lo;
      float best = -2.0f;
      int best_d = centre;
      for (int k = 0; k < count; ++k) {
        if (ls[k] < min_texture) continue;
        const float ncc = (sums[static_cast<std::size_t>(k)] / area - lm[k] * rm) / (ls[k] * rs);
        if (ncc > best) best = ncc, best_d = lo + k;
      }
      if (std::abs(static_cast<float>(best_d) - d_row[x]) > tolerance) v_row[x] = 0;
    }
  }
}

}  // namespace

// Both directions in one sweep, checked against each other, back in source
// pixels and filled as configured.
void RetinaStereo::match_level(const LevelImages& images, const LevelPlan& plan, double step, LevelDisparity& level) {
  LevelScratch& ls = level_scratch_[plan.k];
  if (config_.keep_images) {
    images.left->copyTo(level.left_image);
    images.right->copyTo(level.right_image);
    level.margin = images.inside.tl();
  }
  NccConfig ncc = config_.ncc;
  ncc.drop_range_edges = ncc.drop_range_edges || (plan.innermost && config_.fovea_range_check);
  ncc.range_floor = plan.full_lo;
  ncc.range_ceiling = plan.full_hi;
  ncc_match_cross(*images.left, *images.right, *images.lo, *images.hi, ncc, ls.lr, ls.lr_score, ls.rl, ls.rl_score,
                  ls.ncc);
  const cv::Rect inside = images.inside;
  ls.inside = inside;
  // Validity comes from the scores: with vergence a level disparity may be negative.
  ls.valid.create(images.left->size(), CV_8U);
  cv::Mat valid_view = ls.valid(inside);
  fill(valid_view, 255);
  if (config_.left_right_check)
    left_right_check(ls.lr, ls.lr_score, ls.rl, ls.rl_score, config_.lr_tolerance, ls.valid, inside);
  if (plan.innermost && config_.fovea_recheck > 0)
    recheck_matches(ls.ncc, ls.lr, ls.lr_score, inside, config_.ncc.window / 2, config_.fovea_recheck,
                    config_.lr_tolerance + 0.5f, config_.ncc.min_texture, ls.valid);
  const int valid = to_source_disparities(ls.lr(inside), ls.lr_score(inside), ls.rl(inside), ls.rl_score(inside),
                                          valid_view, plan.offset, step, level);
  level.density = static_cast<double>(valid) / static_cast<double>(level.disparity.size().area());
}

void RetinaStereo::fill_level(const LevelPlan& plan, double step, LevelDisparity& level) {
  if (plan.innermost && config_.fovea_speckle_size > 0)
    level.density = drop_speckles(level.disparity, level.score, config_.fovea_speckle_size,
                                  config_.fovea_speckle_range * step, speckles_);
  level.filled_density = level.density;
  if (config_.fill_gaps > 0) level.filled_density = fill_gaps(level.disparity, level.score, config_.fill_gaps, step);
  if (config_.fill_occlusions)
    level.filled_density = fill_occlusions(level.disparity, level.score, step, config_.occlusion_slack);
  if (config_.fill) level.filled_density = fill_holes(level.disparity, level.score, fixation_.per_level[plan.k]);
}

// Row y of level k as drop_hidden reads it (in hidden_): its disparities
// matched with a positive correlation (level pixels; -1 where unmatched,
// filled, or matched without one: those are neither checked nor taken for
// surfaces), per column the nearest surface right of it (largest disparity,
// plus a pixel of the level that saw it: its uncertainty; this level's and,
// beyond it, the outer levels') and the farthest left of it (this level's
// and, left of it, the outer levels'), and left of the level the finest
// outer level's disparities (matched or filled) with how far off they may
// be. Returns the row's largest disparity so matched (level pixels), < 0 if
// none.
float RetinaStereo::hidden_row(const Retina& left, const std::vector<LevelDisparity>& out, std::size_t k, int y) {
  HiddenScratch& hs = hidden_;
  const LevelGeometry& g = left.geometry[k];
  const cv::Mat& disparity = out[k].disparity;
  const int cols = disparity.cols;
  const double sy = g.to_source(0, y).y;
  const float* d = disparity.ptr<float>(y);
  const float* c = out[k].score.ptr<float>(y);
  hs.row.resize(static_cast<std::size_t>(cols));
  float own_max = -1;
  for (int x = 0; x < cols; ++x) {
    hs.row[static_cast<std::size_t>(x)] = d[x] >= 0 && c[x] > 0 ? static_cast<float>(d[x] / g.step_x) : -1.0f;
    own_max = std::max(own_max, hs.row[static_cast<std::size_t>(x)]);
  }
  if (own_max < 0) return own_max;
  // The outer levels' pixels on this row, finest first; `covered` is the
  // source x up to which a finer level spoke.
  float beyond = -1;
  double covered = g.region.x + cols * g.step_x;
  for (std::size_t j = k; j-- > 0;) {
    const LevelGeometry& o = left.geometry[j];
    const int oy = static_cast<int>(std::floor((sy - o.region.y) / o.step_y));
    if (oy < 0 || oy >= out[j].disparity.rows) continue;
    const float* od = out[j].disparity.ptr<float>(oy);
    const float* oc = out[j].score.ptr<float>(oy);
    for (int x = 0; x < out[j].disparity.cols; ++x)
      if (o.to_source(x, 0).x > covered && od[x] > 0 && oc[x] > 0)
        beyond = std::max(beyond, static_cast<float>((od[x] + o.step_x) / g.step_x));
    covered = std::max(covered, o.region.x + out[j].disparity.cols * o.step_x);
  }
  const int reach = static_cast<int>(std::ceil(own_max)) + 1;
  hs.outer_left.assign(static_cast<std::size_t>(reach), -1.0f);
  hs.outer_left_tolerance.assign(static_cast<std::size_t>(reach), 0.0f);
  for (int i = 0; i < reach; ++i) {
    const double sx = g.to_source(i - reach, 0).x;
    for (std::size_t j = k; j-- > 0;) {
      const LevelGeometry& o = left.geometry[j];
      const int ox = static_cast<int>(std::floor((sx - o.region.x) / o.step_x));
      const int oy = static_cast<int>(std::floor((sy - o.region.y) / o.step_y));
      if (ox < 0 || oy < 0 || ox >= out[j].disparity.cols || oy >= out[j].disparity.rows) continue;
      const float od = out[j].disparity.at<float>(oy, ox);
      if (od < 0) continue;
      hs.outer_left[static_cast<std::size_t>(i)] = static_cast<float>(od / g.step_x);
      hs.outer_left_tolerance[static_cast<std::size_t>(i)] = static_cast<float>(o.step_x / g.step_x + 1);
      break;
    }
  }
  hs.nearest_right.resize(static_cast<std::size_t>(cols));
  hs.farthest_left.resize(static_cast<std::size_t>(cols));
  float nearest = beyond, farthest = std::numeric_limits<float>::infinity();
  for (const float v : hs.outer_left)
    if (v >= 0) farthest = std::min(farthest, v);
  for (int x = cols - 1; x >= 0; --x) {
    hs.nearest_right[static_cast<std::size_t>(x)] = nearest;
    if (hs.row[static_cast<std::size_t>(x)] >= 0) nearest = std::max(nearest, hs.row[static_cast<std::size_t>(x)] + 1);
  }
  for (int x = 0; x < cols; ++x) {
    hs.farthest_left[static_cast<std::size_t>(x)] = farthest;
    if (hs.row[static_cast<std::size_t>(x)] >= 0) farthest = std::min(farthest, hs.row[static_cast<std::size_t>(x)]);
  }
  hs.nearest = nearest;
  return own_max;
}

// Whether the right window of row pixel x (its disparity `own`, level
// pixels) correlates better with another surface's place than with its own
// match (hidden_row and the row's bands in hidden_ made; the bands' column i
// is level column i - r - reach, r the window's half).
bool RetinaStereo::hidden_pixel(int x, int own, int cols, int reach) {
  HiddenScratch& hs = hidden_;
  const int w = config_.ncc.window;
  const std::vector<float>& row = hs.row;
  const int rx = x - own + reach;  // the right window's column in the right band
  if (rx < 0 || rx + w > hs.right_band.cols) return false;
  // Nearer, up to the nearest surface right of x; farther, as far as the
  // farthest surface left of x (infinite: nothing matched left of it).
  const int band_hi = own + hs.left_band.cols - w - x - reach, band_lo = own - x - reach;  // the band's shifts
  const int near_lo = own + 3;
  const int near_hi = std::min(static_cast<int>(std::ceil(hs.nearest_right[static_cast<std::size_t>(x)])), band_hi);
  const float farthest = hs.farthest_left[static_cast<std::size_t>(x)];
  const int far_hi = own - 3;
  const int far_lo =
      std::isfinite(farthest) ? std::max(static_cast<int>(std::floor(farthest)) - 1, band_lo) : far_hi + 1;
  if (near_hi < near_lo && far_hi < far_lo) return false;
  const cv::Mat window = hs.right_band(cv::Rect(rx, 0, w, w));
  double wm, ws;
  mean_and_deviation(window, wm, ws);
  if (ws < config_.ncc.min_texture) return false;
  // One sweep of the window over the left band from the farther places to
  // the nearer ones, its own match's within a pixel among them: shift s
  // pairs it with the left window at level column x - own + s, and
  // correlate_window's shift -t reads strip column t, so samples_[hi - s].
  const int lo = std::max(std::min(far_hi >= far_lo ? far_lo : own - 1, own - 1), band_lo);
  const int hi = std::min(std::max(near_hi >= near_lo ? near_hi : own + 1, own + 1), band_hi);
  const cv::Mat strip = hs.left_band(cv::Rect(x - own + lo + reach, 0, hi - lo + w, w));
  if (correlate_window(window, strip, wm, ws, lo - hi, 0) < 0) return false;
  const auto at = [&](int shift) { return samples_[static_cast<std::size_t>(hi - shift)]; };
  // Its own match at its best within a pixel (the aggregation's pick is not
  // the correlation's peak).
  float mine = -2;
  for (int shift = std::max(own - 1, lo); shift <= std::min(own + 1, hi); ++shift) mine = std::max(mine, at(shift));
  float best = -2;
  // A nearer place where this level matched the left pixel at another
  // disparity (more than 2 px off) does not count (beyond the level, the
  // outer levels place a surface too coarsely to tell).
  for (int shift = near_lo; shift <= near_hi; ++shift) {
    const int lx = x - own + shift;
    if (lx < cols && row[static_cast<std::size_t>(lx)] >= 0 && std::abs(row[static_cast<std::size_t>(lx)] - shift) > 2)
      continue;
    best = std::max(best, at(shift));
  }
  // A farther place counts where that surface was matched, at that
  // disparity (the hidden pixel took the nearer surface's).
  for (int shift = far_lo; shift <= far_hi; ++shift) {
    const int lx = x - own + shift;
    const bool consistent =
        lx >= 0 ? row[static_cast<std::size_t>(lx)] >= 0 && std::abs(row[static_cast<std::size_t>(lx)] - shift) <= 1
                : hs.outer_left[static_cast<std::size_t>(lx + reach)] >= 0 &&
                      std::abs(hs.outer_left[static_cast<std::size_t>(lx + reach)] - shift) <=
                          hs.outer_left_tolerance[static_cast<std::size_t>(lx + reach)];
    if (consistent) best = std::max(best, at(shift));
  }
  return best > -2 && best > mine;
}

// A left pixel the right camera cannot see has no match, only a wrong one,
// and within the restricted ranges the fovea searches, one that the
// left-right check passes (make bench-stereo: 13-31% of its pixels, a
// nearer surface to their right hiding them, 42-85% of them given a
// disparity, 76-97% of those wrong). Its right window shows another
// surface: the nearer one that hides it (right of it on the row, this
// level's or, beyond it, the outer levels'), or, where it took the nearer
// surface's disparity, the farther one seen left of it; matched against
// the left frame there, the window correlates better than at its own match.
void RetinaStereo::drop_hidden(const Retina& left, const cv::Mat& left_frame, const cv::Mat& right_frame,
                               std::vector<LevelDisparity>& out, std::size_t k) {
  LevelDisparity& level = out[k];
  const LevelGeometry& g = left.geometry[k];
  const bool crop = k + 1 == left.levels.size();
  const int w = config_.ncc.window, r = w / 2;
  const int cols = level.disparity.cols;
  HiddenScratch& hs = hidden_;
  int valid = 0;
  for (int y = 0; y < level.disparity.rows; ++y) {
    const float own_max = hidden_row(left, out, k, y);
    if (own_max >= 0) {
      // The row's bands of the frames, from `reach` level pixels left of the
      // level (a match's right window) to the nearest surface right of it.
      const int reach = static_cast<int>(std::ceil(own_max)) + 1;
      const int right_reach = static_cast<int>(std::ceil(std::max(hs.nearest, 0.0f))) + 1;
      const double x0 = g.region.x - (reach + r) * g.step_x, y0 = g.region.y + (y - r) * g.step_y;
      hs.left_band = grown_view(hs.left, cv::Size(reach + cols + right_reach + w, w), left_frame.type());
      hs.right_band = grown_view(hs.right, cv::Size(reach + cols + w, w), right_frame.type());
      sample_frame(left_frame, false, x0, y0, g.step_x, g.step_y, hs.left_band.size(), crop, hs.left_band);
      sample_frame(right_frame, true, x0, y0, g.step_x, g.step_y, hs.right_band.size(), crop, hs.right_band);
      float* d = level.disparity.ptr<float>(y);
      float* c = level.score.ptr<float>(y);
      for (int x = 0; x < cols; ++x) {
        const float own = hs.row[static_cast<std::size_t>(x)];
        if (own >= 0 && hidden_pixel(x, static_cast<int>(std::lround(own)), cols, reach)) d[x] = -1.0f, c[x] = -1.0f;
      }
    }
    const float* d = level.disparity.ptr<float>(y);
    for (int x = 0; x < cols; ++x) valid += d[x] >= 0;
  }
  level.density = static_cast<double>(valid) / static_cast<double>(level.disparity.total());
}

void RetinaStereo::flat_from_outer(const Retina& left, std::vector<LevelDisparity>& out, std::size_t k) {
  const LevelScratch& ls = level_scratch_[k];
  if (ls.ncc.undecided.empty()) return;
  const LevelGeometry& g = left.geometry[k];
  const LevelGeometry& o = left.geometry[k - 1];
  const cv::Mat& outer = out[k - 1].disparity;
  LevelDisparity& level = out[k];
  for (int y = 0; y < level.disparity.rows; ++y) {
    float* d = level.disparity.ptr<float>(y);
    const uint8_t* undecided = ls.ncc.undecided.ptr<uint8_t>(y + ls.inside.y) + ls.inside.x;
    for (int x = 0; x < level.disparity.cols; ++x) {
      if (d[x] < 0 || !undecided[x]) continue;
      // Bilinear over the outer pixels around the point that have a disparity.
      const cv::Point2d p = o.from_source(g.to_source(x, y));
      const int ox = static_cast<int>(std::floor(p.x)), oy = static_cast<int>(std::floor(p.y));
      double sum = 0, weight = 0;
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
          const int qx = ox + i, qy = oy + j;
          if (qx < 0 || qy < 0 || qx >= outer.cols || qy >= outer.rows) continue;
          const float v = outer.at<float>(qy, qx);
          if (v < 0) continue;
          const double share = (i ? p.x - ox : 1 - (p.x - ox)) * (j ? p.y - oy : 1 - (p.y - oy)) + 1e-6;
          sum += share * v;
          weight += share;
        }
      if (weight > 0) d[x] = static_cast<float>(sum / weight);
    }
  }
}

Status RetinaStereo::run(const Retina& left, const Retina& right, std::vector<LevelDisparity>& out) {
  if (left.levels.size() != right.levels.size() || left.levels.empty())
    return Status::error("left and right retinas differ in levels");
  const std::size_t n = left.levels.size();
  if (Status taken = take_rectification(left, right); !taken.ok()) return taken;
  out.resize(n);
  const cv::Mat* right_frame = gray_frame(right, right_gray_);
  // (The left frame pads the levels and confirms the fovea's fixation.)
  const cv::Mat* left_frame = config_.pad > 0 || config_.vergence ? gray_frame(left, left_gray_) : nullptr;
  level_scratch_.resize(n);
  fixation_.per_level.assign(n, -1.0);
  fixation_.disparity = fixation_.score = -1;
  fixation_.confirmed = false;
  if (config_.vergence && right_frame != nullptr && !left.geometry.empty())
    find_fixation(left, left_frame, *right_frame, fixation_);
  const bool padded = left_frame != nullptr && right_frame != nullptr && config_.pad > 0;
  for (std::size_t k = 0; k < n; ++k) {
    LevelPlan plan;
    plan.k = k;
    plan.innermost = k + 1 == n;
    plan.padded = padded;
    if (Status level = check_level(left, right, k, plan.region_shift, plan.right_on_left_rows); !level.ok())
      return level;
    if (plan.innermost && k > 0 && config_.vergence && right_frame != nullptr && config_.coarse_to_fine)
      fovea_fixation(left, out[k - 1], left_frame, *right_frame, fixation_);
    plan_level(left, right, right_frame, plan, out[k]);
    const LevelImages images =
        padded ? padded_images(plan, out, left, right, *left_frame, *right_frame) : level_images(plan, out, left);
    match_level(images, plan, left.geometry[k].step_x, out[k]);
    if (config_.fovea_flat_from_outer && config_.ncc.semi_global && plan.innermost && k > 0)
      flat_from_outer(left, out, k);
    if (config_.occlusion_check && plan.innermost && left_frame != nullptr && right_frame != nullptr)
      drop_hidden(left, *left_frame, *right_frame, out, k);
    fill_level(plan, left.geometry[k].step_x, out[k]);
  }
  return {};
}

namespace {

// Calls `fill(d, c, a, b)` for every unmatched run a+1 .. b-1 between two
// matched pixels a < b of each row (d, c: the row's disparities and scores),
// then returns the share of pixels with a disparity. `fill` may write only
// inside the run.
template <class Fill>
double fill_runs(cv::Mat& disparity, cv::Mat& score, Fill fill) {
  int known = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    float* d = disparity.ptr<float>(y);
    float* c = score.ptr<float>(y);
    int last = -1;  // the last matched pixel of the row
    for (int x = 0; x < disparity.cols; ++x) {
      if (d[x] < 0) continue;
      if (last >= 0 && x - last > 1) fill(d, c, last, x);
      last = x;
    }
    for (int x = 0; x < disparity.cols; ++x) known += d[x] >= 0;
  }
  return static_cast<double>(known) / static_cast<double>(disparity.total());
}

void set_run(float* d, float* c, int first, int end, float value) {
  for (int i = first; i < end; ++i) {
    d[i] = value;
    c[i] = 0.0f;
  }
}

}  // namespace

// (cv::filterSpeckles takes 8-bit and 16-bit maps only, not our float disparities.)
double drop_speckles(cv::Mat& disparity, cv::Mat& score, int min_size, double max_step, SpeckleScratch& scratch) {
  CV_Assert(disparity.type() == CV_32F && disparity.isContinuous() && score.size() == disparity.size() &&
            score.type() == CV_32F && score.isContinuous());
  const int cols = disparity.cols, count = static_cast<int>(disparity.total());
  float* d = disparity.ptr<float>();
  float* c = score.ptr<float>();
  std::vector<uint8_t>& seen = scratch.seen;
  std::vector<int>& members = scratch.members;
  seen.assign(static_cast<std::size_t>(count), 0);
  members.reserve(static_cast<std::size_t>(count));
  int kept = 0;
  for (int start = 0; start < count; ++start) {
    if (d[start] < 0 || seen[static_cast<std::size_t>(start)]) continue;
    // The region grown from `start`, breadth first (members is the queue).
    members.clear();
    members.push_back(start);
    seen[static_cast<std::size_t>(start)] = 1;
    for (std::size_t next = 0; next < members.size(); ++next) {
      const int i = members[next], x = i % cols;
      const auto join = [&](int j) {
        if (d[j] >= 0 && !seen[static_cast<std::size_t>(j)] && std::fabs(d[j] - d[i]) <= max_step)
          seen[static_cast<std::size_t>(j)] = 1, members.push_back(j);
      };
      if (x > 0) join(i - 1);
      if (x + 1 < cols) join(i + 1);
      if (i >= cols) join(i - cols);
      if (i + cols < count) join(i + cols);
    }
    if (static_cast<int>(members.size()) >= min_size) {
      kept += static_cast<int>(members.size());
      continue;
    }
    for (const int i : members) d[i] = -1.0f, c[i] = -1.0f;
  }
  return count > 0 ? static_cast<double>(kept) / count : 0.0;
}

double fill_gaps(cv::Mat& disparity, cv::Mat& score, int max_gap, double tolerance) {
  return fill_runs(disparity, score, [&](float* d, float* c, int a, int b) {
    if (b - a - 1 <= max_gap && std::abs(d[b] - d[a]) <= tolerance) set_run(d, c, a + 1, b, std::min(d[a], d[b]));
  });
}

double fill_occlusions(cv::Mat& disparity, cv::Mat& score, double step, int slack) {
  return fill_runs(disparity, score, [&](float* d, float* c, int a, int b) {
    if (d[b] <= d[a]) return;
    // The nearer surface at b hides (d[b] - d[a]) source pixels of the
    // farther one from the right camera, just left of its edge.
    const double hidden = (d[b] - d[a]) / step + slack;
    set_run(d, c, std::max(a + 1, b - static_cast<int>(hidden)), b, d[a]);
  });
}

double fill_holes(cv::Mat& disparity, cv::Mat& score, double fallback) {
  int known = 0;
  for (int y = 0; y < disparity.rows; ++y) {
    float* d = disparity.ptr<float>(y);
    float* c = score.ptr<float>(y);
    // Nearest matched pixel to the left and to the right along the row; the
    // farther of the two (the smaller disparity) is taken, as a hole next to a
    // depth edge is most often background the nearer surface hides. (A median
    // of the matched pixels around the hole was tried: worse on Aloe.)
    int last = -1;
    for (int x = 0; x < disparity.cols; ++x) {
      if (c[x] > 0) {
        last = x;
        continue;
      }
      int next = x + 1;
      while (next < disparity.cols && !(c[next] > 0)) ++next;
      float value = -1.0f;
      if (last >= 0 && next < disparity.cols)
        value = std::min(d[last], d[next]);
      else if (last >= 0)
        value = d[last];
      else if (next < disparity.cols)
        value = d[next];
      else if (fallback >= 0)
        value = static_cast<float>(fallback);
      for (int i = x; i < next; ++i) {
        d[i] = value;
        c[i] = value >= 0 ? 0.0f : -1.0f;
      }
      x = next - 1;
    }
    for (int x = 0; x < disparity.cols; ++x) known += d[x] >= 0;
  }
  return static_cast<double>(known) / static_cast<double>(disparity.total());
}

namespace {

// Focal length and baseline from whichever of Q, P2 or M1 with T the open file holds.
Result<StereoCalibration> calibration_from(const cv::FileStorage& fs, const std::string& path) {
  auto matrix = [&](const char* name) {
    cv::Mat m;
    if (!fs[name].empty()) fs[name] >> m;
    if (!m.empty()) m.convertTo(m, CV_64F);
    return m;
  };
  StereoCalibration out;
  // The images it was made for, when the file says (saccade calibrate's does).
  if (!fs["image_width"].empty() && !fs["image_height"].empty())
    out.image_size = {static_cast<int>(fs["image_width"]), static_cast<int>(fs["image_height"])};
  out.path = path;
  const std::string file = "calibration file '" + path + "': ";
  if (cv::Mat q = matrix("Q"); q.rows == 4 && q.cols == 4 && q.at<double>(3, 2) != 0) {
    // Q maps (x, y, d, 1) to (X, Y, Z, W): Z/W = Q(2,3) / (Q(3,2) d + Q(3,3)).
    out.focal_px = q.at<double>(2, 3);
    out.baseline_m = std::abs(1.0 / q.at<double>(3, 2));
    if (!out.valid()) return Status::error(file + "Q gives no positive focal length");
    return out;
  }
  if (cv::Mat p2 = matrix("P2"); p2.rows == 3 && p2.cols == 4 && p2.at<double>(0, 0) > 0) {
    out.focal_px = p2.at<double>(0, 0);
    out.baseline_m = std::abs(p2.at<double>(0, 3) / p2.at<double>(0, 0));
    if (!out.valid()) return Status::error(file + "P2 gives no baseline");
    return out;
  }
  cv::Mat m1 = matrix("M1"), t = matrix("T");
  if (m1.rows == 3 && m1.cols == 3 && t.total() == 3) {
    out.focal_px = m1.at<double>(0, 0);
    out.baseline_m = cv::norm(t);
    if (!out.valid()) return Status::error(file + "M1 and T give no focal length or baseline");
    return out;
  }
  return Status::error(file + "expected Q (4x4), P2 (3x4), or M1 (3x3) with T (3x1)");
}

}  // namespace

Result<StereoCalibration> read_calibration(const std::string& path) {
  // OpenCV throws on a file it cannot parse and on a key that is not a matrix.
  try {
    cv::FileStorage fs;
    if (!fs.open(path, cv::FileStorage::READ)) return Status::error("cannot open calibration file '" + path + "'");
    return calibration_from(fs, path);
  } catch (const cv::Exception& e) { return Status::error("calibration file '" + path + "': " + e.what()); }
}

}  // namespace saccade::stereo
