#include "ncc.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "saccade/fill.hpp"

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

void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo, const cv::Mat& hi,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score, NccScratch& scratch) {
  CV_Assert(left.size() == right.size() && left.channels() == 1 && right.channels() == 1 && config.window % 2 == 1);
  CV_Assert(lo.size() == left.size() && hi.size() == left.size() && lo.type() == CV_32S && hi.type() == CV_32S);
  const cv::Mat& ref = direction == Direction::kLeftToRight ? left : right;
  const cv::Mat& other = direction == Direction::kLeftToRight ? right : left;
  const int sign = direction == Direction::kLeftToRight ? -1 : 1;  // other x = x + sign * d
  const int r = config.window / 2, n = config.window * config.window;
  const int w = ref.cols, h = ref.rows;
  disparity.create(ref.size(), CV_32F);
  score.create(ref.size(), CV_32F);
  fill(disparity, -1);
  fill(score, -1);
  if (w < 2 * r + 1 || h < 2 * r + 1) return;
  // Centred values keep the float sums of products exact enough.
  ref.convertTo(scratch.ref_f, CV_32F, 1.0, -128.0);
  other.convertTo(scratch.other_f, CV_32F, 1.0, -128.0);
  box_stats(scratch.ref_f, r, scratch.ref_mean, scratch.ref_std, scratch.col, scratch.col2, scratch.row, scratch.row2);
  box_stats(scratch.other_f, r, scratch.other_mean, scratch.other_std, scratch.col, scratch.col2, scratch.row,
            scratch.row2);
  // The pixels to match and the disparities any of them wants.
  int y0 = h, y1 = -1, x0 = w, x1 = -1, d_min = 1 << 30, d_max = -(1 << 30);
  for (int y = r; y < h - r; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    const float* sa = scratch.ref_std.ptr<float>(y);
    for (int x = r; x < w - r; ++x) {
      if (u[x] < l[x] || sa[x] < config.min_texture) continue;
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      d_min = std::min(d_min, l[x]);
      d_max = std::max(d_max, u[x]);
    }
  }
  if (y1 < 0) return;
  // Per pixel: best score and disparity, the scores next to it, the last score.
  cv::Mat& best = scratch.best;
  cv::Mat& best_d = scratch.best_d;
  cv::Mat& before = scratch.before;
  cv::Mat& after = scratch.after;
  cv::Mat& last = scratch.last;
  for (cv::Mat* m : {&best, &before, &after, &last}) {
    m->create(ref.size(), CV_32F);
    fill(*m, -2.0f);
  }
  best_d.create(ref.size(), CV_32S);
  fill(best_d, 0);
  const float inv_n = 1.0f / static_cast<float>(n);
  std::vector<float>& col = scratch.col;
  std::vector<float>& row = scratch.row;
  std::vector<float>& product = scratch.row2;
  col.assign(static_cast<std::size_t>(w), 0.0f);
  row.assign(static_cast<std::size_t>(w), 0.0f);
  product.assign(static_cast<std::size_t>(w), 0.0f);
  for (int d = d_min; d <= d_max; ++d) {
    // Columns of `ref` whose partner lies inside `other`.
    const int shift = sign * d;
    // Only the columns the matched pixels' windows use.
    const int xa = std::max({0, -shift, x0 - r}), xb = std::min({w, w - shift, x1 + r + 1});
    std::fill(col.begin(), col.end(), 0.0f);
    // Window sums of ref(x) * other(x + shift), rows y0 - r .. y1 + r.
    for (int yy = y0 - r; yy <= y1 + r; ++yy) {
      const float* a = scratch.ref_f.ptr<float>(yy);
      const float* b = scratch.other_f.ptr<float>(yy) + shift;
      for (int x = xa; x < xb; ++x) col[static_cast<std::size_t>(x)] += a[x] * b[x];
      if (yy - 2 * r - 1 >= y0 - r) {
        const float* a0 = scratch.ref_f.ptr<float>(yy - 2 * r - 1);
        const float* b0 = scratch.other_f.ptr<float>(yy - 2 * r - 1) + shift;
        for (int x = xa; x < xb; ++x) col[static_cast<std::size_t>(x)] -= a0[x] * b0[x];
      }
      if (yy < y0 + r) continue;
      const int y = yy - r;
      if (xb - xa < 2 * r + 1) continue;
      row_box(col.data() + xa, row.data() + xa, xb - xa, r);
      const int* l = lo.ptr<int>(y);
      const int* u = hi.ptr<int>(y);
      const float* ma = scratch.ref_mean.ptr<float>(y);
      const float* sa = scratch.ref_std.ptr<float>(y);
      const float* mb = scratch.other_mean.ptr<float>(y);
      const float* sb = scratch.other_std.ptr<float>(y);
      float* bs = best.ptr<float>(y);
      int* bd = best_d.ptr<int>(y);
      float* bf = before.ptr<float>(y);
      float* af = after.ptr<float>(y);
      float* ls = last.ptr<float>(y);
      for (int x = std::max(r, x0); x <= std::min(w - r - 1, x1); ++x) {
        if (d < l[x] || d > u[x] || sa[x] < config.min_texture) {
          ls[x] = -2.0f;
          continue;
        }
        const int xo = x + shift;
        float c = -2.0f;
        if (xo >= r && xo < w - r && sb[xo] >= config.min_texture)
          c = (row[static_cast<std::size_t>(x)] * inv_n - ma[x] * mb[xo]) / (sa[x] * sb[xo]);
        if (d == bd[x] + 1 && bs[x] > -2.0f) af[x] = c;
        if (c > bs[x]) {
          bf[x] = ls[x];
          bs[x] = c;
          bd[x] = d;
          af[x] = -2.0f;
        }
        ls[x] = c;
      }
    }
  }
  for (int y = y0; y <= y1; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    const float* bs = best.ptr<float>(y);
    const int* bd = best_d.ptr<int>(y);
    const float* bf = before.ptr<float>(y);
    const float* af = after.ptr<float>(y);
    float* out_d = disparity.ptr<float>(y);
    float* out_s = score.ptr<float>(y);
    for (int x = r; x < w - r; ++x) {
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
