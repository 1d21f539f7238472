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

// Sums over (2r+1)-wide windows along each row of `in` (rows y0..y1, all
// columns), written at the window's centre; columns within r of the edge are
// left untouched.
inline void row_box(const float* in, float* out, int width, int r) {
  float s = 0;
  const int w = 2 * r + 1;
  for (int x = 0; x < w && x < width; ++x) s += in[x];
  for (int x = r; x + r < width; ++x) {
    out[x] = s;
    if (x + r + 1 < width) s += in[x + r + 1] - in[x - r];
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
    if (y < 2 * r) continue;
    const int yc = y - r;
    row_box(col.data(), row.data(), w, r);
    row_box(col2.data(), row2.data(), w, r);
    float* m = mean.ptr<float>(yc);
    float* sd = stddev.ptr<float>(yc);
    for (int x = r; x + r < w; ++x) {
      const float mu = row[static_cast<std::size_t>(x)] / static_cast<float>(n);
      m[x] = mu;
      sd[x] = std::sqrt(std::max(0.0f, row2[static_cast<std::size_t>(x)] / static_cast<float>(n) - mu * mu));
    }
  }
}

}  // namespace

namespace {

// One direction's search state: per pixel the best score and its disparity,
// the scores next to it (for the sub-pixel parabola), the last score seen and
// at which disparity.
struct Search {
  const cv::Mat* lo;
  const cv::Mat* hi;
  const cv::Mat* stddev;  // of the image this direction's pixels belong to
  cv::Mat *best, *best_d, *before, *after, *last, *last_d;
  int y0 = 0, y1 = -1, x0 = 0, x1 = -1, d_min = 0, d_max = -1;
  bool active() const { return y1 >= y0; }
};

void prepare(Search& s, NccScratch::Side& side, const cv::Mat& lo, const cv::Mat& hi, const cv::Mat& stddev, int r,
             float min_texture) {
  s.lo = &lo;
  s.hi = &hi;
  s.stddev = &stddev;
  const int w = lo.cols, h = lo.rows;
  s.y0 = h;
  s.y1 = -1;
  s.x0 = w;
  s.x1 = -1;
  s.d_min = 1 << 30;
  s.d_max = -(1 << 30);
  for (int y = r; y < h - r; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    const float* sd = stddev.ptr<float>(y);
    for (int x = r; x < w - r; ++x) {
      if (u[x] < l[x] || sd[x] < min_texture) continue;
      s.y0 = std::min(s.y0, y);
      s.y1 = std::max(s.y1, y);
      s.x0 = std::min(s.x0, x);
      s.x1 = std::max(s.x1, x);
      s.d_min = std::min(s.d_min, l[x]);
      s.d_max = std::max(s.d_max, u[x]);
    }
  }
  for (cv::Mat* m : {&side.best, &side.before, &side.after, &side.last}) {
    m->create(lo.size(), CV_32F);
    fill(*m, -2.0f);
  }
  side.best_d.create(lo.size(), CV_32S);
  side.last_d.create(lo.size(), CV_32S);
  fill(side.best_d, 0);
  fill(side.last_d, -(1 << 30));
  s.best = &side.best;
  s.best_d = &side.best_d;
  s.before = &side.before;
  s.after = &side.after;
  s.last = &side.last;
  s.last_d = &side.last_d;
}

// One row of a direction's state, so the inner loop indexes plain arrays.
struct Row {
  const int *lo, *hi;
  const float* stddev;
  float *best, *before, *after, *last;
  int *best_d, *last_d;
  Row(const Search& s, int y)
      : lo(s.lo->ptr<int>(y)), hi(s.hi->ptr<int>(y)), stddev(s.stddev->ptr<float>(y)), best(s.best->ptr<float>(y)),
        before(s.before->ptr<float>(y)), after(s.after->ptr<float>(y)), last(s.last->ptr<float>(y)),
        best_d(s.best_d->ptr<int>(y)), last_d(s.last_d->ptr<int>(y)) {}
};

// Candidates c[i] at disparity d for the pixels first .. first + count - 1 of
// one direction's row. Written with selects and no early exits over
// restrict-qualified arrays, so the compiler vectorises it: this loop is where
// the search spends its time.
SACCADE_AVX2_CLONE void offer_span(const Row& s, int first, int count, int d, const float* __restrict c,
                                   float min_texture) {
  const int* __restrict lo = s.lo + first;
  const int* __restrict hi = s.hi + first;
  const float* __restrict sd = s.stddev + first;
  float* __restrict best = s.best + first;
  float* __restrict before = s.before + first;
  float* __restrict after = s.after + first;
  float* __restrict last = s.last + first;
  int* __restrict best_d = s.best_d + first;
  int* __restrict last_d = s.last_d + first;
  // Eight pixels at a time with GCC's vector extension (two SSE2 registers,
  // or one AVX2 register in the AVX2 clone): the compiler's own vectoriser
  // gives up on this loop's selects.
  typedef float v4f __attribute__((vector_size(32)));
  typedef int v4i __attribute__((vector_size(32)));
  const v4i dv = v4i{} + d, d1 = dv - 1;
  const v4f minus2 = v4f{} - 2.0f;
  const v4f texture = v4f{} + min_texture;
  constexpr int kLanes = static_cast<int>(sizeof(v4f) / sizeof(float));
  int i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    v4f ci, bi, li, ai, fi, sdi;
    v4i bdi, ldi, loi, hii;
    std::memcpy(&ci, c + i, sizeof ci);
    std::memcpy(&bi, best + i, sizeof bi);
    std::memcpy(&li, last + i, sizeof li);
    std::memcpy(&ai, after + i, sizeof ai);
    std::memcpy(&fi, before + i, sizeof fi);
    std::memcpy(&sdi, sd + i, sizeof sdi);
    std::memcpy(&bdi, best_d + i, sizeof bdi);
    std::memcpy(&ldi, last_d + i, sizeof ldi);
    std::memcpy(&loi, lo + i, sizeof loi);
    std::memcpy(&hii, hi + i, sizeof hii);
    const v4i in = (dv >= loi) & (dv <= hii) & (sdi >= texture);
    const v4f previous = ldi == d1 ? li : minus2;
    const v4i next_to_best = (dv == bdi + 1) & (bi > minus2);
    const v4i take = in & (ci > bi);
    const v4f a = (in & next_to_best) ? ci : ai;
    const v4f after_new = take ? minus2 : a;
    const v4f before_new = take ? previous : fi;
    const v4i best_d_new = take ? dv : bdi;
    const v4f best_new = take ? ci : bi;
    const v4f last_new = in ? ci : li;
    const v4i last_d_new = in ? dv : ldi;
    std::memcpy(after + i, &after_new, sizeof after_new);
    std::memcpy(before + i, &before_new, sizeof before_new);
    std::memcpy(best_d + i, &best_d_new, sizeof best_d_new);
    std::memcpy(best + i, &best_new, sizeof best_new);
    std::memcpy(last + i, &last_new, sizeof last_new);
    std::memcpy(last_d + i, &last_d_new, sizeof last_d_new);
  }
  for (; i < count; ++i) {
    const bool in = d >= lo[i] && d <= hi[i] && sd[i] >= min_texture;
    if (!in) continue;
    const float previous = last_d[i] == d - 1 ? last[i] : -2.0f;
    if (d == best_d[i] + 1 && best[i] > -2.0f) after[i] = c[i];
    if (c[i] > best[i]) {
      before[i] = previous;
      best[i] = c[i];
      best_d[i] = d;
      after[i] = -2.0f;
    }
    last[i] = c[i];
    last_d[i] = d;
  }
}

void finish(const Search& s, int r, const NccConfig& config, cv::Mat& disparity, cv::Mat& score) {
  disparity.create(s.lo->size(), CV_32F);
  score.create(s.lo->size(), CV_32F);
  fill(disparity, -1);
  fill(score, -1);
  for (int y = s.y0; y <= s.y1; ++y) {
    const int* l = s.lo->ptr<int>(y);
    const int* u = s.hi->ptr<int>(y);
    const float* bs = s.best->ptr<float>(y);
    const int* bd = s.best_d->ptr<int>(y);
    const float* bf = s.before->ptr<float>(y);
    const float* af = s.after->ptr<float>(y);
    float* out_d = disparity.ptr<float>(y);
    float* out_s = score.ptr<float>(y);
    for (int x = r; x < s.lo->cols - r; ++x) {
      if (!(bs[x] > -2.0f) || bs[x] < config.min_score) continue;
      float dd = static_cast<float>(bd[x]);
      if (config.subpixel && bd[x] > l[x] && bd[x] < u[x]) {
        const float c0 = bf[x], c1 = bs[x], c2 = af[x];
        const float denom = c0 - 2 * c1 + c2;
        if (c0 > -2 && c2 > -2 && denom < 0) dd += std::clamp(0.5f * (c0 - c2) / denom, -0.5f, 0.5f);
      }
      out_d[x] = dd;
      out_s[x] = bs[x];
    }
  }
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

// The correlation coefficients of one row of window sums; -2 where either
// window is too flat to match.
SACCADE_AVX2_CLONE void correlations(float* __restrict c, const float* __restrict sum, const float* __restrict ma,
                                     const float* __restrict sa, const float* __restrict mb,
                                     const float* __restrict sb, int n, float inv_n, float min_texture) {
  for (int x = 0; x < n; ++x) {
    const bool textured = (sa[x] >= min_texture) & (sb[x] >= min_texture);
    const float value = (sum[x] * inv_n - ma[x] * mb[x]) / std::max(sa[x] * sb[x], 1e-6f);
    c[x] = textured ? value : -2.0f;
  }
}

}  // namespace

void ncc_match_both(const cv::Mat& left, const cv::Mat& right, const cv::Mat& lo_lr, const cv::Mat& hi_lr,
                    const cv::Mat& lo_rl, const cv::Mat& hi_rl, const NccConfig& config, cv::Mat& disparity_lr,
                    cv::Mat& score_lr, cv::Mat& disparity_rl, cv::Mat& score_rl, NccScratch& scratch) {
  CV_Assert(left.size() == right.size() && left.channels() == 1 && right.channels() == 1 && config.window % 2 == 1);
  for (const cv::Mat* m : {&lo_lr, &hi_lr, &lo_rl, &hi_rl}) CV_Assert(m->size() == left.size() && m->type() == CV_32S);
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
  Search lr, rl;
  prepare(lr, scratch.lr, lo_lr, hi_lr, scratch.ref_std, r, min_texture);
  prepare(rl, scratch.rl, lo_rl, hi_rl, scratch.other_std, r, min_texture);
  if (lr.active() || rl.active()) {
    const int y0 = std::min(lr.active() ? lr.y0 : h, rl.active() ? rl.y0 : h);
    const int y1 = std::max(lr.y1, rl.y1);
    const int d_min = std::min(lr.active() ? lr.d_min : (1 << 30), rl.active() ? rl.d_min : (1 << 30));
    const int d_max = std::max(lr.active() ? lr.d_max : -(1 << 30), rl.active() ? rl.d_max : -(1 << 30));
    const float inv_n = 1.0f / static_cast<float>(n);
    std::vector<float>& col = scratch.col;
    std::vector<float>& row = scratch.row;
    col.assign(static_cast<std::size_t>(w), 0.0f);
    row.assign(static_cast<std::size_t>(w), 0.0f);
    scratch.scores.assign(static_cast<std::size_t>(w), -2.0f);
    for (int d = d_min; d <= d_max; ++d) {
      // Left pixels x paired with right pixels x - d: those either direction
      // wants at this disparity, with both windows inside the images.
      int xs = w, xe = -1;
      if (lr.active() && d >= lr.d_min && d <= lr.d_max) {
        xs = std::min(xs, lr.x0);
        xe = std::max(xe, lr.x1);
      }
      if (rl.active() && d >= rl.d_min && d <= rl.d_max) {
        xs = std::min(xs, rl.x0 + d);
        xe = std::max(xe, rl.x1 + d);
      }
      xs = std::max({xs, r, r + d});
      xe = std::min({xe, w - r - 1, w - r - 1 + d});
      if (xe < xs) continue;
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
        row_box(col.data() + xa, row.data() + xa, xb - xa, r);
        const float* ma = scratch.ref_mean.ptr<float>(y);
        const float* sa = scratch.ref_std.ptr<float>(y);
        const float* mb = scratch.other_mean.ptr<float>(y);
        const float* sb = scratch.other_std.ptr<float>(y);
        float* __restrict c = scratch.scores.data();
        const float* __restrict sum = row.data();
        correlations(c, sum + xs, ma + xs, sa + xs, mb + xs - d, sb + xs - d, xe - xs + 1, inv_n, min_texture);
        if (lr.active()) offer_span(Row(lr, y), xs, xe - xs + 1, d, c, min_texture);
        if (rl.active()) offer_span(Row(rl, y), xs - d, xe - xs + 1, d, c, min_texture);
      }
    }
  }
  finish(lr, r, config, disparity_lr, score_lr);
  finish(rl, r, config, disparity_rl, score_rl);
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
  for (int y = 0; y < lr.rows; ++y)
    for (int x = 0; x < lr.cols; ++x) {
      if (lr_score.at<float>(y, x) <= -1.0f) {
        valid.at<uint8_t>(y, x) = 0;
        continue;
      }
      ++matched;
      const float d = lr.at<float>(y, x);
      const int xr = static_cast<int>(std::lround(x - d));
      const bool agrees = xr >= 0 && xr < rl.cols && rl_score.at<float>(y, xr) > -1.0f &&
                          std::fabs(rl.at<float>(y, xr) - d) <= tolerance;
      if (agrees) ++kept;
      else valid.at<uint8_t>(y, x) = 0;
    }
  return matched > 0 ? static_cast<double>(kept) / matched : 0.0;
}

}  // namespace saccade::stereo
