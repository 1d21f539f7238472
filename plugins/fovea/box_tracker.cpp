#include "box_tracker.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "color_histogram.hpp"
#include "frame_samples.hpp"
#include "real_fft.hpp"
#include "saccade/reuse.hpp"
#include "saccade/simd.hpp"
#include "saccade/subpixel.hpp"
#include "tracker.hpp"
#include "view_motion.hpp"

namespace saccade::fovea {

const char* to_string(TrackState state) {
  switch (state) {
    case TrackState::kTracking: return "tracking";
    case TrackState::kUncertain: return "uncertain";
    case TrackState::kLost: return "lost";
  }
  return "?";
}

namespace {

constexpr int kChannels = 5;    // gray, and the gradient's strength along 4 directions
constexpr int kScaleSide = 12;  // the scale filter's samples: kScaleSide x kScaleSide cells of the box

// Where a patch comes from: its centre and its step (source pixels per patch pixel).
struct Placement {
  cv::Point2d center;
  double step = 1;
  double angle = 0;       // radians: the patch's axes turned by this from the frame's
  bool proposed = false;  // by the whole-frame search, which centred the target's whole coarse look here

  // Where patch offset `d` (patch pixels from its centre) is in the frame.
  cv::Point2d to_frame(cv::Point2d d) const {
    const double c = std::cos(angle), s = std::sin(angle);
    return center + step * cv::Point2d(c * d.x - s * d.y, s * d.x + c * d.y);
  }
};

// The sizes, besides the target's, at which a lost target is looked for: they
// reach 1.25x, 1.56x and 1.95x either way on successive searches (`reach` 0,
// 1, 2).
constexpr std::array<std::array<double, 2>, 3> kOtherSizes{{{1.25, 0.8}, {1.5625, 0.64}, {1.953125, 0.512}}};
// Looks whose steps differ by less than this share see the target at one size.
constexpr double kSameSize = 0.05;

// One correlation's outcome, in patch pixels from the patch's centre.
struct Peak {
  cv::Point2d offset;
  double value = 0;
  double psr = 0;
  double rival = 0;  // the highest response outside the peak's window, as a share of the peak
};

cv::Mat hann_window(int side) {
  cv::Mat w(side, side, CV_32F);
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x)
      w.at<float>(y, x) = static_cast<float>(0.25 * (1 - std::cos(2 * CV_PI * x / (side - 1))) *
                                             (1 - std::cos(2 * CV_PI * y / (side - 1))));
  return w;
}

// The desired response: a Gaussian at the patch's centre.
cv::Mat gaussian_response(int side, double sigma) {
  cv::Mat g(side, side, CV_32F);
  const double c = side / 2;
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x)
      g.at<float>(y, x) = static_cast<float>(std::exp(-((x - c) * (x - c) + (y - c) * (y - c)) / (2 * sigma * sigma)));
  return g;
}

// Peak-to-sidelobe ratio: the peak against the response outside an 11x11
// window around it. A sharp, lone peak (the target) scores high; a flat or
// many-peaked response (occlusion, clutter) low.
double peak_to_sidelobe(const cv::Mat& response, cv::Point peak, double* rival) {
  const int r = 5;
  double sum = 0, sq = 0, highest = -INFINITY;
  int n = 0;
  for (int y = 0; y < response.rows; ++y) {
    const float* row = response.ptr<float>(y);
    const bool near_row = std::abs(y - peak.y) <= r;
    for (int x = 0; x < response.cols; ++x) {
      if (near_row && std::abs(x - peak.x) <= r) continue;
      sum += row[x];
      sq += static_cast<double>(row[x]) * row[x];
      highest = std::max(highest, static_cast<double>(row[x]));
      ++n;
    }
  }
  const double mean = sum / n;
  const double sd = std::sqrt(std::max(sq / n - mean * mean, 1e-12));
  const double top = response.at<float>(peak);
  *rival = top > 0 ? highest / top : 1.0;
  return (top - mean) / sd;
}

}  // namespace

// Samples `size` pixels centred on `centre` at `step_x` x `step_y` source
// pixels per pixel, its axes turned by `angle` (radians), from an 8-bit gray
// or BGR frame, into 8-bit gray `out`.
// Steps above 1.5 are sampled at twice the resolution and halved, so that a
// pixel is a mean over its cell (as a retina level's), not one source pixel.
// Only the sample is converted to gray: the cost does not grow with the frame.
// `fine` and `fine_gray` keep the buffers between calls (reuse.hpp: looks at
// and under the halving step alternate between two sizes).
void sample_gray(const cv::Mat& frame, cv::Point2d center, double step_x, double step_y, cv::Size size, cv::Mat& out,
                 cv::Mat& fine, cv::Mat& fine_gray, double angle = 0) {
  const bool halve = std::max(step_x, step_y) > 1.5;
  const cv::Size n = halve ? size * 2 : size;
  const double sx = halve ? step_x / 2 : step_x, sy = halve ? step_y / 2 : step_y;
  // Patch pixel (u, v) samples centre + R(angle) diag(sx, sy) ((u, v) - the patch's middle).
  const double c = std::cos(angle), s = std::sin(angle);
  const double mx = (n.width - 1) / 2.0, my = (n.height - 1) / 2.0;
  const cv::Matx23d m(c * sx, -s * sy, center.x - (c * sx * mx - s * sy * my), s * sx, c * sy,
                      center.y - (s * sx * mx + c * sy * my));
  cv::Mat scratch = reuse(fine, n, frame.type());
  if (!halve) return warp_to_gray(frame, m, n, out, scratch);
  cv::Mat twice = reuse(fine_gray, n, CV_8U);
  warp_to_gray(frame, m, n, twice, scratch);
  pyr_down(twice, out);
}

// The chromaticity (r, g: each channel's share of R + G + B) of the mean
// colour inside the central half of `box`, its channels multiplied by
// `gains`: the same under brighter or dimmer light, changed by a tint.
// (1/3, 1/3) for a gray frame.
cv::Vec2d chroma(const cv::Mat& frame, cv::Point2d center, cv::Size2d size, const ChannelGains& gains) {
  if (frame.channels() < 3) return {1.0 / 3, 1.0 / 3};
  const cv::Rect inner = central_half(frame, center, size);
  if (inner.empty()) return {1.0 / 3, 1.0 / 3};
  const cv::Scalar mean = cv::mean(frame(inner));
  const double b = mean[0] * (gains.q8[0] / 256.0), g = mean[1] * (gains.q8[1] / 256.0),
               r = mean[2] * (gains.q8[2] / 256.0);
  const double sum = b + g + r + 1e-9;
  return {r / sum, g / sum};
}

// The scale filter's arithmetic per dimension, each spectrum's real and
// imaginary parts in planes of their own, for the vectoriser: the same
// operations in the same order as on std::complex, so bit for bit its results.

// z += w x: one scale's term of the transform across scales.
SACCADE_AVX2_CLONE void add_scale_term(float* __restrict zr, float* __restrict zi, float wr, float wi,
                                       const float* __restrict x, int count) {
  for (int d = 0; d < count; ++d) {
    zr[d] += wr * x[d];
    zi[d] += wi * x[d];
  }
}

// n <- keep n + g conj(f), `g` the target's spectrum times the rate.
SACCADE_AVX2_CLONE void learn_scale_term(float* __restrict nr, float* __restrict ni, const float* __restrict fr,
                                         const float* __restrict fi, float gr, float gi, float keep, int count) {
  for (int d = 0; d < count; ++d) {
    nr[d] = keep * nr[d] + (gr * fr[d] - gi * -fi[d]);
    ni[d] = keep * ni[d] + (gr * -fi[d] + gi * fr[d]);
  }
}

// DSST's scale filter: a one-dimensional correlation filter across `count`
// scales of the target (Danelljan et al., BMVC 2014). Each scale's sample is
// the target's box times that scale, sampled to a small fixed patch; the
// filter learns which scale matches the model, independent of translation.
class ScaleFilter {
 public:
  ScaleFilter(int count, double step, int side) : count_(count), side_(side), dims_(3 * side * side) {
    const auto n = static_cast<std::size_t>(count);
    factors_.resize(n);
    window_.resize(n);
    std::vector<double> g(n);
    const double sigma = std::sqrt(count) / 4.0;
    for (int k = 0; k < count; ++k) {
      const double i = k - (count - 1) / 2.0;
      factors_[static_cast<std::size_t>(k)] = std::pow(step, -i);
      g[static_cast<std::size_t>(k)] = std::exp(-0.5 * i * i / (sigma * sigma));
      window_[static_cast<std::size_t>(k)] =
          static_cast<float>(0.5 * (1 - std::cos(2 * CV_PI * (k + 1) / (count + 1))));
    }
    twiddle_.resize(n * n);
    for (int a = 0; a < count; ++a)
      for (int b = 0; b < count; ++b)
        twiddle_[static_cast<std::size_t>(a * count + b)] =
            std::polar(1.0f, static_cast<float>(-2 * CV_PI * a * b / count));
    target_.assign(n, {});
    for (int k = 0; k < count; ++k)
      for (int s = 0; s < count; ++s)
        target_[static_cast<std::size_t>(k)] +=
            static_cast<float>(g[static_cast<std::size_t>(s)]) * twiddle_[static_cast<std::size_t>(s * count + k)];
    samples_.resize(n * static_cast<std::size_t>(dims_));
    // Real samples: the spectrum's frequencies above count / 2 mirror those
    // below, so only those up to it are kept.
    const auto half = static_cast<std::size_t>((count / 2 + 1) * dims_);
    spectra_re_.resize(half);
    spectra_im_.resize(half);
    numerator_re_.resize(half);
    numerator_im_.resize(half);
    sample_.resize(static_cast<std::size_t>(side * side));
    values_.resize(n);
  }

  // The best scale factor for a target of `size` around `centre`, turned by
  // `angle` (radians) in the frame (1: unchanged).
  double estimate(const cv::Mat& frame, cv::Point2d center, cv::Size2d size, double angle, double lambda) {
    if (denominator_.empty()) return flatness_ = 1, 1.0;  // nothing learnt yet
    spectra(frame, center, size, angle);
    // Response = IDFT over scales of sum_d A_d(k) Z_d(k) / (B(k) + lambda).
    std::vector<std::complex<float>>& r = response_;
    r.assign(static_cast<std::size_t>(count_), {});
    for (int k = 0; k <= count_ / 2; ++k) {  // the rest mirrors it: real samples
      const auto at = static_cast<std::size_t>(k * dims_);
      const float *ar = &numerator_re_[at], *ai = &numerator_im_[at];
      const float *zr = &spectra_re_[at], *zi = &spectra_im_[at];
      float sr = 0, si = 0;  // one sum, in order: a vectorised one would round otherwise
      for (int d = 0; d < dims_; ++d) {
        sr += ar[d] * zr[d] - ai[d] * zi[d];
        si += ar[d] * zi[d] + ai[d] * zr[d];
      }
      r[static_cast<std::size_t>(k)] =
          std::complex<float>(sr, si) / (denominator_[static_cast<std::size_t>(k)] + static_cast<float>(lambda));
      if (k > 0) r[static_cast<std::size_t>(count_ - k)] = std::conj(r[static_cast<std::size_t>(k)]);
    }
    int best = 0;
    float best_value = -INFINITY;
    for (int s = 0; s < count_; ++s) {
      float value = 0;  // the real part of the inverse transform at s
      for (int k = 0; k < count_; ++k)
        value +=
            (r[static_cast<std::size_t>(k)] * std::conj(twiddle_[static_cast<std::size_t>(s * count_ + k)])).real();
      values_[static_cast<std::size_t>(s)] = value;
      if (value > best_value) best_value = value, best = s;
    }
    const auto below = static_cast<std::size_t>(std::max(best - 2, 0));
    const auto above = static_cast<std::size_t>(std::min(best + 2, count_ - 1));
    flatness_ = best_value > 0 ? (values_[below] + values_[above]) / (2 * best_value) : 1.0;
    return factors_[static_cast<std::size_t>(best)];
  }
  // The last estimate()'s response two scales either side of its top, as a
  // share of the top: near 1, no scale fits the target better than the
  // others (the filter learnt it at another size, or it has turned); where
  // the size is followed, 9 frames in 10 are under 0.67 (docs/tracking-log.md).
  double flatness() const { return flatness_; }

  // Learns from the samples estimate() took when `fresh` is false (the
  // scale did not change, so they are this frame's samples at this size).
  void learn(const cv::Mat& frame, cv::Point2d center, cv::Size2d size, double angle, double rate, bool fresh) {
    if (fresh || denominator_.empty()) spectra(frame, center, size, angle);
    if (denominator_.empty()) {  // the first frame: the model is the sample
      std::fill(numerator_re_.begin(), numerator_re_.end(), 0.0f);
      std::fill(numerator_im_.begin(), numerator_im_.end(), 0.0f);
      denominator_.assign(static_cast<std::size_t>(count_ / 2 + 1), 0.0f);
      rate = 1;
    }
    const float a = static_cast<float>(rate), keep = 1 - a;
    for (int k = 0; k <= count_ / 2; ++k) {  // the rest mirrors it: real samples
      const std::complex<float> g = a * target_[static_cast<std::size_t>(k)];
      const auto at = static_cast<std::size_t>(k * dims_);
      const float *fr = &spectra_re_[at], *fi = &spectra_im_[at];
      learn_scale_term(&numerator_re_[at], &numerator_im_[at], fr, fi, g.real(), g.imag(), keep, dims_);
      float energy = 0;  // in order, as estimate()'s sums
      for (int d = 0; d < dims_; ++d) energy += fr[d] * fr[d] + fi[d] * fi[d];
      float& b = denominator_[static_cast<std::size_t>(k)];
      b = keep * b + a * energy;
    }
  }

 private:
  // Per scale (row), the scale's sample as gray and gradient strengths,
  // windowed across scales; then the transform across scales, per dimension.
  void spectra(const cv::Mat& frame, cv::Point2d center, cv::Size2d size, double angle) {
    const int pixels = side_ * side_;
    // A turned target's scales are read as an upright one's from one view of
    // the largest scale turned with it, at a quarter of the smallest scale's
    // cell, and at least half a source pixel (at half a cell, the second
    // interpolation blurred the samples enough to lower `scale`'s AUC 0.93 ->
    // 0.83 with the view used at any angle).
    const cv::Mat* source = &frame;
    cv::Mat view;
    cv::Point2d middle = center;
    cv::Size2d unit(1, 1);  // source pixels per pixel of the source read
    if (angle != 0) {
      constexpr double kViewCells = 4;  // view pixels per cell of the smallest scale
      const double largest = factors_.front(), smallest = factors_.back();
      unit = cv::Size2d(std::max(0.5, size.width * smallest / side_ / kViewCells),
                        std::max(0.5, size.height * smallest / side_ / kViewCells));
      const cv::Size n(static_cast<int>(std::ceil(size.width * largest / unit.width)) + 3,
                       static_cast<int>(std::ceil(size.height * largest / unit.height)) + 3);
      const double c = std::cos(angle), s = std::sin(angle);
      const double mx = (n.width - 1) / 2.0, my = (n.height - 1) / 2.0;
      // View pixel (u, v) reads centre + R(angle) diag(unit) ((u, v) - the view's middle).
      const cv::Matx23d m(c * unit.width, -s * unit.height, center.x - (c * unit.width * mx - s * unit.height * my),
                          s * unit.width, c * unit.height, center.y - (s * unit.width * mx + c * unit.height * my));
      // In buffers that only grow: the view's size follows the box's.
      view = reuse(view_buffer_, n, CV_8U);
      cv::Mat scratch = reuse(view_scratch_, n, frame.type());
      warp_to_gray(frame, m, n, view, scratch);
      source = &view;
      middle = {mx, my};
    }
    for (int k = 0; k < count_; ++k) {
      const double f = factors_[static_cast<std::size_t>(k)];
      sample_cell_means(*source, middle, size.width * f / side_ / unit.width, size.height * f / side_ / unit.height,
                        cv::Size(side_, side_), sample_.data());
      double sum = 0, sq = 0;
      for (float v : sample_) sum += v, sq += static_cast<double>(v) * v;
      const double mean = sum / pixels;
      const float gain = static_cast<float>(window_[static_cast<std::size_t>(k)] /
                                            (std::sqrt(std::max(sq / pixels - mean * mean, 0.0)) + 1.0));
      const float offset = static_cast<float>(mean);
      const float* v = sample_.data();
      float* out = &samples_[static_cast<std::size_t>(k * dims_)];
      for (int y = 0; y < side_; ++y)
        for (int x = 0; x < side_; ++x) {
          const int i = y * side_ + x;
          const float dx = v[y * side_ + std::min(x + 1, side_ - 1)] - v[y * side_ + std::max(x - 1, 0)];
          const float dy = v[std::min(y + 1, side_ - 1) * side_ + x] - v[std::max(y - 1, 0) * side_ + x];
          out[i] = gain * (v[i] - offset);
          out[pixels + i] = gain * std::abs(dx);
          out[2 * pixels + i] = gain * std::abs(dy);
        }
    }
    for (int k = 0; k <= count_ / 2; ++k) {  // the rest mirrors it: real samples
      const auto at = static_cast<std::size_t>(k * dims_);
      float *zr = &spectra_re_[at], *zi = &spectra_im_[at];
      std::fill(zr, zr + dims_, 0.0f);
      std::fill(zi, zi + dims_, 0.0f);
      for (int s = 0; s < count_; ++s) {
        const std::complex<float> w = twiddle_[static_cast<std::size_t>(s * count_ + k)];
        add_scale_term(zr, zi, w.real(), w.imag(), &samples_[static_cast<std::size_t>(s * dims_)], dims_);
      }
    }
  }

  int count_, side_, dims_;
  std::vector<double> factors_;
  std::vector<float> window_, sample_, samples_;
  std::vector<float> values_;       // the last estimate()'s response per scale
  double flatness_ = 1;             // flatness() of that response
  std::vector<float> denominator_;  // per frequency up to count / 2; empty until the first learn()
  // Per frequency up to count / 2 (row), per dimension: the samples' spectra and the model's numerator.
  std::vector<float> spectra_re_, spectra_im_, numerator_re_, numerator_im_;
  std::vector<std::complex<float>> twiddle_, target_, response_;
  cv::Mat view_buffer_, view_scratch_;  // what holds a turned target's view (spectra), and the warp's scratch
};

namespace {

// One row of the box tracker's feature channels (Impl::features): `p` is the
// row's 7x7 windows' first row in a patch bordered by 3 pixels (`wide`
// floats a row), `w` the row's window weights; `scratch` holds 4 * wide
// floats. Written for the vectoriser: plain loops over the row.
SACCADE_AVX2_CLONE void feature_row(const float* __restrict p, int wide, const float* __restrict w,
                                    float* __restrict scratch, float* const* out) {
  constexpr float kArea = 1.0f / 49.0f, kDiagonal = static_cast<float>(M_SQRT1_2);
  const int side = wide - 6;
  float* __restrict cs = scratch;  // column sums over the window's 7 rows
  float* __restrict cq = scratch + wide;
  float* __restrict mean = scratch + 2 * wide;  // the 7x7 window's mean and mean square
  float* __restrict square = scratch + 3 * wide;
  for (int px = 0; px < wide; ++px) cs[px] = cq[px] = 0.0f;
  for (int r = 0; r < 7; ++r) {
    const float* __restrict q = p + r * wide;
    for (int px = 0; px < wide; ++px) {
      cs[px] += q[px];
      cq[px] += q[px] * q[px];
    }
  }
  for (int x = 0; x < side; ++x) {
    mean[x] = (cs[x] + cs[x + 1] + cs[x + 2] + cs[x + 3] + cs[x + 4] + cs[x + 5] + cs[x + 6]) * kArea;
    square[x] = (cq[x] + cq[x + 1] + cq[x + 2] + cq[x + 3] + cq[x + 4] + cq[x + 5] + cq[x + 6]) * kArea;
  }
  const float* __restrict above = p + 2 * wide + 3;  // rows y - 1, y, y + 1 at the patch's column 0
  const float* __restrict here = above + wide;
  const float* __restrict below = here + wide;
  float* __restrict c0 = out[0];
  float* __restrict c1 = out[1];
  float* __restrict c2 = out[2];
  float* __restrict c3 = out[3];
  float* __restrict c4 = out[4];
  for (int x = 0; x < side; ++x) {
    const float dx = (above[x + 1] + 2 * here[x + 1] + below[x + 1]) - (above[x - 1] + 2 * here[x - 1] + below[x - 1]);
    const float dy = (below[x - 1] + 2 * below[x] + below[x + 1]) - (above[x - 1] + 2 * above[x] + above[x + 1]);
    // +4: flat neighbourhoods stay flat rather than amplify noise.
    const float spread = std::sqrt(std::max(square[x] - mean[x] * mean[x], 0.0f)) + 4.0f;
    const float g = w[x] / spread, e = g * 0.25f;
    c0[x] = (here[x] - mean[x]) * g;
    c1[x] = std::abs(dx) * e;
    c2[x] = std::abs(dy) * e;
    c3[x] = std::abs(dx + dy) * kDiagonal * e;
    c4[x] = std::abs(dx - dy) * kDiagonal * e;
  }
}

// The filter's per-frequency arithmetic over the half spectra's planes
// (RealFft2d's layout), for the vectoriser.

// numerator <- keep numerator + a G conj(F); energy += a |F|^2.
SACCADE_AVX2_CLONE void learn_channel(const float* __restrict gr, const float* __restrict gi,
                                      const float* __restrict fr, const float* __restrict fi, float* __restrict nr,
                                      float* __restrict ni, float* __restrict energy, float a, float keep,
                                      std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    nr[i] = keep * nr[i] + a * (gr[i] * fr[i] + gi[i] * fi[i]);
    ni[i] = keep * ni[i] + a * (gi[i] * fr[i] - gr[i] * fi[i]);
    energy[i] += a * (fr[i] * fr[i] + fi[i] * fi[i]);
  }
}

// sum += Z N.
SACCADE_AVX2_CLONE void multiply_add(const float* __restrict zr, const float* __restrict zi, const float* __restrict nr,
                                     const float* __restrict ni, float* __restrict sr, float* __restrict si,
                                     std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    sr[i] += zr[i] * nr[i] - zi[i] * ni[i];
    si[i] += zr[i] * ni[i] + zi[i] * nr[i];
  }
}

// sum /= energy + lambda.
SACCADE_AVX2_CLONE void divide(float* __restrict sr, float* __restrict si, const float* __restrict energy, float lambda,
                               std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    const float scale = 1.0f / (energy[i] + lambda);
    sr[i] *= scale;
    si[i] *= scale;
  }
}

}  // namespace

struct BoxTracker::Impl {
  // `scale_step`: the scale filter's (scale_step_for the given box).
  Impl(const BoxTrackerConfig& c, double scale_step)
      : config(c), window(hann_window(c.patch)), fft(c.patch), scale_filter(c.scales, scale_step, kScaleSide) {
    fft.forward(gaussian_response(c.patch, c.sigma * c.patch / c.padding), target_spectrum);  // set again by init
  }

  // The patch at `p`: a retina level's view of the target and around it.
  void sample(const cv::Mat& frame, const Placement& p, cv::Mat& out) {
    sample_gray(frame, p.center, p.step, p.step, cv::Size(config.patch, config.patch), out, fine, fine_gray, p.angle);
  }

  // The patch's feature channels, windowed, as spectra: gray under local
  // contrast normalisation (as HOG's blocks: each pixel against its
  // neighbourhood's mean and spread, so a shadow or a light falling on part
  // of the target changes little), and the gradient's strength along four
  // directions under the same normalisation.
  void features(const cv::Mat& patch8, std::vector<HalfSpectrum>& out) {
    // One pass over the patch with a border of kReach pixels (reflected, as
    // OpenCV's filters' default border): per row, the 7x7 windows' sums of
    // values and squares (column sums, then along the row) and the 3x3 Sobel
    // derivatives, then the channels.
    constexpr int kReach = 3;
    const int side = patch8.cols, wide = side + 2 * kReach;
    bordered.resize(static_cast<std::size_t>(wide * wide));
    const auto reflect = [side](int i) { return cv::borderInterpolate(i, side, cv::BORDER_REFLECT_101); };
    for (int py = 0; py < wide; ++py) {
      const uchar* row = patch8.ptr<uchar>(reflect(py - kReach));
      float* out_row = &bordered[static_cast<std::size_t>(py * wide)];
      for (int px = 0; px < kReach; ++px) out_row[px] = row[reflect(px - kReach)];
      for (int x = 0; x < side; ++x) out_row[x + kReach] = row[x];
      for (int px = side + kReach; px < wide; ++px) out_row[px] = row[reflect(px - kReach)];
    }
    row_scratch.resize(4 * static_cast<std::size_t>(wide));
    channels.resize(kChannels);
    for (cv::Mat& c : channels) c.create(side, side, CV_32F);
    for (int y = 0; y < side; ++y) {
      float* c[kChannels];
      for (int k = 0; k < kChannels; ++k) c[k] = channels[static_cast<std::size_t>(k)].ptr<float>(y);
      feature_row(&bordered[static_cast<std::size_t>(y * wide)], wide, window.ptr<float>(y), row_scratch.data(), c);
    }
    out.resize(kChannels);
    for (int k = 0; k < kChannels; ++k)
      fft.forward(channels[static_cast<std::size_t>(k)], out[static_cast<std::size_t>(k)]);
  }

  // Model <- (1 - rate) model + rate (this patch's filter): per channel
  // G conj(F), and the channels' summed energy F conj(F). The target stands
  // `offset` patch pixels from the patch's centre: the desired response G is
  // moved there by a phase ramp, so the patch the target was found in is
  // learnt from without sampling it again.
  void learn(const std::vector<HalfSpectrum>& spectra_in, double rate, cv::Point2d offset = {}) {
    shifted_target(offset);
    const HalfSpectrum& target = offset == cv::Point2d() ? target_spectrum : shifted;
    const std::size_t plane = fft.plane();
    if (numerator.size() != spectra_in.size()) {
      numerator.assign(spectra_in.size(), HalfSpectrum{std::vector<float>(plane), std::vector<float>(plane)});
      denominator.assign(plane, 0.0f);
      rate = 1;
    }
    const float a = static_cast<float>(rate), keep = 1.0f - a;
    for (float& d : denominator) d *= keep;
    for (std::size_t c = 0; c < spectra_in.size(); ++c)
      learn_channel(target.re.data(), target.im.data(), spectra_in[c].re.data(), spectra_in[c].im.data(),
                    numerator[c].re.data(), numerator[c].im.data(), denominator.data(), a, keep, plane);
  }

  // The desired response's spectrum moved by `offset` (patch pixels), in `shifted`.
  void shifted_target(cv::Point2d offset) {
    if (offset == cv::Point2d()) return;
    const int side = config.patch, stride = fft.stride(), rows = fft.rows();
    ramp_x.resize(static_cast<std::size_t>(side));
    ramp_y.resize(static_cast<std::size_t>(side));
    for (int u = 0; u < side; ++u) {
      const double f = 2 * CV_PI * (u < side / 2 ? u : u - side) / side;  // signed: a fractional move interpolates
      ramp_x[static_cast<std::size_t>(u)] = std::polar(1.0f, static_cast<float>(-f * offset.x));
      ramp_y[static_cast<std::size_t>(u)] = std::polar(1.0f, static_cast<float>(-f * offset.y));
    }
    shifted.re.assign(fft.plane(), 0.0f);
    shifted.im.assign(fft.plane(), 0.0f);
    for (int kx = 0; kx < side; ++kx)
      for (int ky = 0; ky < rows; ++ky) {
        const std::size_t i = static_cast<std::size_t>(kx * stride + ky);
        const std::complex<float> g(target_spectrum.re[i], target_spectrum.im[i]);
        const std::complex<float> v = g * ramp_x[static_cast<std::size_t>(kx)] * ramp_y[static_cast<std::size_t>(ky)];
        shifted.re[i] = v.real();
        shifted.im[i] = v.imag();
      }
  }

  // The filter's response to `spectra`, and its best peak.
  Peak correlate(const std::vector<HalfSpectrum>& spectra_in) {
    const std::size_t plane = fft.plane();
    sum.re.assign(plane, 0.0f);
    sum.im.assign(plane, 0.0f);
    for (std::size_t c = 0; c < spectra_in.size(); ++c)
      multiply_add(spectra_in[c].re.data(), spectra_in[c].im.data(), numerator[c].re.data(), numerator[c].im.data(),
                   sum.re.data(), sum.im.data(), plane);
    divide(sum.re.data(), sum.im.data(), denominator.data(), static_cast<float>(config.lambda), plane);
    fft.inverse(sum, response);
    cv::Point at;
    double value = 0;
    cv::minMaxLoc(response, nullptr, &value, nullptr, &at);
    const int last = config.patch - 1;
    cv::Point2d sub(at);
    if (at.x > 0 && at.x < last)
      sub.x += peak_vertex<double>(response.at<float>(at.y, at.x - 1), response.at<float>(at),
                                   response.at<float>(at.y, at.x + 1));
    if (at.y > 0 && at.y < last)
      sub.y += peak_vertex<double>(response.at<float>(at.y - 1, at.x), response.at<float>(at),
                                   response.at<float>(at.y + 1, at.x));
    const double c = config.patch / 2;
    double rival = 0;
    const double psr = peak_to_sidelobe(response, at, &rival);
    return {sub - cv::Point2d(c, c), value, psr, rival};
  }

  // The target's look at a coarse step (its larger side kCoarseSide pixels),
  // learnt as the filter is: what the lost target is looked for with over
  // the whole frame, at a cost that does not grow with the target.
  static constexpr double kCoarseSide = 8;
  double coarse_step() const { return std::max(1.0, std::max(size.width, size.height) / kCoarseSide); }

  void learn_appearance(const cv::Mat& frame, double rate) {
    const double s = coarse_step();
    const cv::Size t(std::max(3, static_cast<int>(std::lround(size.width / s))),
                     std::max(3, static_cast<int>(std::lround(size.height / s))));
    coarse_sample.resize(static_cast<std::size_t>(t.area()));
    sample_cell_means(frame, center, s, s, t, coarse_sample.data());
    const cv::Mat fresh(t, CV_32F, coarse_sample.data());
    if (appearance.size() != t || rate >= 1)
      fresh.copyTo(appearance);
    else
      cv::addWeighted(appearance, 1 - rate, fresh, rate, 0, appearance);
  }

  // A re-detection at `found` (peak `psr`, look `p`) elsewhere than where the
  // unsure tracker sits, while its peak there (`sits_psr`) is still trusted:
  // the target is more likely partly hidden there than gone, and a look-alike
  // elsewhere (another pedestrian in dark clothes) peaks about as high. Taken
  // only if clearly better: its peak by the margin, or its colour nearer the
  // target's by the colour tolerance (the tracker sits on a look-alike of
  // another tint) while sharing at least as much of the target's colours as
  // where it sits (`sits_shared`): a target's mean colour can move away
  // from the learnt one while most of its colours are still there (a
  // pedestrian of vtest.avi, doubted: his mean 0.061 from the learnt one,
  // another pedestrian's 0.034, taken for him; their shares of his histogram
  // 0.62 and 0.55); after redetect_margin_frames unsure frames, as any other,
  // unless the peak where it sits still reaches redetect_psr: as high as a
  // find must, the target is doubted there, not gone (vtest.avi's man at
  // 292,189 in frame 420, his peak down from 25-36 to 10-15 in a crowd and his
  // colour flickering about its tolerance: unsure for 16 frames while CSRT
  // agreed where he was, then another man taken; docs/tracking.md).
  // (`sits_shared` is measured here the first time it is needed: negative
  // until then.)
  bool beats_where_it_sits(const cv::Mat& frame, const Placement& p, cv::Point2d found, double psr, double sits_psr,
                           double sits_color_distance, double& sits_shared, double near) {
    const bool margin_over = unsure_frames > config.redetect_margin_frames && sits_psr < config.redetect_psr;
    if (sits_psr <= 0 || margin_over || cv::norm(found - center) < near) return true;
    if (psr >= config.redetect_margin * sits_psr) return true;
    if (!color_checked(config)) return false;
    const double distance = cv::norm(chroma(frame, found, size * (p.step / step), gains) - chroma_mean);
    if (!(distance + config.min_chroma_change <= sits_color_distance)) return false;
    if (sits_shared < 0) sits_shared = shared_colors_at(frame, {center, step, angle}, center);
    return shared_colors_at(frame, p, found) >= sits_shared;
  }

  // Where the lost target may be: the best matches (normalised correlation)
  // of its coarse look over the whole frame seen at the coarse step, at
  // least a target apart; then, `by_color` and while its colour is checked,
  // the best by look and colour together (color_proposals): a target back
  // turned, in other light or partly hidden matches its look less well than
  // things of another colour that share its shape (`holdout_mixed`: a dog's
  // face among round sweets, proposed at its size on none of 12 searches;
  // re-acquired in 24 frames, 11 with its colour). Not while the tracker is
  // only unsure: the target is then most often partly hidden where it sits,
  // and others of its colours were found instead (vtest.avi's pedestrians:
  // 121 -> 143 jumps over 132 runs; 124 asked only while lost; docs/tracking.md);
  // but while it sits on a look-alike (look_elsewhere(): a sure peak of another
  // colour), which takes one of the places by look.
  void propose(const cv::Mat& frame, int count, int reach, std::vector<Placement>& out, bool by_color) {
    if (appearance.empty()) return;
    const double s = coarse_step();
    const cv::Size coarse_size(static_cast<int>(frame.cols / s), static_cast<int>(frame.rows / s));
    if (coarse_size.width < appearance.cols || coarse_size.height < appearance.rows) return;
    // Cell means straight from the frame (OpenCV's INTER_AREA takes over a
    // millisecond for a VGA frame at a step that is not a whole number).
    coarse_f.create(coarse_size, CV_32F);
    sample_cell_means(frame, {frame.cols / 2.0, frame.rows / 2.0}, static_cast<double>(frame.cols) / coarse_size.width,
                      static_cast<double>(frame.rows) / coarse_size.height, coarse_size, coarse_f.ptr<float>());
    by_color = by_color && config.color_proposals > 0 && colors_asked(frame);
    if (by_color) {
      color_likelihood(frame, coarse_size, color_shares, likelihood, likelihood_bins, gains);
      cv::integral(likelihood, likelihood_sum, CV_64F);
    }
    // The target may have grown or shrunk while it was away (come closer,
    // gone further): its look is matched at its size and kOtherSizes[reach],
    // and each place is proposed at its size.
    const std::array<double, 2>& others = kOtherSizes[static_cast<std::size_t>(reach)];
    for (const double factor : {1.0, others[0], others[1]}) {
      if (!size_plausible(step * factor)) continue;
      const cv::Size t(std::max(3, static_cast<int>(std::lround(appearance.cols * factor))),
                       std::max(3, static_cast<int>(std::lround(appearance.rows * factor))));
      if (coarse_size.width < t.width || coarse_size.height < t.height) continue;
      // (Each size's look and scores in buffers that only grow: the sizes change from call to call.)
      resized = reuse(resized_storage, t, CV_32F);
      match = reuse(match_storage, coarse_size - t + cv::Size(1, 1), CV_32F);
      if (factor == 1.0)
        appearance.copyTo(resized);
      else
        cv::resize(appearance, resized, t, 0, 0, cv::INTER_LINEAR);
      // Directly, not by cv::matchTemplate's DFT: a small target's view of a
      // VGA frame is large (a 32 px target's 160x120), where the DFT cost 0.44 ms a size.
      // A window of a quarter of the look's contrast scores 0: normalised, a
      // nearly flat one (a white wall) matched well enough to take one of the
      // places on every search.
      match_template_normed(coarse_f, resized, match, correlation, 0.25);
      const auto place = [&](cv::Point at) {
        const cv::Point2d middle(at.x + t.width / 2.0, at.y + t.height / 2.0);
        out.push_back({{middle.x * frame.cols / coarse_size.width, middle.y * frame.rows / coarse_size.height},
                       step * factor,
                       angle,
                       true});
        cv::rectangle(match, cv::Rect(at - cv::Point(t.width, t.height), t * 2), -1.0, cv::FILLED);
      };
      for (int n = 0; n < count; ++n) {
        cv::Point at;
        double value = 0;
        cv::minMaxLoc(match, nullptr, &value, nullptr, &at);
        if (value <= 0) break;
        place(at);
      }
      for (int n = 0; by_color && n < config.color_proposals; ++n) {
        const cv::Point at = best_by_look_and_color(t);
        if (at.x < 0) break;
        place(at);
      }
    }
  }

  // The placement of `match` (a window of size `t`, already proposed places
  // marked negative) whose correlation times the mean colour likelihood over
  // its central half is highest; (-1, -1) if none is positive.
  cv::Point best_by_look_and_color(cv::Size t) const {
    const cv::Size half(std::max(1, t.width / 2), std::max(1, t.height / 2));
    const int dx = (t.width - half.width) / 2, dy = (t.height - half.height) / 2;
    cv::Point best(-1, -1);
    double best_score = 0;
    for (int y = 0; y < match.rows; ++y) {
      const float* look = match.ptr<float>(y);
      const double* top = likelihood_sum.ptr<double>(y + dy);
      const double* bottom = likelihood_sum.ptr<double>(y + dy + half.height);
      for (int x = 0; x < match.cols; ++x) {
        if (look[x] <= 0) continue;
        const int left = x + dx, right = left + half.width;
        const double color = (bottom[right] - bottom[left] - top[right] + top[left]) / half.area();
        if (look[x] * color > best_score) best_score = look[x] * color, best = {x, y};
      }
    }
    return best;
  }

  Peak look_at(const cv::Mat& frame, const Placement& p) {
    sample(frame, p, patch);
    features(patch, patch_spectra);
    return correlate(patch_spectra);
  }

  // The target may turn in the image: when the peak weakens, or every few
  // frames, the patch is also sampled turned by +-angle_step from the
  // target's angle, and the best peak wins (the current angle by a margin,
  // or noise would make it wobble). The filter then keeps seeing the target
  // as it learnt it. `at` becomes the winning look's placement.
  Peak look_turning(const cv::Mat& frame, Placement& at) {
    Peak peak = look_at(frame, at);
    const bool weaker = peak.psr < config.turn_psr * psr_mean;
    if (config.angle_step <= 0 || !(weaker || ++frames_since_turn_search >= config.turn_search_every)) return peak;
    frames_since_turn_search = 0;
    const Placement straight = at;
    for (const double turn : {-config.angle_step, config.angle_step}) {
      const Placement turned{straight.center, straight.step, straight.angle + turn * CV_PI / 180};
      const Peak other = look_at(frame, turned);
      if (other.value > peak.value * 1.01) peak = other, at = turned;
    }
    follow_turn(at.angle - straight.angle);
    return peak;
  }
  // A target found turned the same way as the last time, at most
  // turn_search_every turn searches before, is most likely still turning: the next
  // frame searches again, and so on while it turns, so the angle keeps up
  // with a turn of up to angle_step a frame, not angle_step every
  // turn_search_every frames. Not after every turn found: a target that
  // does not turn also wins a turned look now and then, by as much, and
  // searched again after each win its angle wandered off (docs/tracking.md,
  // Turning).
  void follow_turn(double turned) {
    if (searches_since_turn_found < std::numeric_limits<int>::max()) ++searches_since_turn_found;
    if (turned == 0) return;
    const int way = turned > 0 ? 1 : -1;
    if (config.follow_turns && way == last_turn_way && searches_since_turn_found <= config.turn_search_every)
      frames_since_turn_search = config.turn_search_every;
    last_turn_way = way;
    searches_since_turn_found = 0;
  }

  BoxTrackerConfig config;
  cv::Mat window;
  RealFft2d fft;
  HalfSpectrum target_spectrum;
  ScaleFilter scale_filter;
  // The target: its centre and size (source pixels), the patch's step for
  // that size, its velocity, how sure the tracker has been.
  cv::Point2d center, velocity;
  cv::Size2d size;
  double step = 1;
  double angle = 0;  // radians: how far the target has turned since it was given
  // The angle the scale filter sees the target at: upright until the target
  // has turned scale_turn_min degrees. The turn search's angle also sways
  // with a target that does not turn (vtest.avi's walking pedestrians: 5
  // degrees on 1,633 of 2,928 tracked frames, 10-15 on 244), and a scale filter
  // following that sway changed pedestrians' paths (docs/tracking.md).
  double scale_angle() const {
    return std::abs(std::remainder(angle, 2 * CV_PI)) * 180 / CV_PI >= config.scale_turn_min - 1e-9 ? angle : 0.0;
  }
  int frames_since_turn_search = 0;
  int last_turn_way = 0;  // the last turn found: 1 or -1 (none yet: 0)
  int searches_since_turn_found = std::numeric_limits<int>::max();
  double psr_mean = 0;  // over the frames the model learnt from
  int tracked_frames = 0;
  int search_tick = 0;
  int low_frames = 0;     // consecutive frames below lost_psr
  int unsure_frames = 0;  // consecutive frames not confident enough to learn from
  // The camera's white balance since the target was given, undone
  // (WhiteBalanceDrift; neutral unless balance_colors): every colour the
  // tracker measures or learns is read through it.
  ChannelGains gains;
  WhiteBalanceDrift white_balance;
  cv::Vec2d chroma_mean;  // of the tracked frames' target
  double chroma_deviation = 0;
  double colourful = 0;            // the share of the target's pixels off gray (colourful_share), over tracked frames
  bool monochrome_camera = false;  // its frames have no colour at all (monochrome(), of the first frame)
  int chroma_frames = 0;
  int untracked_frames = 0;  // since the target was last tracked
  double sure_step = 1;      // the patch's step then
  // Frames since the last re-detection (none yet: the most an int holds).
  int frames_since_found = std::numeric_limits<int>::max();
  // Frames since look_for_size last gave the target a size (none yet: the most an int holds).
  int frames_since_looked = std::numeric_limits<int>::max();
  // The scale filter's factor for the target where it is now, at the angle
  // the filter sees it at, applied to its size and the patch's step.
  double measure_size(const cv::Mat& frame) {
    const double scale = scale_filter.estimate(frame, center, size, scale_angle(), config.lambda);
    size *= scale;
    step *= scale;
    return scale;
  }
  // Just found again elsewhere, the target is seen at the size of the look
  // that found it, the nearest of a few (resize_found), and the scale filter,
  // which learnt it at the size it had before it went, may fit none of its
  // scales to it: its response is flat and it answers its middle scale, and
  // the box then keeps the look's size (`fresh6_mixed`: found again at 0.76
  // of the target's size and held at 0.65-0.75 of it while tracked). On
  // such a tracked frame, for look_size_frames after the re-detection and
  // after each size this gives (a target that came back growing may go on
  // growing faster than the scale filter, learnt at the old size, follows:
  // `mixed_640`), the position's filter, which learns faster, looks at
  // look_size_step times the size and 1 / that, and a peak 1% higher
  // (reaching tracking_psr) gives the target that size and place. Only then:
  // on every flat frame, it claimed more frames off the target
  // (docs/tracking-log.md). Returns whether the size changed. (It overwrites
  // patch_spectra: after learning.)
  bool look_for_size(const cv::Mat& frame, double scale, const Peak& peak) {
    const bool recent = frames_since_found < config.look_size_frames || frames_since_looked < config.look_size_frames;
    if (!recent || scale != 1.0) return false;
    if (scale_filter.flatness() < config.flat_scale) return false;
    Placement best{center, step, angle};
    double bar = peak.value * 1.01;
    for (const double factor : {config.look_size_step, 1 / config.look_size_step}) {
      const Placement p{center, step * factor, angle};
      const Peak other = look_at(frame, p);
      if (other.psr < config.tracking_psr || other.value <= bar) continue;
      best = {p.to_frame(other.offset), p.step, angle}, bar = other.value;
    }
    if (best.step == step) return false;
    place_at(best.center, best.step);
    sure_center = center;
    sure_step = step;
    frames_since_looked = 0;
    return true;
  }
  // Could the target have grown or shrunk to be seen at patch step `at_step`
  // since it was last tracked?
  bool size_plausible(double at_step) const {
    if (config.max_size_change <= 0) return true;
    const double reach = std::log1p(config.max_size_change) * untracked_frames;  // >= 1: update() counted this frame
    return std::abs(std::log(at_step / sure_step)) <= reach + 1e-9;
  }
  // Consecutive frames whose peak was under the usual one but sure otherwise
  // (over tracking_psr, unrivalled, of the target's colour while that is
  // checked), and their sum. Any other frame, or a re-detection, ends them.
  int lower_frames = 0;
  double lower_psr_sum = 0;
  // After warmup_frames such frames, the usual peak is the target's old
  // look's (it came back larger, it turned for good): it is made anew from
  // them, and the frame is tracked (and learnt from). Not from peaks that
  // would not have re-detected the target (their mean under redetect_psr):
  // those were an occluder's edge or the background the unsure tracker
  // drifted onto, and made the new usual peak, the tracker claimed them for
  // the rest of the sequence (fresh sets' `occlusion`, `mixed`: over the
  // tracking benchmark's 546 runs, 7 of the 15 re-bases off the target were
  // under it, none of the 68 on it; docs/tracking.md). Nor unless
  // `may_settle` (doubted_for_a_lower_peak()).
  bool settled_lower(const BoxTrackerConfig& c, double psr, bool may_settle) {
    lower_psr_sum += psr;
    if (++lower_frames < c.warmup_frames) return false;
    if (!may_settle || lower_psr_sum / lower_frames < c.redetect_psr) {
      forget_lower();
      return false;
    }
    psr_mean = lower_psr_sum / lower_frames;
    forget_lower();
    return true;
  }
  void forget_lower() { lower_frames = 0, lower_psr_sum = 0; }
  // A re-detection's looks, in order: the last frame's candidate (a
  // re-detection must hold on consecutive frames at one place); the local
  // look; on every other frame the whole-frame search's proposals (it costs
  // as much as the rest of the frame, and a candidate it found is confirmed
  // locally meanwhile), on the others, lost and following the target's
  // colours, the local look at that search's other sizes. Returns the local
  // looks' range.
  std::pair<std::size_t, std::size_t> gather_looks(const cv::Mat& frame, cv::Point2d predicted, bool unsure,
                                                   bool by_color) {
    looks.clear();
    if (candidate_frames > 0) looks.push_back({candidate, candidate_step, angle});
    const std::size_t local = looks.size();
    const bool follow_colors = !unsure && lost_look_moved;
    looks.push_back({follow_colors ? lost_look : predicted, step, angle});
    const int sizes = (search_tick / 2) % 3;
    const bool search = search_tick++ % 2 == 0;
    if (search)
      propose(frame, config.proposals, sizes, looks, by_color);
    else if (follow_colors)
      for (const double factor : kOtherSizes[static_cast<std::size_t>(sizes)])
        if (size_plausible(step * factor)) looks.push_back({lost_look, step * factor, angle});
    return {local, search ? local + 1 : looks.size()};
  }
  // Each of `looks`' peaks into look_peaks, the strongest into `strongest`.
  const std::vector<Peak>& look_at_all(const cv::Mat& frame, Peak& strongest) {
    look_peaks.clear();
    for (const Placement& p : looks) {
      look_peaks.push_back(look_at(frame, p));
      if (look_peaks.back().psr > strongest.psr) strongest = look_peaks.back();
    }
    return look_peaks;
  }
  // Where the unsure tracker sits (its peak `sits_psr`, 0: not trusted), the
  // target may show better at another size (it came nearer): the best peak
  // the looks found there is what a find elsewhere must beat (vtest.avi: a
  // pedestrian at 7.4 where he sat, 10.9 there at 1.25x his size, and another
  // man 100 px away at 11.4 was taken for him).
  double best_where_it_sits(double sits_psr, double near) const {
    if (sits_psr <= 0) return sits_psr;
    for (std::size_t i = 0; i < looks.size(); ++i)
      if (cv::norm(looks[i].to_frame(look_peaks[i].offset) - center) < near)
        sits_psr = std::max(sits_psr, look_peaks[i].psr);
    return sits_psr;
  }
  // Unsure, the tracker sits on a peak too weak to track (`sits_psr`, at the
  // target's size): the target may have come nearer, and its look at this
  // size fits it less every frame. A look near it at a larger size that peaks
  // resize_ratio times as high (and reaches redetect_psr, of the target's
  // colours and tones, at a size it could have grown to) gives the target
  // that size and place; it stays unsure, and the next frames look at it at
  // that size (fresh5 `mixed` from its second first box: the orange back from
  // behind its occluder at 1.6 times the size the tracker sat on it at,
  // peaking at 8 there and at 12.8 at 1.56 times, doubted for 44 frames).
  // Never a smaller size: a smaller look peaks higher on the part of a target
  // an occluder still half hides, and the box then stays that small
  // (`fresh4_fast_640` through a JPEG: 0.8 of the face for 150 frames, AUC
  // 0.888 -> 0.740; docs/tracking.md).
  void follow_size_where_it_sits(const cv::Mat& frame, double sits_psr, double near) {
    if (config.resize_ratio <= 0 || sits_psr <= 0) return;
    std::size_t pick = looks.size();
    double bar = resize_bar(sits_psr);
    for (std::size_t i = 0; i < looks.size(); ++i) {
      const Placement& p = looks[i];
      const cv::Point2d found = p.to_frame(look_peaks[i].offset);
      if (p.step / step - 1 < kSameSize || look_peaks[i].psr < bar || cv::norm(found - center) >= near) continue;
      if (!size_plausible(p.step) || !has_its_colors(frame, p, found)) continue;
      pick = i, bar = look_peaks[i].psr;
    }
    if (pick == looks.size()) return;
    place_at(looks[pick].to_frame(look_peaks[pick].offset), looks[pick].step);
  }
  // The peak a look at another size must reach to give the target that size,
  // against `psr` at the size it has: resize_ratio times it, and redetect_psr.
  // (A ratio under 1 counts as 1: a larger look that peaks lower is no sign the target grew.)
  double resize_bar(double psr) const {
    return std::max(config.redetect_psr, std::max(1.0, config.resize_ratio) * psr);
  }
  // A re-detection is seen at the nearest of the few sizes its look was
  // taken at (the whole-frame search's, 0.51-1.95 times the target's), and
  // the scale filter, whose 17 scales span 0.85-1.17, does not make up the
  // rest: a box found at the wrong size kept it (`holdout_mixed_640`: the
  // butterfly back from behind an occluder found at 0.64 of its size by a
  // proposal by colour, and 60 frames at that size). A find elsewhere is
  // looked at the other sizes too, and one whose peak is resize_ratio times
  // as high (and reaches redetect_psr, of the target's colours and tones, at
  // a size it could have grown to) gives the size, as follow_size_where_it_sits()
  // does for a target seen larger where it sits. Smaller, not below the
  // size the target was last tracked at: a smaller look peaks higher on the
  // part of a target an occluder still half hides, and the box stayed that
  // small (follow_size_where_it_sits()). (Taking a smaller size at as high a
  // peak between the find's and the target's last, a target back larger was
  // found at its old size: `fresh7_mixed_640` success@0.5 0.441 -> 0.363.)
  void resize_found(const cv::Mat& frame, cv::Point2d& found, double& at_step, double psr, double near) {
    if (config.resize_ratio <= 0) return;
    const Placement from{found, at_step, angle};
    const double smallest = std::min(at_step, sure_step) * (1 - kSameSize);
    double bar = resize_bar(psr);
    for (const std::array<double, 2>& factors : kOtherSizes)
      for (const double factor : {factors[0], 1 / factors[0]}) {
        const Placement p{from.center, from.step * factor, angle};
        if (!size_plausible(p.step) || p.step < smallest) continue;
        const Peak peak = look_at(frame, p);
        const cv::Point2d at = p.to_frame(peak.offset);
        if (peak.psr < bar || cv::norm(at - from.center) >= near || !has_its_colors(frame, p, at)) continue;
        found = at, at_step = p.step, bar = peak.psr;
      }
  }
  // The box at `found`, at the size a look of patch step `at_step` sees the target at.
  void place_at(cv::Point2d found, double at_step) {
    center = found;
    size *= at_step / step;
    step = at_step;
  }
  // Within redetect_near times the target's larger side of where it was last tracked?
  bool near_where_tracked(cv::Point2d found) const {
    return cv::norm(found - sure_center) < config.redetect_near * std::max(size.width, size.height);
  }
  // A re-detection confirmed at `found`, seen at patch step `at_step`.
  // (Not the size the target was last tracked at, sure_step: what is found
  // may be another object, and the size limit stays measured from the target.)
  void found_at(cv::Point2d found, double at_step, bool elsewhere) {
    lost_look_moved = false;
    // Found again where the tracker sits, the target is confirmed there, and
    // the frames that measure its size while doubted (measure_size) do not start
    // over: `mixed_640`'s butterfly, re-found every fourth frame under a box
    // 1.5x its size and off its centre, had the box grown on the frames
    // between (success@0.5 0.765 -> 0.679 from the true first box).
    if (elsewhere) frames_since_found = 0;
    place_at(found, at_step);  // found at another size
    sure_center = found;
    velocity = {};
    low_frames = unsure_frames = candidate_frames = 0;
    forget_lower();  // what is found may be another object
  }
  // The colour is checked once it is known, and until the target has been
  // away so long that it may come back in another light; and only if the
  // target has colours to check (kMinColourful of its pixels off gray): in a
  // monochrome camera's frames every place is of its colour, and the checks
  // that let a find of its colour in under the bars let anything in
  // (`--gray` in the tracking benchmark: honest lost 0.21-0.96 on the
  // generated sequences with hidden frames, docs/tracking.md).
  bool color_checked(const BoxTrackerConfig& c) const {
    return chroma_frames >= c.warmup_frames && !back_in_other_light() && colourful >= kMinColourful;
  }
  // Away long enough (color_patience frames) that the target may come back
  // in another light: its learnt colours and tones no longer tell it.
  bool back_in_other_light() const { return untracked_frames >= config.color_patience; }
  bool color_matches(const BoxTrackerConfig& c, double distance) const {
    return !color_checked(c) || distance <= std::max(c.min_chroma_change, c.chroma_deviations * chroma_deviation);
  }
  // Where the colour of a look `p` that found the target at `found` is
  // measured (the box's central half, the box at the look's size): where the
  // filter peaks and, at a place the whole-frame search proposed larger than
  // the target (it came nearer while hidden), where that search centred it:
  // the filter knows the target smaller and peaks on a part of it (`mixed`:
  // 9-13 px above the orange's centre, whose colour there was 0.08 from the
  // learnt one; re-acquired 20-25 frames after it reappeared in three runs of
  // six, 13-14 now). (At proposals of every size, a spot of background of the
  // target's colour was taken while it was hidden.) The nearer of the two
  // colours counts.
  struct ColorPlaces {
    std::array<cv::Point2d, 2> at;
    int count;
    cv::Size2d box;
  };
  ColorPlaces color_places(const Placement& p, cv::Point2d found) const {
    return {{found, p.center}, p.proposed && p.step > step ? 2 : 1, size * (p.step / step)};
  }
  // Is a look of the target's colour (while that is checked), enough to let
  // a find under the bar in near where the target was last tracked?
  bool of_its_colour(const cv::Mat& frame, const Placement& p, cv::Point2d found) {
    // A target without colours (a monochrome camera's) has its tones to
    // tell it by, a weaker witness: most of them (near_shared_tones), until
    // it may have come back in other light, as its colour would lapse.
    if (without_colours() && !back_in_other_light())
      return config.near_shared_tones > 0 && shared_tones_at(frame, p, found) >= config.near_shared_tones;
    if (!color_checked(config)) return false;
    const ColorPlaces places = color_places(p, found);
    double distance = INFINITY;
    for (int k = 0; k < places.count; ++k)
      distance = std::min(distance, cv::norm(chroma(frame, places.at[k], places.box, gains) - chroma_mean));
    return color_matches(config, distance) && has_its_colors(frame, p, found);
  }
  // Are enough of a look's colours the target's (min_shared_colors, while
  // its colour is checked), and of its tones (min_shared_tones, always)?
  // Asked of every re-detection, also a sure one: the mean colour of a
  // target partly hidden moves as far as a tinted look-alike's, and so it is
  // not asked of a sure peak; the histograms tell them apart
  // (docs/tracking.md).
  bool has_its_colors(const cv::Mat& frame, const Placement& p, cv::Point2d found) {
    return shared_colors_at(frame, p, found) >= config.min_shared_colors &&
           shared_tones_at(frame, p, found) >= config.min_shared_tones;
  }
  // How much of the target's tone histogram (its gray relative to its mean,
  // tone_histogram) a look shares, asked of every re-detection once the
  // target was tracked warmup_frames; 1 where not asked. The gray
  // counterpart of the colours, and asked with them too: it tells a
  // textured target from flat background or from a look-alike of other
  // contrast, which a monochrome camera's frames have nothing else to tell
  // by (`--gray`: `fast_640`'s background taken while the target was away,
  // precision 0.629 -> 0.911), and in colour it is a second check beside
  // the chromaticity, which people in dark clothes pass for each other
  // (vtest.avi's pedestrians: 122 -> 95 jumps over 132 runs;
  // docs/tracking.md). An area too dark for tones is no evidence either way.
  double shared_tones_at(const cv::Mat& frame, const Placement& p, cv::Point2d found) {
    if (config.min_shared_tones <= 0 || empty(tone_shares) || tracked_frames < config.warmup_frames) return 1.0;
    return shared_at(frame, p, found, tone_histogram, tone_shares);
  }
  // Under the tracked frames' usual peak (an occluder's edge, a look-alike
  // passing over it) a frame sure otherwise is not sure either, unless it has
  // stayed there long enough to be the target's new usual peak. Sure
  // otherwise includes, in colour, the target's colour (follow() doubts a
  // peak of another colour); a target without colours (a monochrome
  // camera's) must share its tones there as a re-detection must, or the
  // count starts again: nothing else told an occluder or the background the
  // tracker slid onto, peaking lower for ten frames, from the target's new
  // look, and it was learnt (`--gray`: `mixed_640@gray` precision 0.425 ->
  // 0.836, honest lost 0.78 -> 1.00; docs/tracking.md). Asked of every
  // tracked frame instead, the tones lost OTB Car4 in plain view. In a
  // monochrome camera's frames, the frame that would make the lower peak the
  // usual one asks most of them (near_shared_tones), as a find near where
  // the target went must: settling is a lower bar too, and an occluder the
  // unsure tracker slid onto, or the background where a target left the
  // view, shared six tenths and was claimed for up to 124 frames (`--gray
  // --runs 6`: false-lock frames 1,423 -> 600). Tones tell the two apart
  // poorly: 20 of the 26 wrong settles were refused, and 71 of the 101 right
  // ones, whose target then stays unsure until it is found again. Not in a
  // colour camera's: its few colourless targets (faces) were re-acquired
  // later with it (`fresh4_occlusion` 13 -> 17 frames) and gained little
  // (docs/tracking-log.md, fifth session of 2026-12-03).
  bool doubted_for_a_lower_peak(const cv::Mat& frame, const Placement& at, cv::Point2d measured, double psr) {
    if (tracked_frames < config.warmup_frames || psr >= config.relative_psr * psr_mean) {
      forget_lower();
      return false;
    }
    if (!without_colours()) return !settled_lower(config, psr, /*may_settle=*/true);
    const double tones = shared_tones_at(frame, at, measured);
    if (tones < config.min_shared_tones) {
      forget_lower();
      return true;
    }
    return !settled_lower(config, psr, /*may_settle=*/!monochrome_camera || tones >= config.near_shared_tones);
  }
  static bool empty(const std::vector<float>& shares) {
    return std::all_of(shares.begin(), shares.end(), [](float share) { return share == 0.f; });
  }
  // Are a look's colours evidence here (a colour frame, a target with
  // colours, its colour still checked)?
  bool colors_asked(const cv::Mat& frame) const {
    return config.min_shared_colors > 0 && frame.channels() >= 3 && !empty(color_shares) && color_checked(config);
  }
  // Is the target known to have no colours to check, but tones (a gray
  // target, a monochrome camera's frames)?
  bool without_colours() const {
    return config.min_shared_tones > 0 && chroma_frames >= config.warmup_frames && colourful < kMinColourful &&
           !empty(tone_shares);
  }
  // How much of the target's chromaticity histogram a look shares; 1 where
  // that is not asked. A gray frame, or a target (or a place) too dark for
  // any colour, has an empty histogram: no evidence either way, and the look
  // is not refused.
  double shared_colors_at(const cv::Mat& frame, const Placement& p, cv::Point2d found) {
    const auto histogram = [this](const cv::Mat& f, cv::Rect area, std::vector<float>& shares) {
      chroma_histogram(f, area, shares, gains);
    };
    return colors_asked(frame) ? shared_at(frame, p, found, histogram, color_shares) : 1.0;
  }
  // How much of a `learnt` histogram (`histogram`'s) a look shares, at the
  // better of its colour places; a place with an empty one shares all.
  template <typename Histogram>
  double shared_at(const cv::Mat& frame, const Placement& p, cv::Point2d found, const Histogram& histogram,
                   const std::vector<float>& learnt) {
    const ColorPlaces places = color_places(p, found);
    double shared = 0;
    for (int k = 0; k < places.count; ++k) {
      histogram(frame, central_half(frame, places.at[k], places.box), candidate_shares);
      shared = std::max(shared, empty(candidate_shares) ? 1.0 : shared_colors(candidate_shares, learnt));
    }
    return shared;
  }
  // A tracked frame's colour (`color`, `distance` from the mean; its
  // histogram measured at `at`). Away so long that it may be back in
  // another light, the target's colour is learnt afresh.
  void learn_color(const BoxTrackerConfig& c, const cv::Mat& frame, cv::Point2d at, cv::Vec2d color, double distance) {
    if (back_in_other_light()) chroma_frames = 0;
    untracked_frames = 0;
    const bool fresh = chroma_frames++ == 0;
    // (Measured against the old mean, a fresh start's distance is no deviation.)
    if (fresh) chroma_mean = color, chroma_deviation = 0, distance = 0;
    chroma_deviation = 0.95 * chroma_deviation + 0.05 * distance;
    chroma_mean = 0.95 * chroma_mean + 0.05 * color;
    const cv::Rect inner = central_half(frame, at, size);
    const double share = colourful_share(frame, inner, c.min_chroma_change, gains);
    colourful = fresh ? share : 0.95 * colourful + 0.05 * share;
    // The tones are never learnt afresh: relative to the mean, they do not
    // change with a brighter or dimmer light. A frame too dark for tones
    // teaches nothing (blended in, its empty histogram would wear the learnt
    // one down under the bar).
    if (c.min_shared_tones > 0) {
      tone_histogram(frame, inner, candidate_shares);
      if (!empty(candidate_shares)) learn_shares(tone_shares, candidate_shares, false);
    }
    if (c.min_shared_colors <= 0) return;
    chroma_histogram(frame, inner, candidate_shares, gains);
    learn_shares(color_shares, candidate_shares, fresh);
  }
  // A histogram learnt over tracked frames, as the mean colour is.
  static void learn_shares(std::vector<float>& learnt, const std::vector<float>& seen, bool fresh) {
    if (fresh || learnt.empty()) learnt = seen;
    for (std::size_t i = 0; i < learnt.size(); ++i) learnt[i] = 0.95f * learnt[i] + 0.05f * seen[i];
  }
  // Lost, the local look stays where the target was lost, unless the
  // target's colours show near there: it then moves to the best of its peaks
  // that shares follow_lost_colors of them, and on the frames between the
  // whole-frame searches also looks there at the search's other two sizes. A
  // target hidden by something passing comes back near where it went, often
  // nearer, turned or in other light, and the filter's peak on it off the
  // look's centre, under its window, or at the wrong size stays under the bars
  // (make bench-track's holdout_mixed: 3.5-3.8 on the target 40 px from where
  // it was lost, 1.2-1.6x larger, its colours shared 0.73-0.85, for 40 frames);
  // followed there, it reaches them. A target without colours (a monochrome
  // camera's) is followed by its tones instead, as much of them as a
  // re-detection must share (`holdout_mixed` in gray: re-acquired in 12
  // frames instead of 41); not a target away so long that its colour is no
  // longer checked: the look then followed an occluder's or the background's
  // peaks and found a look-alike.
  void follow_lost_colors(const cv::Mat& frame, const std::vector<Placement>& at, const std::vector<Peak>& peaks,
                          std::size_t first, std::size_t end) {
    lost_look_moved = false;
    const bool by_colours = colors_asked(frame), by_tones = !by_colours && without_colours();
    if (config.follow_lost_colors <= 0 || !(by_colours || by_tones)) return;
    double best = 0;
    for (std::size_t i = first; i < end; ++i) {
      const cv::Point2d found = at[i].to_frame(peaks[i].offset);
      if (peaks[i].psr <= best || !near_where_tracked(found) ||
          (by_tones ? shared_tones_at(frame, at[i], found) < config.min_shared_tones
                    : shared_colors_at(frame, at[i], found) < config.follow_lost_colors))
        continue;
      best = peaks[i].psr, lost_look = found, lost_look_moved = true;
    }
  }
  // The camera moved the image by `shift` (a head turn): every place kept
  // in the frame's pixels moves with it, also while the target is hidden or
  // lost (where it was last tracked, where its colours were seen, a
  // re-detection waiting for confirmation), not only the next prediction.
  void camera_moved(cv::Point2d shift) {
    center += shift, sure_center += shift, lost_look += shift, candidate += shift;
    told += shift;
  }
  // Where a target no longer tracked can be by now: its image moves with the
  // camera and by itself. The camera's moves are told (camera_moved: a
  // head's turns) or seen: the image's move from the first frame the target
  // was not tracked on is measured (view_motion, over a coarse view of the
  // whole frame) until it is tracked again, which takes in a hand-held
  // camera's turns and the told ones alike. It is measured on the frames
  // that ask for it (a find elsewhere weighed, the target leaving the view)
  // and at least every ViewMotion::kMaxGap frames (a long pan followed).
  ViewMotion view_motion;
  cv::Point2d told;              // the camera's told moves since the target was last tracked ...
  cv::Point2d told_before_view;  // ... of which before view_motion's reference frame
  bool view_changed = false;     // since, the view became another (a cut): the target may be anywhere until tracked
  const cv::Mat* unmeasured = nullptr;  // this frame, while not yet measured
  int frames_unmeasured = 0;            // frames since the last measurement
  void measure_view() {
    if (unmeasured == nullptr) return;
    view_motion.measure(*unmeasured);
    unmeasured = nullptr;
    frames_unmeasured = 0;
    if (view_motion.lost() && !view_changed) view_changed = true, exit_axis = -1;
  }
  // The image's move since the target was last tracked (told only until measured).
  cv::Point2d image_moved() {
    measure_view();
    return view_motion.measuring() ? told_before_view + view_motion.shift() : told;
  }
  // Before a frame, the last one not tracked: its move to be measured.
  void follow_view(const cv::Mat& frame, bool tracked) {
    if (tracked || !view_motion.started()) return;
    unmeasured = &frame;
    if (++frames_unmeasured >= ViewMotion::kMaxGap) measure_view();
  }
  // After a frame: tracked, the measurement starts over from the next frame
  // not tracked; not tracked, the first such frame is the reference.
  void after_frame(const cv::Mat& frame, bool tracked) {
    unmeasured = nullptr;
    if (tracked) {
      view_motion.reset();
      frames_unmeasured = 0;
      told = told_before_view = exit_moved = {};
    } else if (!view_motion.started()) {
      view_motion.measure(frame);
      told_before_view = told;
    }
  }
  // A target not tracked for a few frames is most often still near where it
  // was, the camera's move added: partly hidden, or changed. Somebody like
  // it elsewhere peaks as high as the target partly hidden does, and was
  // taken for it (vtest.avi's pedestrians: 6 of the 8 jumps of the 22 runs
  // went to people 133-251 px away 3-9 frames after the target was last
  // tracked; over 132 runs 68 jumps, 30 with this; docs/tracking.md). So a find
  // elsewhere must lie within the target's size of where it was last
  // tracked, moved with the image, plus reach_speed of its size per frame
  // since, unless it peaks nearly as high as the target's tracked frames
  // usually do (a move the view's measurement missed).
  bool within_reach(cv::Point2d found, double psr) {
    if (config.reach_speed <= 0 || view_changed || psr >= kReachUsualShare * psr_mean) return true;
    const cv::Point2d expected = sure_center + image_moved() - told;  // (sure_center moved with the told moves)
    const double grow = 1 + config.reach_speed * untracked_frames;
    return std::abs(found.x - expected.x) <= size.width * grow && std::abs(found.y - expected.y) <= size.height * grow;
  }
  // (The whole usual peak, not this share of it, kept graphs/tracking.xml's
  // target, which jumps where no target could, from being found for 31
  // frames: its finds peaked 19.8-25.1 about a usual 22.2. Over the 132
  // pedestrians' runs 30 jumps at this share, 28 at the whole.)
  static constexpr double kReachUsualShare = 0.9;

  // A target whose centre left the frame (a pedestrian walking out of view,
  // the camera turning away) can only come back across the border it left
  // by, as far in as the camera has turned back towards it since and its
  // own motion could carry it: a find further in is another object
  // (vtest.avi: 8 of the 13 jumps of the 22 pedestrians' runs went to other
  // people 100-440 px from the border their target had just crossed;
  // docs/tracking.md).
  int exit_axis = -1;      // 0: across the left or right border, 1: the top or bottom; -1: in view
  int exit_sign = 1;       // +1: the border at 0 (left, top), -1: the far one
  double exit_border = 0;  // that border's coordinate
  cv::Point2d exit_moved;  // image_moved() then
  int frames_out = 0;      // frames since
  // Before a frame: has the target (where the tracker put it on the last
  // frame, `tracked` there or not) left the frame?
  void watch_exit(const cv::Mat& frame, bool tracked) {
    if (exit_axis >= 0) ++frames_out;
    if (tracked) view_changed = false;
    if (!tracked && (exit_axis >= 0 || view_changed)) return;
    const double over_x = std::max(-center.x, center.x - frame.cols) / size.width;
    const double over_y = std::max(-center.y, center.y - frame.rows) / size.height;
    if (std::max(over_x, over_y) <= 0) {
      if (tracked) exit_axis = -1;
      return;
    }
    const cv::Point2d moved = image_moved();
    if (!tracked && view_changed) return;  // (found so by that measurement)
    exit_moved = moved;
    exit_axis = over_x >= over_y ? 0 : 1;
    const double at = exit_axis == 0 ? center.x : center.y;
    exit_sign = at < 0 ? 1 : -1;
    exit_border = at < 0 ? 0.0 : (exit_axis == 0 ? frame.cols : frame.rows);
    frames_out = 0;
  }
  // Could a target that left the view be back at `found`?
  bool may_be_back_at(cv::Point2d found) {
    if (exit_axis < 0 || config.reentry_speed <= 0) return true;
    const double side = exit_axis == 0 ? size.width : size.height;
    const cv::Point2d moved = image_moved() - exit_moved;
    const double camera_back = exit_sign * (exit_axis == 0 ? moved.x : moved.y);
    const double inwards = exit_sign * ((exit_axis == 0 ? found.x : found.y) - exit_border);
    return inwards <= side + camera_back + frames_out * config.reentry_speed * side;
  }
  cv::Point2d lost_look;                // where the lost target's colours were last seen near where it was lost ...
  bool lost_look_moved = false;         // ... if they were on the last frame
  std::vector<float> color_shares;      // the tracked frames' chromaticity histogram (min_shared_colors only)
  std::vector<float> tone_shares;       // the tracked frames' tone histogram (min_shared_tones only)
  std::vector<float> candidate_shares;  // scratch: a frame's or a re-detection's
  cv::Mat appearance;                   // CV_32F, the target at the coarse step
  std::vector<float> coarse_sample;
  cv::Mat coarse_f, resized, match, resized_storage, match_storage;
  cv::Mat likelihood, likelihood_sum;  // the coarse view's colour likelihood (CV_32F) and its integral
  std::vector<int> likelihood_bins;
  CorrelationScratch correlation;
  cv::Point2d candidate{-1, -1};  // lost: a re-detection waiting for confirmation, and its step
  double candidate_step = 1;
  std::vector<Placement> looks;
  std::vector<Peak> look_peaks;  // each look's peak, in looks' order
  int candidate_frames = 0;
  bool candidate_coloured = false;      // let in under the bar: near where the target was, of its colour
  cv::Point2d sure_center;              // where the target was last tracked
  std::vector<HalfSpectrum> numerator;  // per channel
  std::vector<float> denominator;       // the channels' summed energy, per frequency (RealFft2d's layout)
  // Scratch, kept between frames so that steady state allocates little.
  cv::Mat fine, fine_gray, patch, response;
  std::vector<float> bordered, row_scratch;
  HalfSpectrum sum, shifted;
  std::vector<std::complex<float>> ramp_x, ramp_y;
  std::vector<cv::Mat> channels;
  std::vector<HalfSpectrum> patch_spectra;
};

// Where the unsure tracker sits: its peak (0: none trusted), that place's
// colour distance from the target's, and whether it is a look-alike: a peak
// as sure as a re-detection's whose colour is off the target's by more than
// follow() lets a tracked frame's be.
struct BoxTracker::UnsurePlace {
  double psr = 0;
  double color_distance = 0;
  bool look_alike = false;
};

BoxTracker::BoxTracker(BoxTrackerConfig config)
    : config_(config), impl_(std::make_shared<Impl>(config, config.scale_step)) {}

namespace {

const cv::Mat& to_gray(const cv::Mat& frame, cv::Mat& scratch) {
  if (frame.channels() == 1) return frame;
  cv::cvtColor(frame, scratch, frame.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return scratch;
}

// Does the camera see no colour (a monochrome camera's frames: one channel, or
// three equal ones, as a gray image file reads)? Asked of a grid of pixels
// of the first frame: a colour camera's noise makes some of them unequal.
bool monochrome(const cv::Mat& frame) {
  if (frame.channels() < 3) return true;
  constexpr int kGrid = 8;
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const int x = (2 * i + 1) * frame.cols / (2 * kGrid), y = (2 * j + 1) * frame.rows / (2 * kGrid);
      const uint8_t* pixel = frame.ptr<uint8_t>(y) + static_cast<std::ptrdiff_t>(x) * frame.channels();
      if (pixel[0] != pixel[1] || pixel[1] != pixel[2]) return false;
    }
  return true;
}

std::string describe(cv::Rect2d b) {
  char text[96];
  std::snprintf(text, sizeof text, "%g,%g,%g,%g", b.x, b.y, b.width, b.height);
  return text;
}

// The scale filter's step for a target given as `box`: scale_step, or more
// for a small target, whose scales 2% apart differ by a fraction of a pixel
// that the filter's cell means barely see (it kept answering 1 while a 21 px
// face grew to 41: `holdout_mixed` at half the size, docs/tracking.md). Its
// steps then move the larger side by scale_step_pixels.
double scale_step_for(const BoxTrackerConfig& c, cv::Rect2d box) {
  const double larger = std::max(box.width, box.height);
  return c.scale_step_pixels > 0 ? std::max(c.scale_step, 1 + c.scale_step_pixels / larger) : c.scale_step;
}

std::string describe(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

}  // namespace

Status BoxTracker::init(const cv::Mat& frame, cv::Rect2d box) {
  if (frame.empty() || frame.depth() != CV_8U) return Status::error("the frame must be an 8-bit image");
  const cv::Rect2d inside = box & cv::Rect2d(0, 0, frame.cols, frame.rows);
  if (!(box.width >= config_.min_target && box.height >= config_.min_target))
    return Status::error("box " + describe(box) + " is smaller than the smallest target, " +
                         describe(config_.min_target) + " pixels a side");
  if (inside.area() < 0.5 * box.area())
    return Status::error("box " + describe(box) + " lies mostly outside the " + std::to_string(frame.cols) + "x" +
                         std::to_string(frame.rows) + " frame");
  cv::Mat scratch;
  cv::Scalar mean, sd;
  cv::meanStdDev(to_gray(frame(cv::Rect(inside)), scratch), mean, sd);  // the box alone: is it flat?
  if (sd[0] < 2)
    return Status::error("box " + describe(box) + " is flat (gray deviation " + std::to_string(sd[0]) +
                         "): nothing to follow");
  // Only a box that will be followed replaces what the tracker had.
  Impl& m = *impl_;
  m = Impl(config_, scale_step_for(config_, box));
  m.center = m.sure_center = {box.x + box.width / 2, box.y + box.height / 2};
  m.size = box.size();
  m.monochrome_camera = monochrome(frame);
  // A small target is not magnified: the patch then covers more than
  // `padding` times it, which also widens the search around a fast one.
  m.step = m.sure_step = std::max(1.0, config_.padding * std::max(box.width, box.height) / config_.patch);
  m.fft.forward(gaussian_response(config_.patch, config_.sigma * std::max(box.width, box.height) / m.step),
                m.target_spectrum);
  m.sample(frame, {m.center, m.step}, m.patch);
  m.features(m.patch, m.patch_spectra);
  m.learn(m.patch_spectra, 1.0);
  m.learn_appearance(frame, 1.0);
  m.scale_filter.learn(frame, m.center, m.size, 0.0, 1.0, true);
  if (config_.balance_colors) m.white_balance.update(frame);  // the colours' reference frame
  camera_shift_ = {};
  initialized_ = true;
  last_ = {box, 0, TrackState::kTracking};
  return {};
}

TrackEstimate BoxTracker::update(const cv::Mat& frame) {
  // (A frame under 2x2 has no pixel pairs to interpolate between, one not 8-bit
  // no pixels the reads know: nothing to look at.)
  if (!initialized_ || frame.rows < 2 || frame.cols < 2 || frame.depth() != CV_8U) return last_;
  Impl& m = *impl_;
  const cv::Point2d shift = camera_shift_;
  camera_shift_ = {};
  ++m.untracked_frames;  // follow() zeroes it on a tracked frame
  if (m.frames_since_found < std::numeric_limits<int>::max()) ++m.frames_since_found;
  if (m.frames_since_looked < std::numeric_limits<int>::max()) ++m.frames_since_looked;
  const bool was_tracked = last_.state == TrackState::kTracking;
  if (config_.balance_colors) {
    // Lost, the target's colours were learnt before it went, however long
    // ago: the balance holds the whole change since (uncertain frames still
    // forget: the box sits on the target, and a view drifting across a
    // scene's colours, as `rotation`'s does, is measured as a drift that
    // only forgetting bounds; held there too, rotation@wb0.2 fell from 0.950
    // to 0.331, docs/tracking-log.md).
    m.white_balance.update(frame, /*forget=*/last_.state != TrackState::kLost);
    m.gains = m.white_balance.gains();
  }
  m.camera_moved(shift);
  m.follow_view(frame, was_tracked);
  m.watch_exit(frame, was_tracked);
  const cv::Point2d predicted = m.center + m.velocity;
  if (last_.state == TrackState::kLost)
    redetect(frame, predicted, /*unsure=*/false, {});
  else
    follow(frame, predicted);
  m.after_frame(frame, last_.state == TrackState::kTracking);
  last_.box = cv::Rect2d(m.center.x - m.size.width / 2, m.center.y - m.size.height / 2, m.size.width, m.size.height);
  return last_;
}

void BoxTracker::follow(const cv::Mat& frame, cv::Point2d predicted) {
  Impl& m = *impl_;
  Placement at{predicted, m.step, m.angle};
  const Peak peak = m.look_turning(frame, at);
  const double psr = peak.psr;
  last_.confidence = psr;
  if (psr < config_.lost_psr) {
    // Too weak to trust even the position: coast on the prediction.
    m.velocity *= 0.8;
    m.center = predicted;
    m.forget_lower();
    ++m.unsure_frames;
    last_.state = ++m.low_frames >= config_.lost_frames || m.unsure_frames >= config_.unsure_frames
                      ? TrackState::kLost
                      : TrackState::kUncertain;
    look_elsewhere(frame, 0.0);
    return;
  }
  m.low_frames = 0;
  const cv::Point2d measured = at.to_frame(peak.offset);
  // Right after the box was given, the model knows one frame and its peaks
  // are higher than they will stay: the mean is made over the first
  // warmup_frames tracked frames before a fall below it counts.
  const bool warm = m.tracked_frames >= config_.warmup_frames;
  // A second peak nearly as high: two look-alikes in the patch, and the
  // filter cannot tell which is the target.
  const bool contested = peak.rival > config_.rival_ratio;
  // A sure peak of another colour: the features (gray, gradients) barely
  // see colour, and a look-alike of another one peaks as surely as the target.
  bool doubted = contested || psr < config_.tracking_psr;
  cv::Vec2d color;
  double color_distance = 0;
  if (!doubted) {
    color = chroma(frame, measured, m.size, m.gains);
    color_distance = cv::norm(color - m.chroma_mean);
    doubted = warm && !m.color_matches(config_, color_distance);
  }
  if (doubted)
    m.forget_lower();
  else
    doubted = m.doubted_for_a_lower_peak(frame, at, measured, psr);
  if (doubted) {
    // Where the peak is, but not sure enough to learn from it or to trust
    // its motion (an occluder's edge, a distractor passing).
    m.velocity *= 0.8;
    m.center = measured;
    // Just re-detected, its size is the search's nearest, and a box of the
    // wrong size is doubted for its colour (rescale_frames): measured anyway.
    if (m.frames_since_found < config_.rescale_frames) m.measure_size(frame);
    last_.state = ++m.unsure_frames >= config_.unsure_frames ? TrackState::kLost : TrackState::kUncertain;
    // Where it sits is still most likely the target, partly hidden or
    // changing: what re-detection finds elsewhere is weighed against it.
    look_elsewhere(frame, psr);
    return;
  }
  m.learn_color(config_, frame, measured, color, color_distance);
  m.unsure_frames = m.candidate_frames = 0;  // (and a count the unsure frames' re-detection began)
  m.angle = at.angle;
  m.velocity = config_.velocity_gain * (measured - m.center) + (1 - config_.velocity_gain) * m.velocity;
  m.center = measured;
  m.sure_center = measured;
  const double scale = m.measure_size(frame);
  m.sure_step = m.step;
  last_.state = TrackState::kTracking;
  // Clamped: on a clean synthetic background a PSR can reach thousands, and
  // one such frame would make every ordinary one look unsure.
  const double usual = std::min(psr, 10 * config_.tracking_psr);
  ++m.tracked_frames;
  m.psr_mean = warm ? 0.95 * m.psr_mean + 0.05 * usual : m.psr_mean + (usual - m.psr_mean) / m.tracked_frames;
  // (From the last look's spectra: on a turn search's frames the +angle_step
  // look's, whichever won. Learning the winner's instead was measured worse:
  // rotation success@0.5 1.000 -> 0.916, docs/tracking.md.)
  m.learn(m.patch_spectra, config_.learning_rate, peak.offset);
  m.learn_appearance(frame, config_.learning_rate);
  const bool resized = m.look_for_size(frame, scale, peak);
  m.scale_filter.learn(frame, m.center, m.size, m.scale_angle(), config_.learning_rate, scale != 1.0 || resized);
}

void BoxTracker::look_elsewhere(const cv::Mat& frame, double sits_psr) {
  // Unsure for a few frames: the target may have jumped (a fast turn of the
  // camera, a cut) rather than be hidden. The whole-frame search runs beside
  // the local one, and a confirmed re-detection ends the doubt at once.
  Impl& m = *impl_;
  if (m.unsure_frames < config_.redetect_after) return;
  UnsurePlace sits{sits_psr, 0, false};
  if (sits_psr > 0 && m.color_checked(config_)) {
    sits.color_distance = cv::norm(chroma(frame, m.center, m.size, m.gains) - m.chroma_mean);
    sits.look_alike = sits_psr >= config_.redetect_psr && !m.color_matches(config_, sits.color_distance);
  }
  const double confidence = last_.confidence;
  const TrackState state = last_.state;
  redetect(frame, m.center, /*unsure=*/true, sits);
  if (last_.state != TrackState::kTracking) last_.confidence = confidence, last_.state = state;
}

void BoxTracker::redetect(const cv::Mat& frame, cv::Point2d predicted, bool unsure, const UnsurePlace& sits) {
  Impl& m = *impl_;
  // One place: as near as a moving target can be on the next frame, the
  // search's reach around the candidate (a quarter patch) or half the target.
  const double near = std::max(0.5 * std::max(m.size.width, m.size.height), 0.25 * config_.patch * m.step);
  // While unsure, the place the tracker sits on is what follow() found too
  // weak to track: found there again, a peak must be as sure as a tracked
  // frame's, or background the filter half matches would be "re-detected".
  const bool warm = m.tracked_frames >= config_.warmup_frames;
  const double tracked_bar = std::max(config_.tracking_psr, warm ? config_.relative_psr * m.psr_mean : 0.0);
  auto bar = [&](cv::Point2d found) {
    return unsure && cv::norm(found - m.center) < near ? std::max(config_.redetect_psr, tracked_bar)
                                                       : config_.redetect_psr;
  };
  const auto [local, local_end] = m.gather_looks(frame, predicted, unsure, /*by_color=*/!unsure || sits.look_alike);
  const std::vector<Placement>& looks = m.looks;
  // A target hidden by something passing, or gone out of view, most often
  // comes back near where it was last tracked, and its colour does not lie
  // where its look may (it came back nearer, turned, in other light: the
  // filter peaks under the bar, make bench-track's `mixed` 7-8 for 15 frames):
  // near that place (not where the unsure tracker sits: what follow() found
  // too weak) and of its colour, a peak need only reach redetect_near_psr.
  // (Of its colour anywhere, a tinted look-alike was taken for it: mixed_640.)
  const auto near_its_place = [&](cv::Point2d found, const Peak& peak) {
    return peak.psr >= config_.redetect_near_psr && m.near_where_tracked(found) &&
           !(unsure && cv::norm(found - m.center) < near);
  };
  const bool has_candidate = m.candidate_frames > 0;
  Peak best, strongest;
  Placement where;
  const std::vector<Peak>& peaks = m.look_at_all(frame, strongest);
  if (!unsure) m.follow_lost_colors(frame, looks, peaks, local, local_end);
  const double sits_psr = unsure ? m.best_where_it_sits(sits.psr, near) : sits.psr;
  double sits_shared = -1;  // its share of the target's colours, measured if asked
  // The last frame's candidate (the first look), found again, goes on: a
  // stronger peak elsewhere would start the count anew. One the lower bar let
  // in, its colour checked, is confirmed at its place without the colour: a
  // colour at the tolerance's edge flickers (the light, white balance), and a
  // recheck restarted the count (`mixed`: 24 frames, not 14).
  bool candidate_held = false, best_coloured = false;
  for (std::size_t i = 0; i < looks.size() && !candidate_held; ++i) {
    const Placement& p = looks[i];
    const Peak& peak = peaks[i];
    const cv::Point2d found = p.to_frame(peak.offset);
    const double found_bar = bar(found);
    // (Under both bars, nothing more to ask; first, as the limits below
    // measure the view's move.)
    if (peak.psr < std::min(found_bar, config_.redetect_near_psr)) continue;
    if (!m.may_be_back_at(found) || (cv::norm(found - m.center) >= near && !m.within_reach(found, peak.psr)) ||
        (unsure && !m.beats_where_it_sits(frame, p, found, peak.psr, sits_psr, sits.color_distance, sits_shared, near)))
      continue;
    const bool over_bar = peak.psr >= found_bar;
    const bool held = i == 0 && has_candidate && m.candidate_coloured && cv::norm(found - m.candidate) < near;
    bool coloured = false;
    if (over_bar ? !(held || m.has_its_colors(frame, p, found))
                 : !(near_its_place(found, peak) && (held || (coloured = m.of_its_colour(frame, p, found)))))
      continue;
    candidate_held = i == 0 && has_candidate;
    if (candidate_held || peak.psr > best.psr) best = peak, where = p, best_coloured = coloured;
  }
  last_.confidence = strongest.psr;
  if (best.psr <= 0) {
    m.candidate_frames = 0;
    if (unsure) m.follow_size_where_it_sits(frame, sits.psr, near);
    return;
  }
  cv::Point2d found = where.to_frame(best.offset);
  double found_step = where.step;
  const bool elsewhere = cv::norm(found - m.center) >= near;
  if (elsewhere) m.resize_found(frame, found, found_step, best.psr, near);
  const bool consistent = m.candidate_frames > 0 && cv::norm(found - m.candidate) < near;
  m.candidate = found;
  m.candidate_coloured = best_coloured;
  m.candidate_step = found_step;
  m.candidate_frames = consistent ? m.candidate_frames + 1 : 1;
  if (m.candidate_frames < config_.redetect_frames) return;
  m.found_at(found, found_step, elsewhere);
  last_.state = TrackState::kTracking;
}

}  // namespace saccade::fovea
