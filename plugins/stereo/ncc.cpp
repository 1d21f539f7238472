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

void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo, const cv::Mat& hi,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score, NccScratch& scratch) {
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
      int best = -1;
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
      if (best < 0 || best_score < config.min_score) continue;
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
