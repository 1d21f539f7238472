#include "real_fft.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "saccade/simd.hpp"

namespace saccade::fovea {

namespace {

typedef float Lanes __attribute__((vector_size(32)));

// (By reference, not by value: a function passing a 32-byte vector by value
// has another ABI with AVX than without, which GCC warns of.)
__attribute__((always_inline)) inline void load(Lanes& v, const float* p) { std::memcpy(&v, p, sizeof v); }
__attribute__((always_inline)) inline void store(float* p, const Lanes& v) { std::memcpy(p, &v, sizeof v); }

// The 8x8 block at `in` (rows `in_step` apart) transposed: its column c
// becomes row out_rows[c] of `out` (rows `out_step` apart).
__attribute__((always_inline)) inline void transpose8(const float* in, std::ptrdiff_t in_step, float* out,
                                                      const int* out_rows, std::ptrdiff_t out_step) {
  Lanes r[8], t[8], s[8];
  for (int i = 0; i < 8; ++i) load(r[i], in + i * in_step);
  for (int i = 0; i < 8; i += 2) {
    t[i] = __builtin_shufflevector(r[i], r[i + 1], 0, 8, 1, 9, 4, 12, 5, 13);
    t[i + 1] = __builtin_shufflevector(r[i], r[i + 1], 2, 10, 3, 11, 6, 14, 7, 15);
  }
  for (int i = 0; i < 8; i += 4) {
    s[i] = __builtin_shufflevector(t[i], t[i + 2], 0, 1, 8, 9, 4, 5, 12, 13);
    s[i + 1] = __builtin_shufflevector(t[i], t[i + 2], 2, 3, 10, 11, 6, 7, 14, 15);
    s[i + 2] = __builtin_shufflevector(t[i + 1], t[i + 3], 0, 1, 8, 9, 4, 5, 12, 13);
    s[i + 3] = __builtin_shufflevector(t[i + 1], t[i + 3], 2, 3, 10, 11, 6, 7, 14, 15);
  }
  for (int i = 0; i < 4; ++i) {
    const Lanes low = __builtin_shufflevector(s[i], s[i + 4], 0, 1, 2, 3, 8, 9, 10, 11);
    const Lanes high = __builtin_shufflevector(s[i], s[i + 4], 4, 5, 6, 7, 12, 13, 14, 15);
    store(out + out_rows[i] * out_step, low);
    store(out + out_rows[i + 4] * out_step, high);
  }
}

// In-place radix-2 FFTs (exp(-2 pi i ...)) of eight sequences, the lanes, of
// n complex elements each: element e's lanes at re[8e .. 8e+7] and
// im[8e .. 8e+7], given in bit-reversed order.
__attribute__((always_inline)) inline void lanes_fft(float* __restrict re, float* __restrict im, int n, const float* cs,
                                                     const float* sn) {
  Lanes ar, ai, br, bi;
  for (int e = 0; e < n; e += 2) {  // the first stage's twiddle is 1
    load(ar, re + 8 * e), load(ai, im + 8 * e), load(br, re + 8 * e + 8), load(bi, im + 8 * e + 8);
    store(re + 8 * e, ar + br);
    store(im + 8 * e, ai + bi);
    store(re + 8 * e + 8, ar - br);
    store(im + 8 * e + 8, ai - bi);
  }
  for (int half = 2, stride = n / 4; half < n; half *= 2, stride /= 2)
    for (int start = 0; start < n; start += 2 * half)
      for (int k = 0; k < half; ++k) {
        const float wr = cs[k * stride], wi = sn[k * stride];
        const int i = start + k, j = i + half;
        load(ar, re + 8 * i), load(ai, im + 8 * i), load(br, re + 8 * j), load(bi, im + 8 * j);
        const Lanes tr = wr * br - wi * bi, ti = wr * bi + wi * br;
        store(re + 8 * i, ar + tr);
        store(im + 8 * i, ai + ti);
        store(re + 8 * j, ar - tr);
        store(im + 8 * j, ai - ti);
      }
}

constexpr int kIdentity[8] = {0, 1, 2, 3, 4, 5, 6, 7};

// What the fast path's passes share: the size, the padded stride of the
// half spectrum, the bit reversal, the twiddles and the buffers.
struct Plan {
  int n, stride;
  const int* reverse;
  const float *cs, *sn;
  float *re, *im, *mid_re, *mid_im;
};

// RealFft2d::forward's fast path: `pixels` (n x n, rows `step` floats apart)
// to the transposed half spectrum's planes.
SACCADE_AVX2_CLONE void forward_lanes(const Plan& p, const float* pixels, std::ptrdiff_t step, float* out_re,
                                      float* out_im) {
  const int n = p.n, rows = n / 2 + 1, stride = p.stride;
  float* re = p.re;
  float* im = p.im;
  const int* reverse = p.reverse;
  // Along y, sixteen columns a transform: x0 .. x0+7 as the lanes' real
  // parts, x0+8 .. x0+15 as their imaginary parts (Z = A + iB, both columns
  // real: A(k) = (Z(k) + conj Z(n-k)) / 2, B(k) = (Z(k) - conj Z(n-k)) / 2i);
  // eight alone when n is 8.
  const int width = n >= 16 ? 16 : 8;
  for (int x0 = 0; x0 < n; x0 += width) {
    for (int e = 0; e < n; ++e) {
      const float* row = pixels + reverse[e] * step + x0;
      std::memcpy(re + 8 * e, row, sizeof(Lanes));
      if (width == 16)
        std::memcpy(im + 8 * e, row + 8, sizeof(Lanes));
      else
        std::memset(im + 8 * e, 0, sizeof(Lanes));
    }
    lanes_fft(re, im, n, p.cs, p.sn);
    for (int ky = 0; ky < stride; ++ky) {
      float* mr = p.mid_re + ky * n + x0;
      float* mi = p.mid_im + ky * n + x0;
      if (ky >= rows) {  // the padding: zeros through the second pass, so the spectrum's padding is zero
        std::fill(mr, mr + width, 0.0f);
        std::fill(mi, mi + width, 0.0f);
        continue;
      }
      if (width == 8) {
        std::memcpy(mr, re + 8 * ky, sizeof(Lanes));
        std::memcpy(mi, im + 8 * ky, sizeof(Lanes));
        continue;
      }
      const int m = (n - ky) % n;
      Lanes zr, zi, wr, wi;
      load(zr, re + 8 * ky), load(zi, im + 8 * ky), load(wr, re + 8 * m), load(wi, im + 8 * m);
      store(mr, 0.5f * (zr + wr));
      store(mi, 0.5f * (zi - wi));
      store(mr + 8, 0.5f * (zi + wi));
      store(mi + 8, 0.5f * (wr - zr));
    }
  }
  // Along x, eight rows ky a transform: 8x8 blocks transposed into the
  // lanes (column x to element reverse(x)), the result stored transposed.
  for (int y0 = 0; y0 < rows; y0 += 8) {
    for (int x0 = 0; x0 < n; x0 += 8) {
      transpose8(p.mid_re + y0 * n + x0, n, re, reverse + x0, 8);
      transpose8(p.mid_im + y0 * n + x0, n, im, reverse + x0, 8);
    }
    lanes_fft(re, im, n, p.cs, p.sn);
    for (int kx = 0; kx < n; ++kx) {
      std::memcpy(out_re + kx * stride + y0, re + 8 * kx, sizeof(Lanes));
      std::memcpy(out_im + kx * stride + y0, im + 8 * kx, sizeof(Lanes));
    }
  }
}

// RealFft2d::inverse's fast path: the transposed half spectrum's planes to
// `pixels` (n x n, rows `step` floats apart), scaled by 1 / n^2.
SACCADE_AVX2_CLONE void inverse_lanes(const Plan& p, const float* in_re, const float* in_im, float* pixels,
                                      std::ptrdiff_t step) {
  const int n = p.n, rows = n / 2 + 1, stride = p.stride;
  float* re = p.re;
  float* im = p.im;
  const int* reverse = p.reverse;
  // Along x, eight rows ky a transform, as conj(FFT(conj X)): mid holds the
  // conjugate of each row's inverse.
  for (int y0 = 0; y0 < rows; y0 += 8) {
    for (int e = 0; e < n; ++e) {
      const std::size_t i = static_cast<std::size_t>(reverse[e] * stride + y0);
      std::memcpy(re + 8 * e, in_re + i, sizeof(Lanes));
      Lanes v;
      load(v, in_im + i);
      store(im + 8 * e, -v);
    }
    lanes_fft(re, im, n, p.cs, p.sn);
    for (int x0 = 0; x0 < n; x0 += 8) {
      transpose8(re + 8 * x0, 8, p.mid_re + y0 * n + x0, kIdentity, n);
      transpose8(im + 8 * x0, 8, p.mid_im + y0 * n + x0, kIdentity, n);
    }
  }
  // Along y, sixteen columns a transform (a and b, both real): mid holds
  // P = conj A and Q = conj B for ky <= n/2, and conj Z = conj(A + iB) is
  // P - iQ there and conj P(n-ky) - i conj Q(n-ky) beyond; FFT(conj Z) is
  // n^2 (a - ib) after both passes. Eight alone when n is 8.
  const float scale = 1.0f / (static_cast<float>(n) * static_cast<float>(n));
  const int width = n >= 16 ? 16 : 8;
  for (int x0 = 0; x0 < n; x0 += width) {
    for (int e = 0; e < n; ++e) {
      const int ky = reverse[e];
      const bool low = ky < rows;
      const std::size_t k = static_cast<std::size_t>((low ? ky : n - ky) * n + x0);
      Lanes pr, pi, qr{}, qi{};
      load(pr, p.mid_re + k), load(pi, p.mid_im + k);
      if (width == 16) load(qr, p.mid_re + k + 8), load(qi, p.mid_im + k + 8);
      store(re + 8 * e, low ? pr + qi : pr - qi);
      store(im + 8 * e, low ? pi - qr : -pi - qr);
    }
    lanes_fft(re, im, n, p.cs, p.sn);
    for (int y = 0; y < n; ++y) {
      Lanes a, b;
      load(a, re + 8 * y), load(b, im + 8 * y);
      store(pixels + y * step + x0, a * scale);
      if (width == 16) store(pixels + y * step + x0 + 8, b * -scale);
    }
  }
}

}  // namespace

RealFft2d::RealFft2d(int n) : n_(std::max(1, n)), stride_((n_ / 2 + 1 + 7) / 8 * 8) {
  if (n_ < 8 || (n_ & (n_ - 1)) != 0) return;  // cv::dft's
  int bits = 0;
  while ((1 << bits) < n_) ++bits;
  reverse_.resize(static_cast<std::size_t>(n_));
  for (int i = 0; i < n_; ++i) {
    int r = 0;
    for (int b = 0; b < bits; ++b) r |= ((i >> b) & 1) << (bits - 1 - b);
    reverse_[static_cast<std::size_t>(i)] = r;
  }
  cos_.resize(static_cast<std::size_t>(n_ / 2));
  sin_.resize(static_cast<std::size_t>(n_ / 2));
  for (int k = 0; k < n_ / 2; ++k) {
    cos_[static_cast<std::size_t>(k)] = static_cast<float>(std::cos(2 * CV_PI * k / n_));
    sin_[static_cast<std::size_t>(k)] = static_cast<float>(-std::sin(2 * CV_PI * k / n_));
  }
  lane_re_.resize(8 * static_cast<std::size_t>(n_));
  lane_im_.resize(lane_re_.size());
  mid_re_.resize(plane());
  mid_im_.resize(plane());
}

void RealFft2d::forward(const cv::Mat& image, HalfSpectrum& out) {
  CV_Assert(image.type() == CV_32F && image.rows == n_ && image.cols == n_);
  const int n = n_, rows = this->rows();
  out.re.resize(plane());
  out.im.resize(plane());
  if (!fast()) {
    std::fill(out.re.begin(), out.re.end(), 0.0f);
    std::fill(out.im.begin(), out.im.end(), 0.0f);
    cv::dft(image, full_, cv::DFT_COMPLEX_OUTPUT);
    for (int ky = 0; ky < rows; ++ky)
      for (int kx = 0; kx < n; ++kx) {
        const cv::Vec2f v = full_.at<cv::Vec2f>(ky, kx);
        out.re[static_cast<std::size_t>(kx * stride_ + ky)] = v[0];
        out.im[static_cast<std::size_t>(kx * stride_ + ky)] = v[1];
      }
    return;
  }
  forward_lanes(Plan{n_, stride_, reverse_.data(), cos_.data(), sin_.data(), lane_re_.data(), lane_im_.data(),
                     mid_re_.data(), mid_im_.data()},
                image.ptr<float>(), static_cast<std::ptrdiff_t>(image.step1()), out.re.data(), out.im.data());
}

void RealFft2d::inverse(const HalfSpectrum& in, cv::Mat& out) {
  CV_Assert(in.re.size() == plane() && in.im.size() == plane());
  const int n = n_, rows = this->rows();
  out.create(n, n, CV_32F);
  if (!fast()) {
    full_.create(n, n, CV_32FC2);
    for (int ky = 0; ky < n; ++ky)
      for (int kx = 0; kx < n; ++kx) {
        const bool low = ky < rows;
        const int y = low ? ky : n - ky, x = low ? kx : (n - kx) % n;
        const std::size_t i = static_cast<std::size_t>(x * stride_ + y);
        full_.at<cv::Vec2f>(ky, kx) = cv::Vec2f(in.re[i], low ? in.im[i] : -in.im[i]);
      }
    cv::idft(full_, out, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
    return;
  }
  inverse_lanes(Plan{n_, stride_, reverse_.data(), cos_.data(), sin_.data(), lane_re_.data(), lane_im_.data(),
                     mid_re_.data(), mid_im_.data()},
                in.re.data(), in.im.data(), out.ptr<float>(), static_cast<std::ptrdiff_t>(out.step1()));
}

}  // namespace saccade::fovea
