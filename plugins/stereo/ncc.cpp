#include "ncc.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "saccade/fill.hpp"
#include "saccade/simd.hpp"

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
        const float denom = c0 - 2 * c1 + c2;
        if (c0 > -2 && c2 > -2 && denom < 0) d += std::clamp(0.5f * (c0 - c2) / denom, -0.5f, 0.5f);
      }
      disparity.at<float>(y, x) = d;
      score.at<float>(y, x) = best_score;
    }
}

namespace {

// Window sums along a row: out[x] = in[x - r] + ... + in[x + r] for x in
// 0 .. n - 1 (in readable from -r to n - 1 + r). Summed term by term rather
// than sliding, so it vectorises and no rounding error accumulates along the row.
SACCADE_AVX2_CLONE void window_sums(float* __restrict out, const float* __restrict in, int n, int r) {
  for (int x = 0; x < n; ++x) out[x] = in[x - r];
  for (int k = 1 - r; k <= r; ++k)
    for (int x = 0; x < n; ++x) out[x] += in[x + k];
}

// Mean and standard deviation from a row of window sums of values and squares.
SACCADE_AVX2_CLONE void moments(float* __restrict mean, float* __restrict stddev, const float* __restrict sum,
                                const float* __restrict sum2, int n, float inv_count) {
  for (int x = 0; x < n; ++x) {
    const float mu = sum[x] * inv_count;
    mean[x] = mu;
    stddev[x] = std::sqrt(std::max(0.0f, sum2[x] * inv_count - mu * mu));
  }
}

// Window mean and standard deviation of `src` (CV_32F) at every pixel whose
// window fits; 0 elsewhere.
void box_stats(const cv::Mat& src, int r, cv::Mat& mean, cv::Mat& stddev, std::vector<float>& col, std::vector<float>& col2,
               std::vector<float>& row, std::vector<float>& row2) {
  const int w = src.cols, h = src.rows, n = (2 * r + 1) * (2 * r + 1);
  mean.create(src.size(), CV_32F);
  stddev.create(src.size(), CV_32F);
  fill(mean, 0);
  fill(stddev, 0);
  col.assign(static_cast<std::size_t>(w), 0.0f);
  col2.assign(static_cast<std::size_t>(w), 0.0f);
  row.assign(static_cast<std::size_t>(w), 0.0f);
  row2.assign(static_cast<std::size_t>(w), 0.0f);
  const int inner = w - 2 * r;
  for (int y = 0; y < h; ++y) {
    const float* add = src.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      col[static_cast<std::size_t>(x)] += add[x];
      col2[static_cast<std::size_t>(x)] += add[x] * add[x];
    }
    if (y >= 2 * r + 1) {
      const float* sub = src.ptr<float>(y - 2 * r - 1);
      for (int x = 0; x < w; ++x) {
        col[static_cast<std::size_t>(x)] -= sub[x];
        col2[static_cast<std::size_t>(x)] -= sub[x] * sub[x];
      }
    }
    if (y < 2 * r || inner <= 0) continue;
    const int yc = y - r;
    window_sums(row.data() + r, col.data() + r, inner, r);
    window_sums(row2.data() + r, col2.data() + r, inner, r);
    moments(mean.ptr<float>(yc) + r, stddev.ptr<float>(yc) + r, row.data() + r, row2.data() + r, inner,
            1.0f / static_cast<float>(n));
  }
}

}  // namespace

namespace {

// Where one direction searches: the rows, columns and disparities of its
// pixels that have a range and texture.
struct Search {
  const cv::Mat* lo;
  const cv::Mat* hi;
  int y0 = 0, y1 = -1, x0 = 0, x1 = -1, d_min = 0, d_max = -1;
  bool active() const { return y1 >= y0; }
  bool wants(int d) const { return active() && d >= d_min && d <= d_max; }
};

Search bounds(const cv::Mat& lo, const cv::Mat& hi, const cv::Mat& stddev, int r, float min_texture) {
  Search s;
  s.lo = &lo;
  s.hi = &hi;
  const int w = lo.cols, h = lo.rows;
  int y0 = h, y1 = -1, x0 = w, x1 = -1, d_min = 1 << 30, d_max = -(1 << 30);
  for (int y = r; y < h - r; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    const float* sd = stddev.ptr<float>(y);
    int row_x0 = w, row_x1 = -1;
    for (int x = r; x < w - r; ++x) {
      if (u[x] < l[x] || sd[x] < min_texture) continue;
      row_x0 = std::min(row_x0, x);
      row_x1 = x;
      d_min = std::min(d_min, l[x]);
      d_max = std::max(d_max, u[x]);
    }
    if (row_x1 < 0) continue;
    y0 = std::min(y0, y);
    y1 = y;
    x0 = std::min(x0, row_x0);
    x1 = std::max(x1, row_x1);
  }
  s.y0 = y0;
  s.y1 = y1;
  s.x0 = x0;
  s.x1 = x1;
  s.d_min = d_min;
  s.d_max = d_max;
  return s;
}

// The sweep's column sums: add the products of the row entering the window,
// subtract those of the row leaving it (a0, b0 null: none leaves).
SACCADE_AVX2_CLONE void slide_products(float* __restrict col, const float* __restrict a, const float* __restrict b,
                                       const float* __restrict a0, const float* __restrict b0, int n) {
  if (a0 != nullptr) {
    for (int x = 0; x < n; ++x) col[x] += a[x] * b[x] - a0[x] * b0[x];
  } else {
    for (int x = 0; x < n; ++x) col[x] += a[x] * b[x];
  }
}

// One row of one direction's search: per pixel its range, and the best
// score and disparity so far. Pointers are indexed by the left image's column
// at the disparity being swept (the right direction's shifted by -d).
struct BestRow {
  const int* lo;
  const int* hi;
  float* best;
  int* best_d;
};

// Eight lanes of one sweep row from column x (see sweep_row); R > 0 the
// window's half width known at compile time, 0 read from r.
// kImplicit: the right pixels have no ranges of their own and take every
// pair a left pixel searches (rl.lo and rl.hi unused).
template <int R, bool kImplicit>
__attribute__((always_inline)) inline void sweep_lanes(const float* __restrict col, int r, const float* __restrict ma,
                                                       const float* __restrict sa, const float* __restrict mb,
                                                       const float* __restrict sb, float inv_n, float min_texture,
                                                       float* __restrict volume, const BestRow& lr, const BestRow& rl,
                                                       int x, int d) {
  typedef float v8f __attribute__((vector_size(32)));
  typedef int v8i __attribute__((vector_size(32)));
  const int half = R > 0 ? R : r;
  v8f sum, term, va, vb, vma, vmb;
  std::memcpy(&sum, col + x - half, sizeof sum);
  for (int k = 1 - half; k <= half; ++k) {
    std::memcpy(&term, col + x + k, sizeof term);
    sum += term;
  }
  std::memcpy(&va, sa + x, sizeof va);
  std::memcpy(&vb, sb + x, sizeof vb);
  std::memcpy(&vma, ma + x, sizeof vma);
  std::memcpy(&vmb, mb + x, sizeof vmb);
  const v8f tiny = v8f{} + 1e-6f, texture = v8f{} + min_texture;
  const v8f prod = va * vb;
  const v8f value = (sum * inv_n - vma * vmb) / (prod > tiny ? prod : tiny);
  const v8f c = ((va >= texture) & (vb >= texture)) ? value : v8f{} - 2.0f;
  std::memcpy(volume + x, &c, sizeof c);
  const v8i dv = v8i{} + d;
  v8i lo, hi;
  std::memcpy(&lo, lr.lo + x, sizeof lo);
  std::memcpy(&hi, lr.hi + x, sizeof hi);
  const v8i wanted_lr = (dv >= lo) & (dv <= hi);
  v8i wanted_rl = wanted_lr;
  if (!kImplicit) {
    std::memcpy(&lo, rl.lo + x, sizeof lo);
    std::memcpy(&hi, rl.hi + x, sizeof hi);
    wanted_rl = (dv >= lo) & (dv <= hi);
  }
  for (int side = 0; side < 2; ++side) {
    const BestRow& s = side == 0 ? lr : rl;
    v8f b;
    v8i bd;
    std::memcpy(&b, s.best + x, sizeof b);
    std::memcpy(&bd, s.best_d + x, sizeof bd);
    const v8i take = (side == 0 ? wanted_lr : wanted_rl) & (c > b);
    const v8f b_new = take ? c : b;
    const v8i bd_new = take ? dv : bd;
    std::memcpy(s.best + x, &b_new, sizeof b_new);
    std::memcpy(s.best_d + x, &bd_new, sizeof bd_new);
  }
}

// One row y of the sweep at disparity d, for left columns 0 .. n - 1 (all
// pointers at the span's first column): the window sums of the products from
// the column sums, their correlation coefficients (-2 where either window is
// too flat), kept in the volume row, and offered to both directions' pixels
// whose range holds d. The first of equal scores (the smallest disparity)
// wins. GCC's vector extension, eight pixels at a time (its own vectoriser
// gives up on the selects); the last eight overlap the ones before where n is
// not a multiple of eight, which is harmless: offering a score again at the
// same disparity changes nothing.
SACCADE_AVX2_CLONE void sweep_row(const float* __restrict col, int r, const float* __restrict ma,
                                  const float* __restrict sa, const float* __restrict mb, const float* __restrict sb,
                                  float inv_n, float min_texture, float* __restrict volume, BestRow lr, BestRow rl,
                                  int n, int d) {
  constexpr int kLanes = 8;
  if (n >= kLanes) {
    for (int x = 0;; x += kLanes) {
      const int at = std::min(x, n - kLanes);
      if (rl.lo == nullptr) {
        if (r == 2) sweep_lanes<2, true>(col, r, ma, sa, mb, sb, inv_n, min_texture, volume, lr, rl, at, d);
        else if (r == 1) sweep_lanes<1, true>(col, r, ma, sa, mb, sb, inv_n, min_texture, volume, lr, rl, at, d);
        else sweep_lanes<0, true>(col, r, ma, sa, mb, sb, inv_n, min_texture, volume, lr, rl, at, d);
      } else {
        if (r == 2) sweep_lanes<2, false>(col, r, ma, sa, mb, sb, inv_n, min_texture, volume, lr, rl, at, d);
        else if (r == 1) sweep_lanes<1, false>(col, r, ma, sa, mb, sb, inv_n, min_texture, volume, lr, rl, at, d);
        else sweep_lanes<0, false>(col, r, ma, sa, mb, sb, inv_n, min_texture, volume, lr, rl, at, d);
      }
      if (at == n - kLanes) break;
    }
    return;
  }
  for (int x = 0; x < n; ++x) {
    float sum = col[x - r];
    for (int k = 1 - r; k <= r; ++k) sum += col[x + k];
    const bool textured = (sa[x] >= min_texture) & (sb[x] >= min_texture);
    const float c = textured ? (sum * inv_n - ma[x] * mb[x]) / std::max(sa[x] * sb[x], 1e-6f) : -2.0f;
    volume[x] = c;
    const bool wanted_lr = d >= lr.lo[x] && d <= lr.hi[x];
    const bool wanted_rl = rl.lo == nullptr ? wanted_lr : d >= rl.lo[x] && d <= rl.hi[x];
    if (wanted_lr && c > lr.best[x]) {
      lr.best[x] = c;
      lr.best_d[x] = d;
    }
    if (wanted_rl && c > rl.best[x]) {
      rl.best[x] = c;
      rl.best_d[x] = d;
    }
  }
}

// The sweep's result: the correlation of left pixel x with right pixel x - d
// at volume[(d - d_min) * plane + y * width + x] on rows y0 .. y1, -2 where
// it was not computed.
struct Volume {
  const float* data;
  std::size_t plane;
  int width, d_min;
};

// One direction's disparities from its best scores, with the parabola
// through the scores either side of the best from the volume. `shift` 0: the
// pixels are the left image's (left x at d is volume column x); 1: the right
// image's (right x at d is left x + d). A neighbour counts where it was
// searched: inside the pixel's range, or with `searched_by` (the left ranges,
// for right pixels without their own) where the left pixel's range held it.
void finish(const Search& s, const cv::Mat& best, const cv::Mat& best_d, const Volume& volume, int shift,
            const cv::Mat* lo_left, const cv::Mat* hi_left, const NccConfig& config, cv::Mat& disparity,
            cv::Mat& score) {
  disparity.create(best.size(), CV_32F);
  score.create(best.size(), CV_32F);
  fill(disparity, -1);
  fill(score, -1);
  if (!s.active()) return;
  const bool subpixel = config.subpixel;
  const float min_score = config.min_score;
  const int w = volume.width;
  const std::ptrdiff_t plane = static_cast<std::ptrdiff_t>(volume.plane);
  for (int y = s.y0; y <= s.y1; ++y) {
    const int* l = lo_left != nullptr ? lo_left->ptr<int>(y) : s.lo->ptr<int>(y);
    const int* u = hi_left != nullptr ? hi_left->ptr<int>(y) : s.hi->ptr<int>(y);
    const float* bs = best.ptr<float>(y);
    const int* bds = best_d.ptr<int>(y);
    float* out_d = disparity.ptr<float>(y);
    float* out_s = score.ptr<float>(y);
    // Row y of the plane of disparity 0 (not necessarily one that exists):
    // the score at (d, x) is at base[d * plane + x].
    const float* base = volume.data + static_cast<std::ptrdiff_t>(y) * w -
                        static_cast<std::ptrdiff_t>(volume.d_min) * plane;
    for (int x = s.x0; x <= s.x1; ++x) {
      const float b = bs[x];
      if (!(b > -2.0f) || b < min_score) continue;
      const int bd = bds[x];
      float dd = static_cast<float>(bd);
      const int x0 = x + shift * (bd - 1), x2 = x + shift * (bd + 1);
      bool neighbours = x0 >= 0 && x2 < w;
      if (neighbours) {
        if (lo_left != nullptr)
          neighbours = l[x0] <= bd - 1 && bd - 1 <= u[x0] && l[x2] <= bd + 1 && bd + 1 <= u[x2];
        else
          neighbours = bd > l[x] && bd < u[x];
      }
      if (subpixel && neighbours) {
        const float c0 = base[(bd - 1) * plane + x0];
        const float c2 = base[(bd + 1) * plane + x2];
        const float denom = c0 - 2 * b + c2;
        if (c0 > -2 && c2 > -2 && denom < 0) dd += std::clamp(0.5f * (c0 - c2) / denom, -0.5f, 0.5f);
      }
      out_d[x] = dd;
      out_s[x] = b;
    }
  }
}

}  // namespace

namespace {

// Both directions in one sweep. lo_rl and hi_rl null: the right pixels take
// exactly the pairs the left pixels search.
void match(const cv::Mat& left, const cv::Mat& right, const cv::Mat& lo_lr, const cv::Mat& hi_lr, const cv::Mat* lo_rl,
           const cv::Mat* hi_rl, const NccConfig& config, cv::Mat& disparity_lr, cv::Mat& score_lr,
           cv::Mat& disparity_rl, cv::Mat& score_rl, NccScratch& scratch) {
  CV_Assert(left.size() == right.size() && left.channels() == 1 && right.channels() == 1 && config.window % 2 == 1);
  CV_Assert((lo_rl == nullptr) == (hi_rl == nullptr));
  for (const cv::Mat* m : {&lo_lr, &hi_lr, lo_rl, hi_rl})
    if (m != nullptr) CV_Assert(m->size() == left.size() && m->type() == CV_32S);
  const int r = config.window / 2, n = config.window * config.window;
  const int w = left.cols, h = left.rows;
  const float min_texture = config.min_texture;
  if (w < 2 * r + 1 || h < 2 * r + 1) {
    for (cv::Mat* m : {&disparity_lr, &score_lr, &disparity_rl, &score_rl}) {
      m->create(left.size(), CV_32F);
      fill(*m, -1);
    }
    return;
  }
  // Centred values keep the float sums of products exact enough.
  left.convertTo(scratch.ref_f, CV_32F, 1.0, -128.0);
  right.convertTo(scratch.other_f, CV_32F, 1.0, -128.0);
  box_stats(scratch.ref_f, r, scratch.ref_mean, scratch.ref_std, scratch.col, scratch.col2, scratch.row, scratch.row2);
  box_stats(scratch.other_f, r, scratch.other_mean, scratch.other_std, scratch.col, scratch.col2, scratch.row,
            scratch.row2);
  const Search lr = bounds(lo_lr, hi_lr, scratch.ref_std, r, min_texture);
  const bool implicit = lo_rl == nullptr;
  Search rl;
  if (!implicit) {
    rl = bounds(*lo_rl, *hi_rl, scratch.other_std, r, min_texture);
  } else if (lr.active()) {
    // The right pixels any left pixel's search reaches.
    rl = lr;
    rl.lo = rl.hi = nullptr;
    rl.x0 = std::max(r, lr.x0 - lr.d_max);
    rl.x1 = std::min(w - 1 - r, lr.x1 - lr.d_min);
  }
  // One sweep over the disparities either direction wants fills the volume
  // of correlations; each direction then picks its best from it. The left
  // pixel x at d and the right pixel x - d at d share one correlation.
  const int y0 = std::min(lr.active() ? lr.y0 : h, rl.active() ? rl.y0 : h);
  const int y1 = std::max(lr.y1, rl.y1);
  const int d_min = std::min(lr.active() ? lr.d_min : (1 << 30), rl.active() ? rl.d_min : (1 << 30));
  const int d_max = std::max(lr.active() ? lr.d_max : -(1 << 30), rl.active() ? rl.d_max : -(1 << 30));
  const int count = y1 >= y0 ? d_max - d_min + 1 : 0;
  const std::size_t plane = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (scratch.volume.size() < plane * static_cast<std::size_t>(count)) scratch.volume.resize(plane * static_cast<std::size_t>(count));
  const float inv_n = 1.0f / static_cast<float>(n);
  std::vector<float>& col = scratch.col;
  col.assign(static_cast<std::size_t>(w), 0.0f);
  for (cv::Mat* m : {&scratch.best_lr, &scratch.best_rl}) {
    m->create(left.size(), CV_32F);
    fill(*m, -2.0f);
  }
  for (cv::Mat* m : {&scratch.best_d_lr, &scratch.best_d_rl}) {
    m->create(left.size(), CV_32S);
    fill(*m, 0);
  }
  for (int d = d_min; d < d_min + count; ++d) {
    // Left pixels x paired with right pixels x - d: those either direction
    // wants at this disparity, with both windows inside the images.
    int xs = w, xe = -1;
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
    if (xe < xs) {
      float* empty = scratch.volume.data() + static_cast<std::size_t>(d - d_min) * plane;
      std::fill(empty + static_cast<std::size_t>(y0) * w, empty + static_cast<std::size_t>(y1 + 1) * w, -2.0f);
      continue;
    }
    float* plane_d = scratch.volume.data() + static_cast<std::size_t>(d - d_min) * plane;
    std::fill(plane_d + static_cast<std::size_t>(y0) * w, plane_d + static_cast<std::size_t>(y1 + 1) * w, -2.0f);
    // Window sums of left(x) * right(x - d) over columns xs - r .. xe + r.
    const int xa = xs - r, xb = xe + r + 1;
    std::fill(col.begin() + xa, col.begin() + xb, 0.0f);
    for (int yy = y0 - r; yy <= y1 + r; ++yy) {
      const float* a = scratch.ref_f.ptr<float>(yy);
      const float* b = scratch.other_f.ptr<float>(yy) - d;
      const bool leaving = yy - 2 * r - 1 >= y0 - r;
      const float* a0 = leaving ? scratch.ref_f.ptr<float>(yy - 2 * r - 1) : nullptr;
      const float* b0 = leaving ? scratch.other_f.ptr<float>(yy - 2 * r - 1) - d : nullptr;
      slide_products(col.data() + xa, a + xa, b + xa, a0 ? a0 + xa : nullptr, b0 ? b0 + xa : nullptr, xb - xa);
      if (yy < y0 + r) continue;
      const int y = yy - r;
      const BestRow lr_row{lo_lr.ptr<int>(y) + xs, hi_lr.ptr<int>(y) + xs, scratch.best_lr.ptr<float>(y) + xs,
                           scratch.best_d_lr.ptr<int>(y) + xs};
      const BestRow rl_row{implicit ? nullptr : lo_rl->ptr<int>(y) + xs - d,
                           implicit ? nullptr : hi_rl->ptr<int>(y) + xs - d, scratch.best_rl.ptr<float>(y) + xs - d,
                           scratch.best_d_rl.ptr<int>(y) + xs - d};
      sweep_row(col.data() + xs, r, scratch.ref_mean.ptr<float>(y) + xs, scratch.ref_std.ptr<float>(y) + xs,
                scratch.other_mean.ptr<float>(y) + xs - d, scratch.other_std.ptr<float>(y) + xs - d, inv_n, min_texture,
                plane_d + static_cast<std::size_t>(y) * w + xs, lr_row, rl_row, xe - xs + 1, d);
    }
  }
  const Volume volume{scratch.volume.data(), plane, w, d_min};
  finish(lr, scratch.best_lr, scratch.best_d_lr, volume, 0, nullptr, nullptr, config, disparity_lr, score_lr);
  finish(rl, scratch.best_rl, scratch.best_d_rl, volume, 1, implicit ? &lo_lr : nullptr, implicit ? &hi_lr : nullptr,
         config, disparity_rl, score_rl);
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

double left_right_check(const cv::Mat& lr, const cv::Mat& lr_score, const cv::Mat& rl, const cv::Mat& rl_score,
                        float tolerance, cv::Mat& valid) {
  int matched = 0, kept = 0;
  for (int y = 0; y < lr.rows; ++y) {
    const float* d_row = lr.ptr<float>(y);
    const float* s_row = lr_score.ptr<float>(y);
    const float* back = rl.ptr<float>(y);
    const float* back_score = rl_score.ptr<float>(y);
    uint8_t* ok = valid.ptr<uint8_t>(y);
    for (int x = 0; x < lr.cols; ++x) {
      if (s_row[x] <= -1.0f) {
        ok[x] = 0;
        continue;
      }
      ++matched;
      const float d = d_row[x];
      const int xr = static_cast<int>(std::lround(x - d));
      const bool agrees =
          xr >= 0 && xr < rl.cols && back_score[xr] > -1.0f && std::fabs(back[xr] - d) <= tolerance;
      if (agrees) ++kept;
      else ok[x] = 0;
    }
  }
  return matched > 0 ? static_cast<double>(kept) / matched : 0.0;
}

}  // namespace saccade::stereo
