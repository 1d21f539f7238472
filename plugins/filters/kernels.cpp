#include "kernels.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

namespace saccade::filters {

const std::array<const char*, kFeatureCount> kFeatureNames = {
    "gauss", "sobel_x", "sobel_y", "grad_mag", "grad_mask", "grad_dir",
    "laplacian", "log", "ggrad_x", "ggrad_y", "ggrad_mag", "ggrad_mask"};

int feature_index(const std::string& name) {
  for (int i = 0; i < kFeatureCount; ++i)
    if (name == kFeatureNames[static_cast<std::size_t>(i)]) return i;
  return -1;
}

int to_cv_border(Border border) {
  return border == Border::kReplicate ? cv::BORDER_REPLICATE : cv::BORDER_REFLECT_101;
}

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

float fast_atan2(float y, float x) {
  // Branch-free, so the loops calling it vectorise.
  float ax = std::fabs(x), ay = std::fabs(y);
  float mx = std::max(ax, ay), mn = std::min(ax, ay);
  float a = mn / std::max(mx, 1e-30f);
  float s = a * a;
  // Odd minimax polynomial for atan on [0, 1], error below 1e-5 rad.
  float r = ((((-0.01172120f * s + 0.05265332f) * s - 0.11643287f) * s + 0.19354346f) * s - 0.33262347f) * s * a +
            0.99997726f * a;
  r = ay > ax ? 1.57079637f - r : r;
  r = x < 0 ? 3.14159274f - r : r;
  return y < 0 ? -r : r;
}

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
  std::array<cv::Mat, kFeatureCount> all = {gauss, sx, sy, mag, mask, dir,
                                            correlate_reference(level, laplacian4_kernel(), config.border),
                                            correlate_reference(gauss, laplacian4_kernel(), config.border),
                                            ggx, ggy, gmag, gmask};
  for (int f = 0; f < kFeatureCount; ++f)
    if (config.wanted[static_cast<std::size_t>(f)]) outs[static_cast<std::size_t>(f)] = all[static_cast<std::size_t>(f)];
}

FilterBank::FilterBank(BankConfig config) : config_(config) {
  auto [g, dg] = gaussian_derivative_kernels(config_.ggrad_sigma);
  g_.assign(g.ptr<float>(), g.ptr<float>() + g.cols);
  dg_.assign(dg.ptr<float>(), dg.ptr<float>() + dg.cols);
  radius_ = gaussian_radius(config_.ggrad_sigma);
}

void FilterBank::run(const cv::Mat& level, std::array<cv::Mat, kFeatureCount>& outs) {
  CV_Assert(level.type() == CV_8UC1);
  const auto& want = config_.wanted;
  const int w = level.cols, h = level.rows;
  const bool need_ggrad = want[kGGradX] || want[kGGradY] || want[kGGradMag] || want[kGGradMask];
  const int pad = need_ggrad ? std::max(1, radius_) : 1;
  // BORDER_ISOLATED: a level that is a view into a larger image must not borrow
  // its neighbours' pixels for the border.
  const int border = to_cv_border(config_.border) | cv::BORDER_ISOLATED;
  padded_.create(h + 2 * pad, w + 2 * pad, CV_8U);
  cv::copyMakeBorder(level, padded_, pad, pad, pad, pad, border);

  auto target = [&](int f, int type) -> cv::Mat& {
    cv::Mat& m = want[static_cast<std::size_t>(f)] ? outs[static_cast<std::size_t>(f)] : scratch_[static_cast<std::size_t>(f)];
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
    for (int y = 0; y < h; ++y) {
      const uint8_t* p0 = padded_.ptr<uint8_t>(y + pad - 1) + pad;
      const uint8_t* p1 = padded_.ptr<uint8_t>(y + pad) + pad;
      const uint8_t* p2 = padded_.ptr<uint8_t>(y + pad + 1) + pad;
      float* og = gauss.ptr<float>(y);
      float* ox = sx.ptr<float>(y);
      float* oy = sy.ptr<float>(y);
      float* ol = lap.ptr<float>(y);
      for (int x = 0; x < w; ++x) {
        int a = p0[x - 1], b = p0[x], c = p0[x + 1];
        int d = p1[x - 1], e = p1[x], f = p1[x + 1];
        int g = p2[x - 1], hh = p2[x], i = p2[x + 1];
        int cross = b + d + f + hh;
        og[x] = static_cast<float>(a + c + g + i + 2 * cross + 4 * e) * (1.0f / 16.0f);
        ox[x] = static_cast<float>((c + 2 * f + i) - (a + 2 * d + g));
        oy[x] = static_cast<float>((g + 2 * hh + i) - (a + 2 * b + c));
        ol[x] = static_cast<float>(cross - 4 * e);
      }
    }
    if (want[kGradMag] || want[kGradMask] || want[kGradDir]) {
      cv::Mat& mag = target(kGradMag, CV_32F);
      cv::Mat* mask = want[kGradMask] ? &target(kGradMask, CV_8U) : nullptr;
      cv::Mat* dir = want[kGradDir] ? &target(kGradDir, CV_32F) : nullptr;
      const float thr = config_.grad_threshold;
      for (int y = 0; y < h; ++y) {
        const float* gx = sx.ptr<float>(y);
        const float* gy = sy.ptr<float>(y);
        float* om = mag.ptr<float>(y);
        for (int x = 0; x < w; ++x) om[x] = std::sqrt(gx[x] * gx[x] + gy[x] * gy[x]);
        if (mask != nullptr) {
          uint8_t* ok = mask->ptr<uint8_t>(y);
          for (int x = 0; x < w; ++x) ok[x] = om[x] > thr ? 255 : 0;
        }
        if (dir != nullptr) {
          float* od = dir->ptr<float>(y);
          for (int x = 0; x < w; ++x) od[x] = fast_atan2(gy[x], gx[x]);
        }
      }
    }
    if (want[kLoG]) {
      gauss_padded_.create(h + 2, w + 2, CV_32F);
      cv::copyMakeBorder(gauss, gauss_padded_, 1, 1, 1, 1, border);
      cv::Mat& log = target(kLoG, CV_32F);
      for (int y = 0; y < h; ++y) {
        const float* q0 = gauss_padded_.ptr<float>(y) + 1;
        const float* q1 = gauss_padded_.ptr<float>(y + 1) + 1;
        const float* q2 = gauss_padded_.ptr<float>(y + 2) + 1;
        float* o = log.ptr<float>(y);
        for (int x = 0; x < w; ++x) o[x] = (q0[x] + q2[x] + q1[x - 1] + q1[x + 1]) - 4.0f * q1[x];
      }
    }
  }
  if (need_ggrad) {
    // Row pass over every padded row, then a column pass: ggrad_x = dg (x) then
    // g (y); ggrad_y = g (x) then dg (y).
    const int r = radius_, n = 2 * r + 1;
    const int rows = h + 2 * pad;
    padded_.convertTo(padded_f_, CV_32F);
    row_g_.create(rows, w, CV_32F);
    row_dg_.create(rows, w, CV_32F);
    // Tap-outer loops: the inner loop runs along x and vectorises.
    for (int y = 0; y < rows; ++y) {
      const float* p = padded_f_.ptr<float>(y) + pad - r;
      float* og = row_g_.ptr<float>(y);
      float* od = row_dg_.ptr<float>(y);
      std::fill(og, og + w, 0.0f);
      std::fill(od, od + w, 0.0f);
      for (int k = 0; k < n; ++k) {
        const float wg = g_[static_cast<std::size_t>(k)], wd = dg_[static_cast<std::size_t>(k)];
        const float* pk = p + k;
        for (int x = 0; x < w; ++x) {
          og[x] += wg * pk[x];
          od[x] += wd * pk[x];
        }
      }
    }
    cv::Mat& gx = target(kGGradX, CV_32F);
    cv::Mat& gy = target(kGGradY, CV_32F);
    for (int y = 0; y < h; ++y) {
      float* ox = gx.ptr<float>(y);
      float* oy = gy.ptr<float>(y);
      std::fill(ox, ox + w, 0.0f);
      std::fill(oy, oy + w, 0.0f);
      for (int k = 0; k < n; ++k) {
        const float* rd = row_dg_.ptr<float>(y + pad - r + k);
        const float* rg = row_g_.ptr<float>(y + pad - r + k);
        const float wg = g_[static_cast<std::size_t>(k)], wd = dg_[static_cast<std::size_t>(k)];
        for (int x = 0; x < w; ++x) {
          ox[x] += wg * rd[x];
          oy[x] += wd * rg[x];
        }
      }
    }
    if (want[kGGradMag] || want[kGGradMask]) {
      cv::Mat& mag = target(kGGradMag, CV_32F);
      cv::Mat* mask = want[kGGradMask] ? &target(kGGradMask, CV_8U) : nullptr;
      const float thr = config_.ggrad_threshold;
      for (int y = 0; y < h; ++y) {
        const float* a = gx.ptr<float>(y);
        const float* b = gy.ptr<float>(y);
        float* om = mag.ptr<float>(y);
        for (int x = 0; x < w; ++x) om[x] = std::sqrt(a[x] * a[x] + b[x] * b[x]);
        if (mask != nullptr) {
          uint8_t* ok = mask->ptr<uint8_t>(y);
          for (int x = 0; x < w; ++x) ok[x] = om[x] > thr ? 255 : 0;
        }
      }
    }
  }
}

}  // namespace saccade::filters
