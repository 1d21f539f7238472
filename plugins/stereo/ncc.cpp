#include "ncc.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "saccade/fill.hpp"
#include "saccade/simd.hpp"
#include "saccade/subpixel.hpp"
#include "sgm.hpp"

namespace saccade::stereo {

namespace {

float pixel(const cv::Mat& m, int y, int x) {
  return m.depth() == CV_8U ? static_cast<float>(m.at<uint8_t>(y, x)) : m.at<float>(y, x);
}

// Window mean and (population) standard deviation of every pixel whose window
// fits inside the image; 0 elsewhere.
void window_stats(const cv::Mat& image, int r, cv::Mat& mean, cv::Mat& stddev) {
  mean.create(image.size(), CV_32F);
  stddev.create(image.size(), CV_32F);
  fill(mean, 0);
  fill(stddev, 0);
  const int n = (2 * r + 1) * (2 * r + 1);
  for (int y = r; y < image.rows - r; ++y)
    for (int x = r; x < image.cols - r; ++x) {
      double s = 0, s2 = 0;
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          double v = pixel(image, y + dy, x + dx);
          s += v;
          s2 += v * v;
        }
      double m = s / n;
      mean.at<float>(y, x) = static_cast<float>(m);
      stddev.at<float>(y, x) = static_cast<float>(std::sqrt(std::max(0.0, s2 / n - m * m)));
    }
}

}  // namespace

double ncc_reference(const cv::Mat& a, int x0, int y0, const cv::Mat& b, int x1, int y1, int window) {
  const int r = window / 2;
  double ma = 0, mb = 0;
  const int n = window * window;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      ma += pixel(a, y0 + dy, x0 + dx);
      mb += pixel(b, y1 + dy, x1 + dx);
    }
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      double va = pixel(a, y0 + dy, x0 + dx) - ma, vb = pixel(b, y1 + dy, x1 + dx) - mb;
      sab += va * vb;
      saa += va * va;
      sbb += vb * vb;
    }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0.0;
}

void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo, const cv::Mat& hi,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score) {
  NccScratch scratch;
  ncc_match(left, right, direction, lo, hi, config, disparity, score, scratch);
}

void ncc_match_reference(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo,
                         const cv::Mat& hi, const NccConfig& config, cv::Mat& disparity, cv::Mat& score,
                         NccScratch& scratch) {
  CV_Assert(left.size() == right.size() && left.channels() == 1 && right.channels() == 1 && config.window % 2 == 1);
  CV_Assert(lo.size() == left.size() && hi.size() == left.size() && lo.type() == CV_32S && hi.type() == CV_32S);
  const cv::Mat& ref = direction == Direction::kLeftToRight ? left : right;
  const cv::Mat& other = direction == Direction::kLeftToRight ? right : left;
  const int sign = direction == Direction::kLeftToRight ? -1 : 1;  // other x = x + sign * d
  const int r = config.window / 2, n = config.window * config.window;
  cv::Mat& ref_mean = scratch.ref_mean;
  cv::Mat& ref_std = scratch.ref_std;
  cv::Mat& other_mean = scratch.other_mean;
  cv::Mat& other_std = scratch.other_std;
  window_stats(ref, r, ref_mean, ref_std);
  window_stats(other, r, other_mean, other_std);
  disparity.create(ref.size(), CV_32F);
  score.create(ref.size(), CV_32F);
  fill(disparity, -1);
  fill(score, -1);
  std::vector<float>& scores = scratch.scores;
  for (int y = r; y < ref.rows - r; ++y)
    for (int x = r; x < ref.cols - r; ++x) {
      const float sa = ref_std.at<float>(y, x);
      if (sa < config.min_texture) continue;
      const int d_lo = lo.at<int>(y, x), d_hi = hi.at<int>(y, x);
      if (d_hi < d_lo) continue;
      scores.assign(static_cast<std::size_t>(d_hi - d_lo + 1), -2.0f);
      const float ma = ref_mean.at<float>(y, x);
      int best = d_lo;
      float best_score = -2.0f;
      for (int d = d_lo; d <= d_hi; ++d) {
        const int xo = x + sign * d;
        if (xo < r || xo >= other.cols - r) continue;
        const float sb = other_std.at<float>(y, xo);
        if (sb < config.min_texture) continue;
        const float mb = other_mean.at<float>(y, xo);
        double sab = 0;
        for (int dy = -r; dy <= r; ++dy)
          for (int dx = -r; dx <= r; ++dx)
            sab += (pixel(ref, y + dy, x + dx) - ma) * (pixel(other, y + dy, xo + dx) - mb);
        const float c = static_cast<float>(sab / (n * static_cast<double>(sa) * sb));
        scores[static_cast<std::size_t>(d - d_lo)] = c;
        if (c > best_score) {
          best_score = c;
          best = d;
        }
      }
      // Disparities may be negative (relative to a vergence): a score, not the
      // disparity, says whether anything matched.
      if (!(best_score > -2.0f) || best_score < config.min_score) continue;
      float d = static_cast<float>(best);
      if (config.subpixel && best > d_lo && best < d_hi) {
        const float c0 = scores[static_cast<std::size_t>(best - 1 - d_lo)];
        const float c1 = scores[static_cast<std::size_t>(best - d_lo)];
        const float c2 = scores[static_cast<std::size_t>(best + 1 - d_lo)];
        if (c0 > -2 && c2 > -2) d += peak_vertex(c0, c1, c2);
      }
      disparity.at<float>(y, x) = d;
      score.at<float>(y, x) = best_score;
    }
}

namespace {

// The rows of box_stats: column sums of values and squares slid down the
// image, then per pixel its window's sums along the row (term by term in
// registers: no rounding error accumulates along the row), mean and
// deviation. One call per image: the rows are short, and calls per row cost
// as much as their arithmetic. R > 0: the window's half width known at
// compile time.
template <int R>
__attribute__((always_inline)) inline void box_stats_rows_impl(const float* __restrict src, std::ptrdiff_t step, int w,
                                                               int h, int r_arg, float* __restrict mean,
                                                               float* __restrict stddev, float* __restrict col,
                                                               float* __restrict col2) {
  const int r = R > 0 ? R : r_arg;
  const float inv_count = 1.0f / static_cast<float>((2 * r + 1) * (2 * r + 1));
  const int inner = w - 2 * r;
  // Two rows of column sums (col, col2: 2 w each): a row's windows read the
  // sums stored an iteration before, while this one stores the next row's
  // (read right after their stores, the windows' unaligned loads each span
  // two stores, which cannot forward to a load).
  float* sums[2] = {col, col + w};
  float* squares[2] = {col2, col2 + w};
  for (int x = 0; x < w; ++x) sums[1][x] = squares[1][x] = 0.0f;
  const auto windows = [&](const float* __restrict c, const float* __restrict c2, int y) {
    float* m = mean + y * step + r;
    float* sd = stddev + y * step + r;
    for (int x = 0; x < inner; ++x) {
      float sum = c[x], sum2 = c2[x];
      for (int k = 1; k <= 2 * r; ++k) {
        sum += c[x + k];
        sum2 += c2[x + k];
      }
      const float mu = sum * inv_count;
      m[x] = mu;
      sd[x] = std::sqrt(std::max(0.0f, sum2 * inv_count - mu * mu));
    }
  };
  for (int y = 0; y < h; ++y) {
    const float* add = src + y * step;
    float* __restrict c = sums[y & 1];
    float* __restrict c2 = squares[y & 1];
    const float* __restrict before = sums[(y + 1) & 1];
    const float* __restrict before2 = squares[(y + 1) & 1];
    if (y >= 2 * r + 1) {
      const float* sub = add - (2 * r + 1) * step;
      for (int x = 0; x < w; ++x) {
        c[x] = (before[x] + add[x]) - sub[x];
        c2[x] = (before2[x] + add[x] * add[x]) - sub[x] * sub[x];
      }
    } else {
      for (int x = 0; x < w; ++x) {
        c[x] = before[x] + add[x];
        c2[x] = before2[x] + add[x] * add[x];
      }
    }
    // The row before's windows (centred on row y - 1 - r), its sums now an
    // iteration old.
    if (y - 1 >= 2 * r && inner > 0) windows(before, before2, y - 1 - r);
  }
  if (h - 1 >= 2 * r && inner > 0) windows(sums[(h - 1) & 1], squares[(h - 1) & 1], h - 1 - r);
}

SACCADE_AVX2_CLONE void box_stats_rows(const float* __restrict src, std::ptrdiff_t step, int w, int h, int r,
                                       float* __restrict mean, float* __restrict stddev, float* __restrict col,
                                       float* __restrict col2) {
  if (r == 2)
    box_stats_rows_impl<2>(src, step, w, h, r, mean, stddev, col, col2);
  else if (r == 1)
    box_stats_rows_impl<1>(src, step, w, h, r, mean, stddev, col, col2);
  else
    box_stats_rows_impl<0>(src, step, w, h, r, mean, stddev, col, col2);
}

// Window mean and standard deviation of `src` (CV_32F) at every pixel whose
// window fits; 0 elsewhere.
void box_stats(const cv::Mat& src, int r, cv::Mat& mean, cv::Mat& stddev, std::vector<float>& col,
               std::vector<float>& col2) {
  CV_Assert(src.isContinuous());
  const int w = src.cols;
  mean.create(src.size(), CV_32F);
  stddev.create(src.size(), CV_32F);
  // Zero where the window does not fit: the rows above and below and the
  // columns either side (the rows between are all written).
  const int h = src.rows, edge = std::min(r, h);
  for (cv::Mat* m : {&mean, &stddev}) {
    float* p = m->ptr<float>();
    std::fill_n(p, static_cast<std::size_t>(edge) * w, 0.0f);
    std::fill_n(p + static_cast<std::size_t>(h - edge) * w, static_cast<std::size_t>(edge) * w, 0.0f);
    for (int y = edge; y < h - edge; ++y) {
      std::fill_n(p + static_cast<std::size_t>(y) * w, std::min(r, w), 0.0f);
      std::fill_n(p + static_cast<std::size_t>(y) * w + std::max(0, w - r), std::min(r, w), 0.0f);
    }
  }
  col.assign(2 * static_cast<std::size_t>(w), 0.0f);
  col2.assign(2 * static_cast<std::size_t>(w), 0.0f);
  box_stats_rows(src.ptr<float>(), w, w, src.rows, r, mean.ptr<float>(), stddev.ptr<float>(), col.data(), col2.data());
}

// Where one direction searches: the rows, columns and disparities of its
// pixels that have a range and texture.
struct Search {
  int y0 = 0, y1 = -1, x0 = 0, x1 = -1, d_min = 0, d_max = -1;
  bool active() const { return y1 >= y0; }
  bool wants(int d) const { return active() && d >= d_min && d <= d_max; }
};

// Eight pixels at a time (GCC's vectoriser leaves these reductions scalar),
// the last eight overlapping the ones before: the minima and maxima do not
// mind seeing a pixel twice.
SACCADE_AVX2_CLONE Search bounds(const cv::Mat& lo, const cv::Mat& hi, const cv::Mat& stddev, int r,
                                 float min_texture) {
  typedef float v8f __attribute__((vector_size(32)));
  typedef int v8i __attribute__((vector_size(32)));
  constexpr int kLanes = 8, kNone = 1 << 30;
  Search s;
  const int w = lo.cols, h = lo.rows;
  int y0 = h, y1 = -1, x0 = w, x1 = -1, d_min = kNone, d_max = -kNone;
  for (int y = r; y < h - r; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    const float* sd = stddev.ptr<float>(y);
    int row_x0 = w, row_x1 = -1, row_min = kNone, row_max = -kNone;
    if (w - 2 * r >= kLanes) {
      v8i first = v8i{} + w, last = v8i{} - 1, low = v8i{} + kNone, high = v8i{} - kNone;
      for (int x = r;; x += kLanes) {
        const int at = std::min(x, w - r - kLanes);
        v8i vl, vu;
        v8f vs;
        std::memcpy(&vl, l + at, sizeof vl);
        std::memcpy(&vu, u + at, sizeof vu);
        std::memcpy(&vs, sd + at, sizeof vs);
        const v8i lane = v8i{0, 1, 2, 3, 4, 5, 6, 7} + at;
        const v8i searches = (vu >= vl) & (vs >= min_texture);
        first = searches & (lane < first) ? lane : first;
        last = searches & (lane > last) ? lane : last;
        low = searches & (vl < low) ? vl : low;
        high = searches & (vu > high) ? vu : high;
        if (at == w - r - kLanes) break;
      }
      for (int i = 0; i < kLanes; ++i) {
        row_x0 = std::min(row_x0, first[i]);
        row_x1 = std::max(row_x1, last[i]);
        row_min = std::min(row_min, low[i]);
        row_max = std::max(row_max, high[i]);
      }
    } else {
      for (int x = r; x < w - r; ++x) {
        if (u[x] < l[x] || sd[x] < min_texture) continue;
        row_x0 = std::min(row_x0, x);
        row_x1 = x;
        row_min = std::min(row_min, l[x]);
        row_max = std::max(row_max, u[x]);
      }
    }
    if (row_x1 < 0) continue;
    y0 = std::min(y0, y);
    y1 = y;
    x0 = std::min(x0, row_x0);
    x1 = std::max(x1, row_x1);
    d_min = std::min(d_min, row_min);
    d_max = std::max(d_max, row_max);
  }
  s.y0 = y0;
  s.y1 = y1;
  s.x0 = x0;
  s.x1 = x1;
  s.d_min = d_min;
  s.d_max = d_max;
  return s;
}

// Everything one disparity's pass of the sweep reads and writes, as base
// pointers and row strides (elements), so one call covers every row.
struct SweepArgs {
  const float *left, *right;  // centred values
  const float *left_mean, *left_std, *right_mean, *right_std;
  std::ptrdiff_t image_step;  // of the six images above and the volumes
  const int *lo_lr, *hi_lr;   // left pixels' ranges
  const int *lo_rl, *hi_rl;   // right pixels' ranges, null: the left pixels' pairs
  std::ptrdiff_t lr_step, rl_step;
  float* col;  // column sums, two rows of col_stride
  std::ptrdiff_t col_stride;
  float *volume_lr, *volume_rl;  // this disparity's planes, rows of image_step; no volume_rl with kImplicit
  int r, y0, y1;                 // window half size; rows whose pixels are searched
  float inv_n, min_texture;
};

// Eight lanes of one row of the sweep from left column x; R > 0 the window's
// half width known at compile time, 0 read from a.r. kImplicit: the right
// pixels have no ranges of their own and take every pair a left pixel searches.
template <int R, bool kImplicit>
__attribute__((always_inline)) inline void sweep_lanes(const SweepArgs& a, const float* col, std::ptrdiff_t row,
                                                       std::ptrdiff_t lr_row, std::ptrdiff_t rl_row, int x, int d) {
  typedef float v8f __attribute__((vector_size(32)));
  typedef int v8i __attribute__((vector_size(32)));
  const int half = R > 0 ? R : a.r;
  v8f sum, term, va, vb, vma, vmb;
  std::memcpy(&sum, col + x - half, sizeof sum);
  for (int k = 1 - half; k <= half; ++k) {
    std::memcpy(&term, col + x + k, sizeof term);
    sum += term;
  }
  const std::ptrdiff_t at = row + x, at_right = row + x - d;
  std::memcpy(&va, a.left_std + at, sizeof va);
  std::memcpy(&vb, a.right_std + at_right, sizeof vb);
  std::memcpy(&vma, a.left_mean + at, sizeof vma);
  std::memcpy(&vmb, a.right_mean + at_right, sizeof vmb);
  const v8f tiny = v8f{} + 1e-6f, texture = v8f{} + a.min_texture;
  const v8f prod = va * vb;
  const v8f value = (sum * a.inv_n - vma * vmb) / (prod > tiny ? prod : tiny);
  const v8f c = ((va >= texture) & (vb >= texture)) ? value : v8f{} - 2.0f;
  const v8i dv = v8i{} + d;
  v8i lo, hi;
  std::memcpy(&lo, a.lo_lr + lr_row + x, sizeof lo);
  std::memcpy(&hi, a.hi_lr + lr_row + x, sizeof hi);
  const v8i wanted_lr = (dv >= lo) & (dv <= hi);
  v8i wanted_rl = wanted_lr;
  if (!kImplicit) {
    std::memcpy(&lo, a.lo_rl + rl_row + x - d, sizeof lo);
    std::memcpy(&hi, a.hi_rl + rl_row + x - d, sizeof hi);
    wanted_rl = (dv >= lo) & (dv <= hi);
  }
  const v8f none = v8f{} - 2.0f;
  const v8f c_lr = wanted_lr ? c : none;
  std::memcpy(a.volume_lr + at, &c_lr, sizeof c_lr);
  if (!kImplicit) {
    const v8f c_rl = wanted_rl ? c : none;
    std::memcpy(a.volume_rl + at_right, &c_rl, sizeof c_rl);
  }
}

// One pixel of the same, where a row is narrower than eight lanes.
inline void sweep_pixel(const SweepArgs& a, const float* col, std::ptrdiff_t row, std::ptrdiff_t lr_row,
                        std::ptrdiff_t rl_row, int x, int d) {
  float sum = col[x - a.r];
  for (int k = 1 - a.r; k <= a.r; ++k) sum += col[x + k];
  const std::ptrdiff_t at = row + x, at_right = row + x - d;
  const float sa = a.left_std[at], sb = a.right_std[at_right];
  const bool textured = (sa >= a.min_texture) & (sb >= a.min_texture);
  const float c =
      textured ? (sum * a.inv_n - a.left_mean[at] * a.right_mean[at_right]) / std::max(sa * sb, 1e-6f) : -2.0f;
  const bool wanted_lr = d >= a.lo_lr[lr_row + x] && d <= a.hi_lr[lr_row + x];
  const bool wanted_rl = a.lo_rl == nullptr ? wanted_lr : d >= a.lo_rl[rl_row + x - d] && d <= a.hi_rl[rl_row + x - d];
  a.volume_lr[at] = wanted_lr ? c : -2.0f;
  if (a.volume_rl != nullptr) a.volume_rl[at_right] = wanted_rl ? c : -2.0f;
}

// The sweep at disparity d over left columns xs .. xe: column sums of
// left(x) * right(x - d) slid down the rows, and per row the window sums and
// their correlation coefficients (-2 where either window is too flat), kept
// at the left pixel (volume_lr), -2 where it does not search the pair; where
// the right pixels have ranges of their own, also at the right pixel
// (volume_rl), -2 where that one does not search it. Each side then picks its
// best reading whole vectors of its own pixels (pick_lanes). GCC's
// vector extension, eight pixels at a time (its own vectoriser gives up on the
// selects); the last eight overlap the ones before where the row is not a
// multiple of eight, which is harmless: they store the same values again.
template <int R, bool kImplicit>
__attribute__((always_inline)) inline void sweep_plane_impl(const SweepArgs& args, int d, int xs, int xe) {
  // A local copy: the stores into the volume could alias the caller's
  // arguments as far as the compiler knows, and it would load every pointer
  // again after each store.
  const SweepArgs a = args;
  constexpr int kLanes = 8;
  const int r = R > 0 ? R : a.r;
  const int xa = xs - r, xb = xe + r + 1, n = xe - xs + 1;
  // Two rows of column sums: a row's window sums read the row before's,
  // stored an iteration earlier, while this iteration stores the next row's.
  // (Read right after their stores, the window sums' unaligned loads each
  // spanned two of them, which a store cannot forward to a load.)
  float* sums[2] = {a.col, a.col + a.col_stride};
  for (int x = xa; x < xb; ++x) sums[1][x] = 0.0f;
  const auto lanes = [&](const float* col, int y) {
    const std::ptrdiff_t row = y * a.image_step, lr_row = y * a.lr_step, rl_row = y * a.rl_step;
    if (n < kLanes) {
      for (int x = xs; x <= xe; ++x) sweep_pixel(a, col, row, lr_row, rl_row, x, d);
      return;
    }
    for (int x = xs;; x += kLanes) {
      const int at = std::min(x, xe + 1 - kLanes);
      sweep_lanes<R, kImplicit>(a, col, row, lr_row, rl_row, at, d);
      if (at == xe + 1 - kLanes) break;
    }
  };
  int t = 0;
  for (int yy = a.y0 - r; yy <= a.y1 + r; ++yy, ++t) {
    const float* __restrict in_a = a.left + yy * a.image_step;
    const float* __restrict in_b = a.right + yy * a.image_step - d;
    float* __restrict col = sums[t & 1];
    const float* __restrict before = sums[(t + 1) & 1];
    if (yy - 2 * r - 1 >= a.y0 - r) {
      const float* __restrict out_a = in_a - (2 * r + 1) * a.image_step;
      const float* __restrict out_b = in_b - (2 * r + 1) * a.image_step;
      for (int x = xa; x < xb; ++x) col[x] = before[x] + (in_a[x] * in_b[x] - out_a[x] * out_b[x]);
    } else {
      for (int x = xa; x < xb; ++x) col[x] = before[x] + in_a[x] * in_b[x];
    }
    // The row before's windows, now that its sums are an iteration old.
    if (yy - 1 >= a.y0 + r) lanes(before, yy - 1 - r);
  }
  lanes(sums[(t + 1) & 1], a.y1);
}

#if defined(__x86_64__)
std::atomic<bool> avx512_allowed{true};

// The first n of sixteen lanes (none for n <= 0, all for n >= 16).
inline __mmask16 first_lanes(int n) {
  return n >= 16 ? static_cast<__mmask16>(0xFFFF) : static_cast<__mmask16>((1u << std::max(n, 0)) - 1);
}

// 0, 1, ..., 15: each lane's offset from a vector's first pixel.
__attribute__((target("avx512f"), always_inline)) inline __m512i lane_offsets() {
  return _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
}

// Whether the AVX-512 code runs: the CPU has it, the environment does not
// say no, and tests have not turned it off.
bool use_avx512() { return avx512f_usable() && avx512_allowed.load(std::memory_order_relaxed); }

// sweep_plane_impl<R, true> sixteen pixels wide in AVX-512 (intrinsics: GCC's
// vector extension turns sixteen-lane selects into per-lane branches), for
// rows at least sixteen wide and at most 16 kChunks wide with the windows'
// margins: a row's column sums stay in kChunks registers and its windows take
// their sums from them by permutes, so nothing waits on a store (through
// memory, each window's unaligned loads would span two stores, which cannot
// forward to a load). The same arithmetic in the same order: the same results
// to the bit.
template <int R, int kChunks>
__attribute__((target("avx512f"))) void sweep_plane_avx512(const SweepArgs& args, int d, int xs, int xe) {
  const SweepArgs a = args;
  constexpr int kLanes = 16;
  const int r = R > 0 ? R : a.r;
  const int xa = xs - r, xb = xe + r + 1;
  const __m512 none = _mm512_set1_ps(-2.0f), tiny = _mm512_set1_ps(1e-6f), texture = _mm512_set1_ps(a.min_texture);
  const __m512 inv_n = _mm512_set1_ps(a.inv_n);
  const __m512i dv = _mm512_set1_epi32(d);
  const __m512i iota = lane_offsets();
  __mmask16 chunk_mask[kChunks];
  __m512 sums[kChunks];
  for (int j = 0; j < kChunks; ++j) {
    const int left = xb - (xa + kLanes * j);
    chunk_mask[j] = first_lanes(left);
    sums[j] = _mm512_setzero_ps();
  }
  for (int yy = a.y0 - r; yy <= a.y1 + r; ++yy) {
    const float* in_a = a.left + yy * a.image_step + xa;
    const float* in_b = a.right + yy * a.image_step - d + xa;
    const bool slide = yy - 2 * r - 1 >= a.y0 - r;
    const float* out_a = in_a - (2 * r + 1) * a.image_step;
    const float* out_b = in_b - (2 * r + 1) * a.image_step;
    for (int j = 0; j < kChunks; ++j) {
      const __mmask16 m = chunk_mask[j];
      __m512 term =
          _mm512_mul_ps(_mm512_maskz_loadu_ps(m, in_a + kLanes * j), _mm512_maskz_loadu_ps(m, in_b + kLanes * j));
      if (slide)
        term = _mm512_sub_ps(term, _mm512_mul_ps(_mm512_maskz_loadu_ps(m, out_a + kLanes * j),
                                                 _mm512_maskz_loadu_ps(m, out_b + kLanes * j)));
      sums[j] = _mm512_add_ps(sums[j], term);
    }
    if (yy < a.y0 + r) continue;
    const int y = yy - r;
    const std::ptrdiff_t row = y * a.image_step, lr_row = y * a.lr_step;
    for (int x = xs;; x += kLanes) {
      const int at_x = std::min(x, xe + 1 - kLanes);
      // Lane i's window: columns at_x + i - r .. at_x + i + r, which are
      // sums lanes o + i .. o + i + 2r, o = at_x - r - xa: in two registers,
      // or three for a last block that overlaps the one before.
      const int o = at_x - r - xa, j0 = o / kLanes, j1 = std::min(j0 + 1, kChunks - 1);
      const int j2 = std::min(j0 + 2, kChunks - 1);
      const bool third = o - kLanes * j0 + kLanes - 1 + 2 * r >= 2 * kLanes;
      const __m512i base = _mm512_add_epi32(iota, _mm512_set1_epi32(o - kLanes * j0));
      __m512 sum = _mm512_setzero_ps();
      for (int k = 0; k <= 2 * r; ++k) {
        const __m512i index = _mm512_add_epi32(base, _mm512_set1_epi32(k));
        __m512 v = _mm512_permutex2var_ps(sums[j0], index, sums[j1]);
        if (third)
          v = _mm512_mask_permutexvar_ps(v, _mm512_cmpge_epi32_mask(index, _mm512_set1_epi32(2 * kLanes)), index,
                                         sums[j2]);
        sum = k == 0 ? v : _mm512_add_ps(sum, v);
      }
      const std::ptrdiff_t at = row + at_x, at_right = row + at_x - d;
      const __m512 va = _mm512_loadu_ps(a.left_std + at), vb = _mm512_loadu_ps(a.right_std + at_right);
      const __m512 vma = _mm512_loadu_ps(a.left_mean + at), vmb = _mm512_loadu_ps(a.right_mean + at_right);
      const __m512 prod = _mm512_mul_ps(va, vb);
      const __m512 den = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(prod, tiny, _CMP_GT_OQ), tiny, prod);
      const __m512 value = _mm512_div_ps(_mm512_sub_ps(_mm512_mul_ps(sum, inv_n), _mm512_mul_ps(vma, vmb)), den);
      const __mmask16 textured =
          _mm512_cmp_ps_mask(va, texture, _CMP_GE_OQ) & _mm512_cmp_ps_mask(vb, texture, _CMP_GE_OQ);
      const __m512i lo = _mm512_loadu_si512(a.lo_lr + lr_row + at_x);
      const __m512i hi = _mm512_loadu_si512(a.hi_lr + lr_row + at_x);
      const __mmask16 wanted =
          _mm512_cmp_epi32_mask(dv, lo, _MM_CMPINT_NLT) & _mm512_cmp_epi32_mask(dv, hi, _MM_CMPINT_LE);
      _mm512_storeu_ps(a.volume_lr + at, _mm512_mask_blend_ps(textured & wanted, none, value));
      if (at_x == xe + 1 - kLanes) break;
    }
  }
}
#endif

SACCADE_AVX2_CLONE void sweep_plane(const SweepArgs& a, int d, int xs, int xe) {
#if defined(__x86_64__)
  if (a.lo_rl == nullptr && use_avx512()) {
    const int n = xe - xs + 1, chunks = (n + 2 * a.r + 15) / 16;
    if ((a.r == 1 || a.r == 2) && n >= 16 && chunks <= 4) {
      if (a.r == 2) {
        if (chunks == 2)
          sweep_plane_avx512<2, 2>(a, d, xs, xe);
        else if (chunks == 3)
          sweep_plane_avx512<2, 3>(a, d, xs, xe);
        else
          sweep_plane_avx512<2, 4>(a, d, xs, xe);
      } else {
        if (chunks == 2)
          sweep_plane_avx512<1, 2>(a, d, xs, xe);
        else if (chunks == 3)
          sweep_plane_avx512<1, 3>(a, d, xs, xe);
        else
          sweep_plane_avx512<1, 4>(a, d, xs, xe);
      }
      return;
    }
  }
#endif
  const bool implicit = a.lo_rl == nullptr;
  if (a.r == 2) {
    if (implicit)
      sweep_plane_impl<2, true>(a, d, xs, xe);
    else
      sweep_plane_impl<2, false>(a, d, xs, xe);
  } else if (a.r == 1) {
    if (implicit)
      sweep_plane_impl<1, true>(a, d, xs, xe);
    else
      sweep_plane_impl<1, false>(a, d, xs, xe);
  } else {
    if (implicit)
      sweep_plane_impl<0, true>(a, d, xs, xe);
    else
      sweep_plane_impl<0, false>(a, d, xs, xe);
  }
}

// What one side's pick reads: one of the sweep's volumes, whose planes hold
// the correlation of each pair that side's pixel searches at that disparity,
// or -2 (not searched, a flat window, or a pair the sweep did not compute:
// outside the plane's span, read as -2 whatever the buffer holds there).
// Right pixels that take the left pixels' pairs read the left pixels'
// volume along its diagonal: right x at d is left x + d, so eight right
// pixels are eight consecutive left ones there too.
struct PickArgs {
  const float* volume;  // plane of d_min, rows of step
  std::ptrdiff_t plane, step;
  int d_min, count;
  const int *span_lo, *span_hi;  // per plane, the left columns computed
  int right_side;                // 1: right pixels (left x = right x + d)
  int diagonal;                  // 1: right pixels reading the left pixels' volume
  float min_score;
  bool subpixel;
  float *disparity, *score;  // rows of step
};

// Picks of kBlocks vectors of eight pixels at row y, from columns xs[0..]:
// every disparity in turn, the best score (the first of equal ones, the
// smallest disparity) and the scores either side of it held in registers,
// then the parabola through those three where both neighbours were searched
// and computed (> -2) and it opens downwards. Unmatched pixels get -1. The
// same arithmetic as the scalar pick_pixel, lane by lane. Several vectors at
// once: each one's best is a chain of dependent steps through the
// disparities, and independent chains overlap.
template <int kBlocks>
__attribute__((always_inline)) inline void pick_lanes(const PickArgs& a, int y, const int* xs, int begin, int end) {
  typedef float v8f __attribute__((vector_size(32)));
  typedef int v8i __attribute__((vector_size(32)));
  const v8f none = v8f{} - 2.0f;
  v8i lane[kBlocks];
  v8f best[kBlocks], before[kBlocks], after[kBlocks], previous[kBlocks];
  v8i best_d[kBlocks];
  const float* at[kBlocks];
  for (int b = 0; b < kBlocks; ++b) {
    lane[b] = v8i{0, 1, 2, 3, 4, 5, 6, 7} + xs[b];
    best[b] = before[b] = after[b] = previous[b] = none;
    best_d[b] = v8i{} + (a.d_min - 2);
    at[b] = a.volume + y * a.step + xs[b];
  }
  // The score after the best is the one read just after a take; a take at
  // the last disparity has none.
  v8i took[kBlocks];
  for (int b = 0; b < kBlocks; ++b) took[b] = v8i{};
  for (int i = begin; i <= end; ++i) {
    const int d = a.d_min + i, shift = a.right_side * d;
    const int first = a.span_lo[i] - shift, last = a.span_hi[i] - shift;
    // Most planes span all the vectors: no lane to mask then.
    const bool whole = xs[0] >= first && xs[kBlocks - 1] + 7 <= last;
    const v8i dv = v8i{} + d;
    for (int b = 0; b < kBlocks; ++b) {
      v8f c;
      std::memcpy(&c, at[b] + i * a.plane + a.diagonal * d, sizeof c);
      if (!whole) c = (lane[b] > first - 1) & (last + 1 > lane[b]) ? c : none;
      after[b] = took[b] ? c : after[b];
      const v8i take = c > best[b];
      before[b] = take ? previous[b] : before[b];
      best[b] = take ? c : best[b];
      best_d[b] = take ? dv : best_d[b];
      previous[b] = c;
      took[b] = take;
    }
  }
  for (int b = 0; b < kBlocks; ++b) after[b] = took[b] ? none : after[b];
  for (int b = 0; b < kBlocks; ++b) {
    v8f d_out = __builtin_convertvector(best_d[b], v8f);
    if (a.subpixel) {
      const v8f denom = before[b] - 2.0f * best[b] + after[b];
      const v8i fits = (before[b] > none) & (after[b] > none) & (denom < 0.0f);
      v8f step = 0.5f * (before[b] - after[b]) / denom;
      step = step < -0.5f ? v8f{} - 0.5f : (0.5f < step ? v8f{} + 0.5f : step);
      d_out = fits ? d_out + step : d_out;
    }
    const v8i matched = (best[b] >= a.min_score) & (best[b] > none);
    const v8f minus_one = v8f{} - 1.0f;
    const v8f out_d = matched ? d_out : minus_one, out_s = matched ? best[b] : minus_one;
    std::memcpy(a.disparity + y * a.step + xs[b], &out_d, sizeof out_d);
    std::memcpy(a.score + y * a.step + xs[b], &out_s, sizeof out_s);
  }
}

// One pixel of the same, for images narrower than eight.
inline void pick_pixel(const PickArgs& a, int y, int x) {
  float best = -2.0f, before = -2.0f, after = -2.0f, previous = -2.0f;
  int best_d = a.d_min - 2;
  const float* at = a.volume + y * a.step + x;
  for (int i = 0; i < a.count; ++i) {
    const int d = a.d_min + i, shift = a.right_side * d;
    const bool computed = x >= a.span_lo[i] - shift && x <= a.span_hi[i] - shift;
    const float c = computed ? at[i * a.plane + a.diagonal * d] : -2.0f;
    if (best_d == d - 1) after = c;
    if (c > best) {
      before = previous;
      after = -2.0f;
      best = c;
      best_d = d;
    }
    previous = c;
  }
  if (!(best >= a.min_score) || !(best > -2.0f)) return;
  float d_out = static_cast<float>(best_d);
  if (a.subpixel && before > -2.0f && after > -2.0f) d_out += peak_vertex(before, best, after);
  a.disparity[y * a.step + x] = d_out;
  a.score[y * a.step + x] = best;
}

#if defined(__x86_64__)
// pick_lanes sixteen pixels wide in AVX-512 (masks in mask registers; GCC's
// vector extension turns sixteen-lane selects into per-lane branches), the
// same arithmetic in the same order: the same results to the bit.
template <int kRows>
__attribute__((target("avx512f"))) void pick_avx512(const PickArgs& a, int y, int x, int begin, int end) {
  const __m512 none = _mm512_set1_ps(-2.0f);
  const __m512i lane = _mm512_add_epi32(_mm512_set1_epi32(x), lane_offsets());
  __m512 best[kRows], before[kRows], after[kRows], previous[kRows];
  __m512i best_d[kRows];
  __mmask16 took[kRows];
  const float* at[kRows];
  for (int k = 0; k < kRows; ++k) {
    best[k] = before[k] = after[k] = previous[k] = none;
    best_d[k] = _mm512_set1_epi32(a.d_min - 2);
    took[k] = 0;
    at[k] = a.volume + (y + k) * a.step + x;
  }
  for (int i = begin; i <= end; ++i) {
    const int d = a.d_min + i, shift = a.right_side * d;
    const int first = a.span_lo[i] - shift, last = a.span_hi[i] - shift;
    const bool partial = x < first || x + 15 > last;
    const __mmask16 computed = _mm512_cmpgt_epi32_mask(lane, _mm512_set1_epi32(first - 1)) &
                               _mm512_cmplt_epi32_mask(lane, _mm512_set1_epi32(last + 1));
    for (int k = 0; k < kRows; ++k) {
      __m512 c = _mm512_loadu_ps(at[k] + i * a.plane + a.diagonal * d);
      if (partial) c = _mm512_mask_blend_ps(computed, none, c);
      after[k] = _mm512_mask_blend_ps(took[k], after[k], c);
      const __mmask16 take = _mm512_cmp_ps_mask(c, best[k], _CMP_GT_OQ);
      before[k] = _mm512_mask_blend_ps(take, before[k], previous[k]);
      // max(c, best) is c where c > best and best otherwise (equal ones too):
      // the take without waiting for the comparison.
      best[k] = _mm512_max_ps(c, best[k]);
      best_d[k] = _mm512_mask_blend_epi32(take, best_d[k], _mm512_set1_epi32(d));
      previous[k] = c;
      took[k] = take;
    }
  }
  for (int k = 0; k < kRows; ++k) {
    after[k] = _mm512_mask_blend_ps(took[k], after[k], none);
    // (maskz: GCC 12 warns of the undefined source plain _mm512_cvtepi32_ps uses.)
    __m512 d_out = _mm512_maskz_cvtepi32_ps(0xFFFF, best_d[k]);
    if (a.subpixel) {
      const __m512 denom =
          _mm512_add_ps(_mm512_sub_ps(before[k], _mm512_mul_ps(_mm512_set1_ps(2.0f), best[k])), after[k]);
      const __mmask16 fits = _mm512_cmp_ps_mask(before[k], none, _CMP_GT_OQ) &
                             _mm512_cmp_ps_mask(after[k], none, _CMP_GT_OQ) &
                             _mm512_cmp_ps_mask(denom, _mm512_setzero_ps(), _CMP_LT_OQ);
      __m512 step = _mm512_div_ps(_mm512_mul_ps(_mm512_set1_ps(0.5f), _mm512_sub_ps(before[k], after[k])), denom);
      const __m512 low = _mm512_set1_ps(-0.5f), high = _mm512_set1_ps(0.5f);
      const __mmask16 below = _mm512_cmp_ps_mask(step, low, _CMP_LT_OQ);
      step = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(high, step, _CMP_LT_OQ), step, high);
      step = _mm512_mask_blend_ps(below, step, low);
      d_out = _mm512_mask_blend_ps(fits, d_out, _mm512_add_ps(d_out, step));
    }
    const __mmask16 matched = _mm512_cmp_ps_mask(best[k], _mm512_set1_ps(a.min_score), _CMP_GE_OQ) &
                              _mm512_cmp_ps_mask(best[k], none, _CMP_GT_OQ);
    const __m512 minus_one = _mm512_set1_ps(-1.0f);
    _mm512_storeu_ps(a.disparity + (y + k) * a.step + x, _mm512_mask_blend_ps(matched, minus_one, d_out));
    _mm512_storeu_ps(a.score + (y + k) * a.step + x, _mm512_mask_blend_ps(matched, minus_one, best[k]));
  }
}

#endif

// The planes whose span reaches columns first .. last of this side, as
// begin .. end (end < begin: none). Before and after them every score the
// pick would read there is -2, which changes nothing: right pixels far to one
// side of the left pixels' columns reach few disparities.
void planes_reaching(const PickArgs& a, int first, int last, int& begin, int& end) {
  begin = a.count;
  end = -1;
  for (int i = 0; i < a.count; ++i) {
    const int shift = a.right_side * (a.d_min + i);
    if (a.span_hi[i] - shift >= first && a.span_lo[i] - shift <= last) {
      begin = std::min(begin, i);
      end = i;
    }
  }
}

// One side's picks over its box (rows y0 .. y1, columns x0 .. x1): whole
// vectors, the last overlapping the one before, each group of vectors down
// every row over the planes that reach it; outside the box's columns a
// vector's extra pixels are outside every plane's span, so they write the -1
// the outputs start with.
SACCADE_AVX2_CLONE void pick(const PickArgs& a, int y0, int y1, int x0, int x1, int width) {
  constexpr int kLanes = 8;
  if (width < kLanes) {
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) pick_pixel(a, y, x);
    return;
  }
#if defined(__x86_64__)
  // Sixteen lanes where the CPU has them.
  constexpr int kWide = 16;
  if (width >= kWide && use_avx512()) {
    for (int x = std::min(x0, width - kWide);; x += kWide) {
      const int at = std::min(x, std::max(x1 + 1, kWide) - kWide);
      int begin, end;
      planes_reaching(a, at, at + kWide - 1, begin, end);
      // Four rows at a time: each one's best is a chain of steps through the
      // disparities, and independent chains overlap.
      int y = y0;
      for (; y + 3 <= y1; y += 4) pick_avx512<4>(a, y, at, begin, end);
      for (; y + 1 <= y1; y += 2) pick_avx512<2>(a, y, at, begin, end);
      if (y <= y1) pick_avx512<1>(a, y, at, begin, end);
      if (at + kWide > x1) break;
    }
    return;
  }
#endif
  // Two vectors of eight at a time.
  int xs[2], blocks = 0;
  for (int x = std::min(x0, width - kLanes);; x += kLanes) {
    const int at = std::min(x, std::max(x1 + 1, kLanes) - kLanes);
    const bool last = at + kLanes > x1;
    xs[blocks++] = at;
    if (blocks == 2 || last) {
      int begin, end;
      planes_reaching(a, xs[0], xs[blocks - 1] + kLanes - 1, begin, end);
      for (int y = y0; y <= y1; ++y) {
        if (blocks == 2)
          pick_lanes<2>(a, y, xs, begin, end);
        else
          pick_lanes<1>(a, y, xs, begin, end);
      }
      blocks = 0;
    }
    if (last) break;
  }
}

// Outputs where nothing matched.
void unmatched(cv::Size size, cv::Mat& disparity_lr, cv::Mat& score_lr, cv::Mat& disparity_rl, cv::Mat& score_rl) {
  for (cv::Mat* m : {&disparity_lr, &score_lr, &disparity_rl, &score_rl}) {
    m->create(size, CV_32F);
    fill(*m, -1);
  }
}

// Where the right pixels search: within their own ranges, or without any
// (lo_rl null) wherever a left pixel's search reaches.
Search right_search(const Search& lr, const cv::Mat* lo_rl, const cv::Mat* hi_rl, const cv::Mat& stddev, int r,
                    float min_texture, int w) {
  if (lo_rl != nullptr) return bounds(*lo_rl, *hi_rl, stddev, r, min_texture);
  Search rl;
  if (lr.active()) {
    rl = lr;
    rl.x0 = std::max(r, lr.x0 - lr.d_max);
    rl.x1 = std::min(w - 1 - r, lr.x1 - lr.d_min);
  }
  return rl;
}

// The rows and disparities one sweep covers: all that either side searches
// (no disparities where neither searches anything).
struct SweepExtent {
  int y0, y1, d_min, count;
};

SweepExtent sweep_extent(const Search& lr, const Search& rl, int h) {
  const int y0 = std::min(lr.active() ? lr.y0 : h, rl.active() ? rl.y0 : h);
  const int y1 = std::max(lr.y1, rl.y1);
  const int d_min = std::min(lr.active() ? lr.d_min : (1 << 30), rl.active() ? rl.d_min : (1 << 30));
  const int d_max = std::max(lr.active() ? lr.d_max : -(1 << 30), rl.active() ? rl.d_max : -(1 << 30));
  return {.y0 = y0, .y1 = y1, .d_min = d_min, .count = y1 >= y0 ? d_max - d_min + 1 : 0};
}

// The sweep's buffers, grown to `count` planes and no plane computed yet;
// returns the left pixels' volume. That volume has a row's worth and a vector
// either side: the right pixels read it along its diagonal, up to a row
// beyond its planes (lanes outside the planes' spans, whose values are not
// used).
float* sweep_buffers(NccScratch& scratch, int w, std::size_t plane, int count, bool implicit) {
  const std::size_t guard = static_cast<std::size_t>(w) + 8;
  if (scratch.volume.size() < plane * static_cast<std::size_t>(count) + 2 * guard)
    scratch.volume.resize(plane * static_cast<std::size_t>(count) + 2 * guard);
  if (!implicit && scratch.volume_rl.size() < plane * static_cast<std::size_t>(count))
    scratch.volume_rl.resize(plane * static_cast<std::size_t>(count));
  scratch.col.assign(2 * static_cast<std::size_t>(w), 0.0f);
  scratch.span_lo.assign(static_cast<std::size_t>(count), 0);
  scratch.span_hi.assign(static_cast<std::size_t>(count), -1);
  return scratch.volume.data() + guard;
}

// What every plane of the sweep reads; each plane then sets where it writes.
// The images are match's own (continuous, rows of w); the ranges the caller's.
SweepArgs sweep_args(NccScratch& scratch, const cv::Mat& lo_lr, const cv::Mat& hi_lr, const cv::Mat* lo_rl,
                     const cv::Mat* hi_rl, int r, const SweepExtent& extent, const NccConfig& config) {
  const bool implicit = lo_rl == nullptr;
  CV_Assert(hi_lr.step1() == lo_lr.step1() && (implicit || hi_rl->step1() == lo_rl->step1()));
  for (const cv::Mat* m :
       {&scratch.ref_f, &scratch.other_f, &scratch.ref_mean, &scratch.ref_std, &scratch.other_mean, &scratch.other_std})
    CV_Assert(m->isContinuous());
  const int w = scratch.ref_f.cols;
  return {
      .left = scratch.ref_f.ptr<float>(),
      .right = scratch.other_f.ptr<float>(),
      .left_mean = scratch.ref_mean.ptr<float>(),
      .left_std = scratch.ref_std.ptr<float>(),
      .right_mean = scratch.other_mean.ptr<float>(),
      .right_std = scratch.other_std.ptr<float>(),
      .image_step = w,
      .lo_lr = lo_lr.ptr<int>(),
      .hi_lr = hi_lr.ptr<int>(),
      .lo_rl = implicit ? nullptr : lo_rl->ptr<int>(),
      .hi_rl = implicit ? nullptr : hi_rl->ptr<int>(),
      .lr_step = static_cast<std::ptrdiff_t>(lo_lr.step1()),
      .rl_step = implicit ? 0 : static_cast<std::ptrdiff_t>(lo_rl->step1()),
      .col = scratch.col.data(),
      .col_stride = w,
      .volume_lr = nullptr,
      .volume_rl = nullptr,
      .r = r,
      .y0 = extent.y0,
      .y1 = extent.y1,
      .inv_n = 1.0f / static_cast<float>(config.window * config.window),
      .min_texture = config.min_texture,
  };
}

// Left pixels x paired with right pixels x - d at disparity d: those either
// side wants, with both windows inside the images (none where xe < xs).
void sweep_columns(const Search& lr, const Search& rl, bool implicit, int d, int r, int w, int& xs, int& xe) {
  xs = w;
  xe = -1;
  if (lr.wants(d)) {
    xs = std::min(xs, lr.x0);
    xe = std::max(xe, lr.x1);
  }
  if (!implicit && rl.wants(d)) {
    xs = std::min(xs, rl.x0 + d);
    xe = std::max(xe, rl.x1 + d);
  }
  xs = std::max({xs, r, r + d});
  xe = std::min({xe, w - r - 1, w - r - 1 + d});
}

// Both directions in one sweep. lo_rl and hi_rl null: the right pixels take
// exactly the pairs the left pixels search.
void match(const cv::Mat& left, const cv::Mat& right, const cv::Mat& lo_lr, const cv::Mat& hi_lr, const cv::Mat* lo_rl,
           const cv::Mat* hi_rl, const NccConfig& config, cv::Mat& disparity_lr, cv::Mat& score_lr,
           cv::Mat& disparity_rl, cv::Mat& score_rl, NccScratch& scratch) {
  CV_Assert(left.size() == right.size() && left.channels() == 1 && right.channels() == 1 && config.window % 2 == 1);
  CV_Assert((lo_rl == nullptr) == (hi_rl == nullptr));
  for (const cv::Mat* m : {&lo_lr, &hi_lr, lo_rl, hi_rl})
    if (m != nullptr) CV_Assert(m->size() == left.size() && m->type() == CV_32S);
  const int r = config.window / 2;
  const int w = left.cols, h = left.rows;
  scratch.undecided.create(left.size(), CV_8U);
  fill(scratch.undecided, 0);
  if (w < 2 * r + 1 || h < 2 * r + 1) {
    unmatched(left.size(), disparity_lr, score_lr, disparity_rl, score_rl);
    return;
  }
  // Centred values keep the float sums of products exact enough.
  left.convertTo(scratch.ref_f, CV_32F, 1.0, -128.0);
  right.convertTo(scratch.other_f, CV_32F, 1.0, -128.0);
  box_stats(scratch.ref_f, r, scratch.ref_mean, scratch.ref_std, scratch.col, scratch.col2);
  box_stats(scratch.other_f, r, scratch.other_mean, scratch.other_std, scratch.col, scratch.col2);
  const Search lr = bounds(lo_lr, hi_lr, scratch.ref_std, r, config.min_texture);
  const bool implicit = lo_rl == nullptr;
  const Search rl = right_search(lr, lo_rl, hi_rl, scratch.other_std, r, config.min_texture, w);
  // One sweep over the disparities either direction wants fills the volume
  // of correlations; each direction then picks its best from it. The left
  // pixel x at d and the right pixel x - d at d share one correlation.
  const SweepExtent extent = sweep_extent(lr, rl, h);
  const std::size_t plane = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  float* const volume_lr = sweep_buffers(scratch, w, plane, extent.count, implicit);
  SweepArgs args = sweep_args(scratch, lo_lr, hi_lr, lo_rl, hi_rl, r, extent, config);
  for (int d = extent.d_min; d < extent.d_min + extent.count; ++d) {
    int xs, xe;
    sweep_columns(lr, rl, implicit, d, r, w, xs, xe);
    if (xe < xs) continue;
    const std::size_t i = static_cast<std::size_t>(d - extent.d_min);
    scratch.span_lo[i] = xs;
    scratch.span_hi[i] = xe;
    args.volume_lr = volume_lr + i * plane;
    args.volume_rl = implicit ? nullptr : scratch.volume_rl.data() + i * plane;
    sweep_plane(args, d, xs, xe);
  }
  if (implicit && config.semi_global && lr.active()) {
    const SweepVolume volume{.data = volume_lr,
                             .plane = plane,
                             .width = w,
                             .d_min = extent.d_min,
                             .d_max = extent.d_min + extent.count - 1,
                             .span_lo = scratch.span_lo.data(),
                             .span_hi = scratch.span_hi.data()};
    semi_global_match(volume, lo_lr, hi_lr, r, config, scratch, disparity_lr, score_lr, disparity_rl, score_rl);
    return;
  }
  unmatched(left.size(), disparity_lr, score_lr, disparity_rl, score_rl);
  // Each side picks from the volume indexed by its own pixels; every output
  // here was created above: continuous, rows of w.
  const PickArgs left_pick{.volume = volume_lr,
                           .plane = static_cast<std::ptrdiff_t>(plane),
                           .step = w,
                           .d_min = extent.d_min,
                           .count = extent.count,
                           .span_lo = scratch.span_lo.data(),
                           .span_hi = scratch.span_hi.data(),
                           .right_side = 0,
                           .diagonal = 0,
                           .min_score = config.min_score,
                           .subpixel = config.subpixel,
                           .disparity = disparity_lr.ptr<float>(),
                           .score = score_lr.ptr<float>()};
  if (lr.active()) pick(left_pick, lr.y0, lr.y1, lr.x0, lr.x1, w);
  PickArgs right_pick = left_pick;
  right_pick.volume = implicit ? volume_lr : scratch.volume_rl.data();
  right_pick.right_side = 1;
  right_pick.diagonal = implicit ? 1 : 0;
  right_pick.disparity = disparity_rl.ptr<float>();
  right_pick.score = score_rl.ptr<float>();
  if (rl.active()) pick(right_pick, rl.y0, rl.y1, rl.x0, rl.x1, w);
}

}  // namespace

void ncc_match_both(const cv::Mat& left, const cv::Mat& right, const cv::Mat& lo_lr, const cv::Mat& hi_lr,
                    const cv::Mat& lo_rl, const cv::Mat& hi_rl, const NccConfig& config, cv::Mat& disparity_lr,
                    cv::Mat& score_lr, cv::Mat& disparity_rl, cv::Mat& score_rl, NccScratch& scratch) {
  match(left, right, lo_lr, hi_lr, &lo_rl, &hi_rl, config, disparity_lr, score_lr, disparity_rl, score_rl, scratch);
}

void ncc_match_cross(const cv::Mat& left, const cv::Mat& right, const cv::Mat& lo, const cv::Mat& hi,
                     const NccConfig& config, cv::Mat& disparity_lr, cv::Mat& score_lr, cv::Mat& disparity_rl,
                     cv::Mat& score_rl, NccScratch& scratch) {
  match(left, right, lo, hi, nullptr, nullptr, config, disparity_lr, score_lr, disparity_rl, score_rl, scratch);
}

void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo, const cv::Mat& hi,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score, NccScratch& scratch) {
  // The other direction searches nothing.
  scratch.none_lo.create(left.size(), CV_32S);
  scratch.none_hi.create(left.size(), CV_32S);
  fill(scratch.none_lo, 1);
  fill(scratch.none_hi, 0);
  if (direction == Direction::kLeftToRight)
    ncc_match_both(left, right, lo, hi, scratch.none_lo, scratch.none_hi, config, disparity, score, scratch.unused_d,
                   scratch.unused_s, scratch);
  else
    ncc_match_both(left, right, scratch.none_lo, scratch.none_hi, lo, hi, config, scratch.unused_d, scratch.unused_s,
                   disparity, score, scratch);
}

void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, int d_min, int d_max,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score) {
  cv::Mat lo(left.size(), CV_32S, cv::Scalar(d_min)), hi(left.size(), CV_32S, cv::Scalar(d_max));
  ncc_match(left, right, direction, lo, hi, config, disparity, score);
}

bool allow_avx512(bool allowed) {
#if defined(__x86_64__)
  avx512_allowed.store(allowed, std::memory_order_relaxed);
  return avx512f_usable();
#else
  (void)allowed;
  return false;
#endif
}

namespace {

#if defined(__x86_64__)
// One row of left_right_check sixteen pixels at a time in AVX-512, the
// right pixels' results read by lane: the same decisions (lround's halves
// away from zero made exact from the truncation and the exact remainder).
__attribute__((target("avx512f"))) void left_right_check_avx512(const float* d_row, const float* s_row,
                                                                const float* back, const float* back_score, int cols,
                                                                float tolerance, uint8_t* ok, int x0, int x1,
                                                                int& matched, int& kept) {
  constexpr int kLanes = 16;
  const __m512i lanes = lane_offsets();
  const __m512 minus_one = _mm512_set1_ps(-1.0f), half = _mm512_set1_ps(0.5f), minus_half = _mm512_set1_ps(-0.5f);
  const __m512 limit = _mm512_set1_ps(tolerance);
  const __m512i one = _mm512_set1_epi32(1), width = _mm512_set1_epi32(cols);
  for (int x = x0; x < x1; x += kLanes) {
    const __mmask16 m = first_lanes(x1 - x);
    const __m512 score = _mm512_maskz_loadu_ps(m, s_row + x);
    const __m512 d = _mm512_maskz_loadu_ps(m, d_row + x);
    const __mmask16 has = m & _mm512_cmp_ps_mask(score, minus_one, _CMP_NLE_UQ);
    const __m512 v = _mm512_sub_ps(_mm512_maskz_cvtepi32_ps(0xFFFF, _mm512_add_epi32(_mm512_set1_epi32(x), lanes)), d);
    const __m512 whole = _mm512_roundscale_ps(v, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC);
    const __m512 rest = _mm512_sub_ps(v, whole);
    __m512i xr = _mm512_cvttps_epi32(whole);
    xr = _mm512_mask_add_epi32(xr, _mm512_cmp_ps_mask(rest, half, _CMP_GE_OQ), xr, one);
    xr = _mm512_mask_sub_epi32(xr, _mm512_cmp_ps_mask(rest, minus_half, _CMP_LE_OQ), xr, one);
    const __mmask16 inside = has & _mm512_cmp_epi32_mask(xr, _mm512_setzero_si512(), _MM_CMPINT_NLT) &
                             _mm512_cmp_epi32_mask(xr, width, _MM_CMPINT_LT);
    // The right pixels these point to lie close together: where within 32
    // of each other, two loads and a permute each instead of a gather (slow
    // here: 16 loads).
    __m512 other_score, other;
    const int first = _mm512_mask_reduce_min_epi32(inside, xr), last = _mm512_mask_reduce_max_epi32(inside, xr);
    if (inside != 0 && last - first < 2 * kLanes) {
      const __m512i index = _mm512_sub_epi32(xr, _mm512_set1_epi32(first));
      const int reach = cols - first;
      const __mmask16 low = first_lanes(reach), high = first_lanes(reach - kLanes);
      other_score =
          _mm512_mask_blend_ps(inside, minus_one,
                               _mm512_permutex2var_ps(_mm512_maskz_loadu_ps(low, back_score + first), index,
                                                      _mm512_maskz_loadu_ps(high, back_score + first + kLanes)));
      other = _mm512_permutex2var_ps(_mm512_maskz_loadu_ps(low, back + first), index,
                                     _mm512_maskz_loadu_ps(high, back + first + kLanes));
    } else {
      other_score = _mm512_mask_i32gather_ps(minus_one, inside, xr, back_score, 4);
      other = _mm512_mask_i32gather_ps(_mm512_setzero_ps(), inside, xr, back, 4);
    }
    const __mmask16 agrees = inside & _mm512_cmp_ps_mask(other_score, minus_one, _CMP_GT_OQ) &
                             _mm512_cmp_ps_mask(_mm512_abs_ps(_mm512_sub_ps(other, d)), limit, _CMP_LE_OQ);
    matched += __builtin_popcount(has);
    kept += __builtin_popcount(agrees);
    for (unsigned clear = m & ~agrees & 0xFFFFu; clear != 0; clear &= clear - 1) ok[x + __builtin_ctz(clear)] = 0;
  }
}
#endif

}  // namespace

double left_right_check(const cv::Mat& lr, const cv::Mat& lr_score, const cv::Mat& rl, const cv::Mat& rl_score,
                        float tolerance, cv::Mat& valid, cv::Rect region) {
  if (region.empty()) region = cv::Rect(0, 0, lr.cols, lr.rows);
  region &= cv::Rect(0, 0, lr.cols, lr.rows);
  int matched = 0, kept = 0;
  for (int y = region.y; y < region.y + region.height; ++y) {
    const float* d_row = lr.ptr<float>(y);
    const float* s_row = lr_score.ptr<float>(y);
    const float* back = rl.ptr<float>(y);
    const float* back_score = rl_score.ptr<float>(y);
    uint8_t* ok = valid.ptr<uint8_t>(y);
#if defined(__x86_64__)
    if (use_avx512()) {
      left_right_check_avx512(d_row, s_row, back, back_score, rl.cols, tolerance, ok, region.x, region.x + region.width,
                              matched, kept);
      continue;
    }
#endif
    for (int x = region.x; x < region.x + region.width; ++x) {
      if (s_row[x] <= -1.0f) {
        ok[x] = 0;
        continue;
      }
      ++matched;
      const float d = d_row[x];
      const int xr = static_cast<int>(std::lround(x - d));
      const bool agrees = xr >= 0 && xr < rl.cols && back_score[xr] > -1.0f && std::fabs(back[xr] - d) <= tolerance;
      if (agrees)
        ++kept;
      else
        ok[x] = 0;
    }
  }
  return matched > 0 ? static_cast<double>(kept) / matched : 0.0;
}

}  // namespace saccade::stereo
