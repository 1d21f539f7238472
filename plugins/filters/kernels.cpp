#include "kernels.hpp"
#include "saccade/simd.hpp"

#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

namespace saccade::filters {

const std::array<const char*, kFeatureCount> kFeatureNames = {"gauss",     "sobel_x",  "sobel_y",   "grad_mag",
                                                              "grad_mask", "grad_dir", "laplacian", "log",
                                                              "ggrad_x",   "ggrad_y",  "ggrad_mag", "ggrad_mask"};

int feature_index(const std::string& name) {
  for (int i = 0; i < kFeatureCount; ++i)
    if (name == kFeatureNames[static_cast<std::size_t>(i)]) return i;
  return -1;
}

int to_cv_border(Border border) { return border == Border::kReplicate ? cv::BORDER_REPLICATE : cv::BORDER_REFLECT_101; }

cv::Mat gaussian3_kernel() { return (cv::Mat_<float>(3, 3) << 1, 2, 1, 2, 4, 2, 1, 2, 1) / 16.0f; }
cv::Mat sobel_x_kernel() { return (cv::Mat_<float>(3, 3) << -1, 0, 1, -2, 0, 2, -1, 0, 1); }
cv::Mat sobel_y_kernel() { return (cv::Mat_<float>(3, 3) << -1, -2, -1, 0, 0, 0, 1, 2, 1); }
cv::Mat laplacian4_kernel() { return (cv::Mat_<float>(3, 3) << 0, 1, 0, 1, -4, 1, 0, 1, 0); }

int gaussian_radius(float sigma) { return std::max(1, static_cast<int>(std::ceil(3.0f * sigma))); }

std::pair<cv::Mat, cv::Mat> gaussian_derivative_kernels(float sigma) {
  int r = gaussian_radius(sigma);
  cv::Mat g(1, 2 * r + 1, CV_32F), dg(1, 2 * r + 1, CV_32F);
  double sum = 0, ramp = 0;
  for (int k = -r; k <= r; ++k) sum += std::exp(-k * k / (2.0 * sigma * sigma));
  for (int k = -r; k <= r; ++k) {
    double gk = std::exp(-k * k / (2.0 * sigma * sigma)) / sum;
    g.at<float>(0, k + r) = static_cast<float>(gk);
    ramp += k * (k * gk);
  }
  // Correlation kernel of the derivative: positive to the right, so a ramp that
  // rises with x gives a positive response, as Sobel x does.
  for (int k = -r; k <= r; ++k) dg.at<float>(0, k + r) = static_cast<float>(k * g.at<float>(0, k + r) / ramp);
  return {g, dg};
}

namespace {
// Branch-free, so the loops calling it vectorise.
inline float fast_atan2_inline(float y, float x) {
  float ax = std::fabs(x), ay = std::fabs(y);
  float mx = std::max(ax, ay), mn = std::min(ax, ay);
  float a = mn / std::max(mx, 1e-30f);
  float s = a * a;
  // Odd minimax polynomial for atan on [0, 1], error below 1e-5 rad.
  float r = ((((-0.01172120f * s + 0.05265332f) * s - 0.11643287f) * s + 0.19354346f) * s - 0.33262347f) * s * a +
            0.99997726f * a;
  // Octant fix-ups as arithmetic on 0/1 factors: no branch, no select.
  const float swap = static_cast<float>(ay > ax), left = static_cast<float>(x < 0);
  r += swap * (1.57079637f - 2.0f * r);
  r += left * (3.14159274f - 2.0f * r);
  return std::copysign(r, y);
}
}  // namespace

float fast_atan2(float y, float x) { return fast_atan2_inline(y, x); }

namespace {

int border_index(int i, int n, Border border) {
  if (border == Border::kReplicate) return std::clamp(i, 0, n - 1);
  if (n == 1) return 0;
  while (i < 0 || i >= n) i = i < 0 ? -i : 2 * (n - 1) - i;
  return i;
}

float pixel(const cv::Mat& m, int y, int x) {
  return m.depth() == CV_8U ? static_cast<float>(m.at<uint8_t>(y, x)) : m.at<float>(y, x);
}

}  // namespace

cv::Mat correlate_reference(const cv::Mat& src, const cv::Mat& kernel, Border border) {
  cv::Mat out(src.size(), CV_32F);
  int ry = kernel.rows / 2, rx = kernel.cols / 2;
  for (int y = 0; y < src.rows; ++y)
    for (int x = 0; x < src.cols; ++x) {
      double acc = 0;
      for (int ky = 0; ky < kernel.rows; ++ky)
        for (int kx = 0; kx < kernel.cols; ++kx) {
          int sy = border_index(y + ky - ry, src.rows, border), sx = border_index(x + kx - rx, src.cols, border);
          acc += static_cast<double>(kernel.at<float>(ky, kx)) * pixel(src, sy, sx);
        }
      out.at<float>(y, x) = static_cast<float>(acc);
    }
  return out;
}

void bank_reference(const cv::Mat& level, const BankConfig& config, std::array<cv::Mat, kFeatureCount>& outs) {
  for (auto& o : outs) o.release();
  cv::Mat gauss = correlate_reference(level, gaussian3_kernel(), config.border);
  cv::Mat sx = correlate_reference(level, sobel_x_kernel(), config.border);
  cv::Mat sy = correlate_reference(level, sobel_y_kernel(), config.border);
  cv::Mat mag(level.size(), CV_32F), dir(level.size(), CV_32F), mask(level.size(), CV_8U);
  for (int y = 0; y < level.rows; ++y)
    for (int x = 0; x < level.cols; ++x) {
      float gx = sx.at<float>(y, x), gy = sy.at<float>(y, x);
      mag.at<float>(y, x) = std::sqrt(gx * gx + gy * gy);
      dir.at<float>(y, x) = std::atan2(gy, gx);
      mask.at<uint8_t>(y, x) = mag.at<float>(y, x) > config.grad_threshold ? 255 : 0;
    }
  auto [g, dg] = gaussian_derivative_kernels(config.ggrad_sigma);
  cv::Mat ggx = correlate_reference(correlate_reference(level, dg, config.border), g.t(), config.border);
  cv::Mat ggy = correlate_reference(correlate_reference(level, g, config.border), dg.t(), config.border);
  cv::Mat gmag(level.size(), CV_32F), gmask(level.size(), CV_8U);
  for (int y = 0; y < level.rows; ++y)
    for (int x = 0; x < level.cols; ++x) {
      float a = ggx.at<float>(y, x), b = ggy.at<float>(y, x);
      gmag.at<float>(y, x) = std::sqrt(a * a + b * b);
      gmask.at<uint8_t>(y, x) = gmag.at<float>(y, x) > config.ggrad_threshold ? 255 : 0;
    }
  std::array<cv::Mat, kFeatureCount> all = {gauss,
                                            sx,
                                            sy,
                                            mag,
                                            mask,
                                            dir,
                                            correlate_reference(level, laplacian4_kernel(), config.border),
                                            correlate_reference(gauss, laplacian4_kernel(), config.border),
                                            ggx,
                                            ggy,
                                            gmag,
                                            gmask};
  for (int f = 0; f < kFeatureCount; ++f)
    if (config.wanted[static_cast<std::size_t>(f)])
      outs[static_cast<std::size_t>(f)] = all[static_cast<std::size_t>(f)];
}

namespace {

// Copies an 8-bit level into a float buffer with `pad` border pixels on every
// side, resolving the border by the same index rule as the reference. The level
// alone is read, even when it is a view into a larger image.
template <class T>
void pad_rows(const cv::Mat& level, int pad, Border border, const std::vector<int>& map_x, cv::Mat& out) {
  const int w = level.cols, h = level.rows;
  for (int y = 0; y < h + 2 * pad; ++y) {
    const T* src = level.ptr<T>(border_index(y - pad, h, border));
    float* dst = out.ptr<float>(y);
    for (int x = 0; x < pad; ++x) dst[x] = static_cast<float>(src[map_x[static_cast<std::size_t>(x)]]);
    for (int x = 0; x < w; ++x) dst[x + pad] = static_cast<float>(src[x]);
    for (int x = w + pad; x < w + 2 * pad; ++x) dst[x] = static_cast<float>(src[map_x[static_cast<std::size_t>(x)]]);
  }
}

void pad_level(const cv::Mat& level, int pad, Border border, std::vector<int>& map_x, cv::Mat& out) {
  const int w = level.cols, h = level.rows;
  out.create(h + 2 * pad, w + 2 * pad, CV_32F);
  map_x.resize(static_cast<std::size_t>(w + 2 * pad));
  for (int x = 0; x < w + 2 * pad; ++x) map_x[static_cast<std::size_t>(x)] = border_index(x - pad, w, border);
  if (level.depth() == CV_8U)
    pad_rows<uint8_t>(level, pad, border, map_x, out);
  else
    pad_rows<float>(level, pad, border, map_x, out);
}

// One output row of the 3x3 masks. Rows start one pixel left of the output's
// first pixel. Restrict parameters (GCC honours restrict on parameters) and
// float arithmetic on small integers (exact) let this vectorise.
SACCADE_AVX2_CLONE void row_3x3(const float* __restrict r0, const float* __restrict r1, const float* __restrict r2,
                                float* __restrict og, float* __restrict ox, float* __restrict oy, float* __restrict ol,
                                int w) {
  for (int x = 0; x < w; ++x) {
    const float a = r0[x], b = r0[x + 1], c = r0[x + 2];
    const float d = r1[x], e = r1[x + 1], f = r1[x + 2];
    const float g = r2[x], hh = r2[x + 1], i = r2[x + 2];
    const float cross = (b + d) + (f + hh);
    og[x] = ((a + c) + (g + i) + 2.0f * cross + 4.0f * e) * (1.0f / 16.0f);
    ox[x] = (c + 2.0f * f + i) - (a + 2.0f * d + g);
    oy[x] = (g + 2.0f * hh + i) - (a + 2.0f * b + c);
    ol[x] = cross - 4.0f * e;
  }
}

// One output row of the 4-neighbour Laplacian, rows as in row_3x3.
SACCADE_AVX2_CLONE void row_cross(const float* __restrict r0, const float* __restrict r1, const float* __restrict r2,
                                  float* __restrict o, int w) {
  for (int x = 0; x < w; ++x) o[x] = (r0[x + 1] + r2[x + 1] + r1[x] + r1[x + 2]) - 4.0f * r1[x + 1];
}

SACCADE_AVX2_CLONE void row_magnitude(const float* __restrict gx, const float* __restrict gy, float* __restrict mag,
                                      int w) {
  for (int x = 0; x < w; ++x) mag[x] = std::sqrt(gx[x] * gx[x] + gy[x] * gy[x]);
}

SACCADE_AVX2_CLONE void row_threshold(const float* __restrict v, float thr, uint8_t* __restrict mask, int w) {
  for (int x = 0; x < w; ++x) mask[x] = v[x] > thr ? 255 : 0;
}

// AVX2 where the CPU has it: the polynomial is a large share of the bank's
// arithmetic.
SACCADE_AVX2_CLONE void row_direction(const float* __restrict gx, const float* __restrict gy, float* __restrict dir,
                                      int w) {
  for (int x = 0; x < w; ++x) dir[x] = fast_atan2_inline(gy[x], gx[x]);
}

// GCC's auto-vectoriser keeps these loops scalar behind an alias check, so
// they are written with its portable vector extension, eight lanes (two SSE2
// registers, one AVX2 register in the AVX2 clone of gradient_passes).
typedef float v8sf __attribute__((vector_size(32)));

// (By reference: a 32-byte vector passed by value changes the ABI without AVX.)
__attribute__((always_inline)) inline void load8(v8sf& v, const float* p) { std::memcpy(&v, p, sizeof v); }
__attribute__((always_inline)) inline void store8(float* p, const v8sf& v) { std::memcpy(p, &v, sizeof v); }

// Horizontal pass over one padded row: out_g = g * src, out_dg = dg * src (src
// starts at the first tap). N taps known at compile time: the tap loop unrolls
// and the weights stay in registers. column_taps below is the same sum over a
// table of rows; serving this pass with it (rows src, src + 1, ...) costs 6% more
// instructions per map (callgrind), so the row pass keeps its direct offsets.
template <int N>
__attribute__((always_inline)) inline void row_taps(const float* src, const float* g, const float* dg, float* out_g,
                                                    float* out_dg, int w) {
  v8sf wg[N], wd[N];
  for (int k = 0; k < N; ++k) {
    wg[k] = v8sf{} + g[k];
    wd[k] = v8sf{} + dg[k];
  }
  int x = 0;
  for (; x + 8 <= w; x += 8) {
    v8sf ag = v8sf{}, ad = v8sf{};
    for (int k = 0; k < N; ++k) {
      v8sf v;
      load8(v, src + x + k);
      ag += wg[k] * v;
      ad += wd[k] * v;
    }
    store8(out_g + x, ag);
    store8(out_dg + x, ad);
  }
  for (; x < w; ++x) {
    float ag = 0, ad = 0;
    for (int k = 0; k < N; ++k) {
      ag += g[k] * src[x + k];
      ad += dg[k] * src[x + k];
    }
    out_g[x] = ag;
    out_dg[x] = ad;
  }
}

// Vertical pass for one output row: out_x = sum g[k] rows_dg[k], out_y = sum dg[k] rows_g[k].
template <int N>
__attribute__((always_inline)) inline void column_taps(const float* const* rows_dg, const float* const* rows_g,
                                                       const float* g, const float* dg, float* out_x, float* out_y,
                                                       int w) {
  v8sf wg[N], wd[N];
  for (int k = 0; k < N; ++k) {
    wg[k] = v8sf{} + g[k];
    wd[k] = v8sf{} + dg[k];
  }
  int x = 0;
  for (; x + 8 <= w; x += 8) {
    v8sf ax = v8sf{}, ay = v8sf{};
    for (int k = 0; k < N; ++k) {
      v8sf vx, vy;
      load8(vx, rows_dg[k] + x);
      load8(vy, rows_g[k] + x);
      ax += wg[k] * vx;
      ay += wd[k] * vy;
    }
    store8(out_x + x, ax);
    store8(out_y + x, ay);
  }
  for (; x < w; ++x) {
    float ax = 0, ay = 0;
    for (int k = 0; k < N; ++k) {
      ax += g[k] * rows_dg[k][x];
      ay += dg[k] * rows_g[k][x];
    }
    out_x[x] = ax;
    out_y[x] = ay;
  }
}

// Both passes for a kernel of N taps.
template <int N>
__attribute__((always_inline)) inline void separable_gradient(const cv::Mat& padded, int pad, int w, int h,
                                                              const float* g, const float* dg, cv::Mat& row_g,
                                                              cv::Mat& row_dg, const float** rows_g,
                                                              const float** rows_dg, cv::Mat& gx, cv::Mat& gy) {
  constexpr int r = N / 2;
  for (int y = 0; y < h + 2 * pad; ++y)
    row_taps<N>(padded.ptr<float>(y) + pad - r, g, dg, row_g.ptr<float>(y), row_dg.ptr<float>(y), w);
  for (int y = 0; y < h; ++y) {
    for (int k = 0; k < N; ++k) {
      rows_dg[k] = row_dg.ptr<float>(y + pad - r + k);
      rows_g[k] = row_g.ptr<float>(y + pad - r + k);
    }
    column_taps<N>(rows_dg, rows_g, g, dg, gx.ptr<float>(y), gy.ptr<float>(y), w);
  }
}

// Every kernel size's passes in one function, so the AVX2 clone covers them.
SACCADE_AVX2_CLONE void gradient_passes(int n, const cv::Mat& padded, int pad, int w, int h, const float* g,
                                        const float* dg, cv::Mat& row_g, cv::Mat& row_dg, const float** rows_g,
                                        const float** rows_dg, cv::Mat& gx, cv::Mat& gy) {
  // sigma in [0.3, 3] gives radius 1..9.
  // One case per kernel size, made by a macro clang-format cannot lay out.
  // clang-format off
  switch (n) {
#define SACCADE_TAPS(N) \
  case N: separable_gradient<N>(padded, pad, w, h, g, dg, row_g, row_dg, rows_g, rows_dg, gx, gy); break;
    SACCADE_TAPS(3) SACCADE_TAPS(5) SACCADE_TAPS(7) SACCADE_TAPS(9) SACCADE_TAPS(11)
    SACCADE_TAPS(13) SACCADE_TAPS(15) SACCADE_TAPS(17) SACCADE_TAPS(19)
#undef SACCADE_TAPS
    default: CV_Error(cv::Error::StsOutOfRange, "Gaussian gradient radius above 9 (sigma above 3)");
  }
  // clang-format on
}

}  // namespace

GaussianGradient::GaussianGradient(float sigma, Border border) : border_(border) {
  auto [g, dg] = gaussian_derivative_kernels(sigma);
  g_.assign(g.ptr<float>(), g.ptr<float>() + g.cols);
  dg_.assign(dg.ptr<float>(), dg.ptr<float>() + dg.cols);
  radius_ = gaussian_radius(sigma);
  rows_g_.resize(g_.size());
  rows_dg_.resize(g_.size());
}

void GaussianGradient::run(const cv::Mat& src, cv::Mat& gx, cv::Mat& gy) {
  CV_Assert(src.channels() == 1 && (src.depth() == CV_32F || src.depth() == CV_8U));
  pad_level(src, radius_, border_, map_x_, padded_);
  run_padded(padded_, radius_, src.cols, src.rows, gx, gy);
}

// Row pass over every padded row, then a column pass: gx = dg (x) then g (y);
// gy = g (x) then dg (y). Taps outer, pixels inner, so both vectorise.
void GaussianGradient::run_padded(const cv::Mat& padded, int pad, int w, int h, cv::Mat& gx, cv::Mat& gy) {
  const int n = 2 * radius_ + 1;
  row_g_.create(h + 2 * pad, w, CV_32F);
  row_dg_.create(h + 2 * pad, w, CV_32F);
  gx.create(h, w, CV_32F);
  gy.create(h, w, CV_32F);
  const float** rg = rows_g_.data();
  const float** rd = rows_dg_.data();
  gradient_passes(n, padded, pad, w, h, g_.data(), dg_.data(), row_g_, row_dg_, rg, rd, gx, gy);
}

FilterBank::FilterBank(BankConfig config) : config_(config), ggrad_(config.ggrad_sigma, config.border) {}

void FilterBank::run(const cv::Mat& level, std::array<cv::Mat, kFeatureCount>& outs) {
  CV_Assert(level.type() == CV_8UC1);
  const auto& want = config_.wanted;
  const int w = level.cols, h = level.rows;
  const bool need_ggrad = want[kGGradX] || want[kGGradY] || want[kGGradMag] || want[kGGradMask];
  const int pad = need_ggrad ? std::max(1, ggrad_.radius()) : 1;
  pad_level(level, pad, config_.border, map_x_, padded_f_);

  auto target = [&](int f, int type) -> cv::Mat& {
    cv::Mat& m =
        want[static_cast<std::size_t>(f)] ? outs[static_cast<std::size_t>(f)] : scratch_[static_cast<std::size_t>(f)];
    m.create(h, w, type);
    return m;
  };
  const bool need_3x3 = want[kGauss] || want[kSobelX] || want[kSobelY] || want[kGradMag] || want[kGradMask] ||
                        want[kGradDir] || want[kLaplacian] || want[kLoG];
  if (need_3x3) {
    cv::Mat& gauss = target(kGauss, CV_32F);
    cv::Mat& sx = target(kSobelX, CV_32F);
    cv::Mat& sy = target(kSobelY, CV_32F);
    cv::Mat& lap = target(kLaplacian, CV_32F);
    // Float arithmetic on small integers: exact, and it vectorises.
    for (int y = 0; y < h; ++y) {
      row_3x3(padded_f_.ptr<float>(y + pad - 1) + pad - 1, padded_f_.ptr<float>(y + pad) + pad - 1,
              padded_f_.ptr<float>(y + pad + 1) + pad - 1, gauss.ptr<float>(y), sx.ptr<float>(y), sy.ptr<float>(y),
              lap.ptr<float>(y), w);
    }
    if (want[kGradMag] || want[kGradMask] || want[kGradDir]) {
      cv::Mat& mag = target(kGradMag, CV_32F);
      cv::Mat* mask = want[kGradMask] ? &target(kGradMask, CV_8U) : nullptr;
      cv::Mat* dir = want[kGradDir] ? &target(kGradDir, CV_32F) : nullptr;
      const float thr = config_.grad_threshold;
      for (int y = 0; y < h; ++y) {
        row_magnitude(sx.ptr<float>(y), sy.ptr<float>(y), mag.ptr<float>(y), w);
        if (mask != nullptr) row_threshold(mag.ptr<float>(y), thr, mask->ptr<uint8_t>(y), w);
        if (dir != nullptr) row_direction(sx.ptr<float>(y), sy.ptr<float>(y), dir->ptr<float>(y), w);
      }
    }
    if (want[kLoG]) {
      pad_level(gauss, 1, config_.border, map_x_, gauss_padded_);
      cv::Mat& log = target(kLoG, CV_32F);
      for (int y = 0; y < h; ++y) {
        row_cross(gauss_padded_.ptr<float>(y), gauss_padded_.ptr<float>(y + 1), gauss_padded_.ptr<float>(y + 2),
                  log.ptr<float>(y), w);
      }
    }
  }
  if (need_ggrad) {
    cv::Mat& gx = target(kGGradX, CV_32F);
    cv::Mat& gy = target(kGGradY, CV_32F);
    ggrad_.run_padded(padded_f_, pad, w, h, gx, gy);
    if (want[kGGradMag] || want[kGGradMask]) {
      cv::Mat& mag = target(kGGradMag, CV_32F);
      cv::Mat* mask = want[kGGradMask] ? &target(kGGradMask, CV_8U) : nullptr;
      const float thr = config_.ggrad_threshold;
      for (int y = 0; y < h; ++y) {
        row_magnitude(gx.ptr<float>(y), gy.ptr<float>(y), mag.ptr<float>(y), w);
        if (mask != nullptr) row_threshold(mag.ptr<float>(y), thr, mask->ptr<uint8_t>(y), w);
      }
    }
  }
}

}  // namespace saccade::filters
