#include "real_fft.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>

#include "saccade/simd.hpp"

namespace saccade::fovea {

namespace {

typedef float Lanes __attribute__((vector_size(32)));

// A vector of lanes (Lanes, Lanes16) from and to floats. (By reference, not by
// value: a function passing a 32-byte vector by value has another ABI with AVX
// than without, which GCC warns of.)
template <class V>
__attribute__((always_inline)) inline void load(V& v, const float* p) {
  std::memcpy(&v, p, sizeof v);
}
template <class V>
__attribute__((always_inline)) inline void store(float* p, const V& v) {
  std::memcpy(p, &v, sizeof v);
}

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

// In-place radix-2 FFTs (exp(-2 pi i ...)) of W sequences, the lanes (V: W
// floats), of n complex elements each: element e's lanes at re[W e .. W e +
// W - 1] and im[W e .. W e + W - 1], given in bit-reversed order.
template <class V, int W>
__attribute__((always_inline)) inline void lanes_fft_of(float* __restrict re, float* __restrict im, int n,
                                                        const float* cs, const float* sn) {
  V ar, ai, br, bi;
  for (int e = 0; e < n; e += 2) {  // the first stage's twiddle is 1
    load(ar, re + W * e), load(ai, im + W * e), load(br, re + W * e + W), load(bi, im + W * e + W);
    store(re + W * e, ar + br);
    store(im + W * e, ai + bi);
    store(re + W * e + W, ar - br);
    store(im + W * e + W, ai - bi);
  }
  for (int half = 2, stride = n / 4; half < n; half *= 2, stride /= 2)
    for (int start = 0; start < n; start += 2 * half)
      for (int k = 0; k < half; ++k) {
        const float wr = cs[k * stride], wi = sn[k * stride];
        const int i = start + k, j = i + half;
        load(ar, re + W * i), load(ai, im + W * i), load(br, re + W * j), load(bi, im + W * j);
        const V tr = wr * br - wi * bi, ti = wr * bi + wi * br;
        store(re + W * i, ar + tr);
        store(im + W * i, ai + ti);
        store(re + W * j, ar - tr);
        store(im + W * j, ai - ti);
      }
}

__attribute__((always_inline)) inline void lanes_fft(float* __restrict re, float* __restrict im, int n, const float* cs,
                                                     const float* sn) {
  lanes_fft_of<Lanes, 8>(re, im, n, cs, sn);
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

// The forward transform's second pass for W rows ky from y0 (V: W floats):
// 8x8 blocks of the first pass's output transposed into the lanes (column x
// to element reverse(x)), transformed along x, the result stored transposed.
template <class V, int W>
__attribute__((always_inline)) inline void rows_along_x(const Plan& p, int y0, float* out_re, float* out_im) {
  const int n = p.n;
  for (int x0 = 0; x0 < n; x0 += 8)
    for (int half = 0; half < W; half += 8) {
      transpose8(p.mid_re + (y0 + half) * n + x0, n, p.re + half, p.reverse + x0, W);
      transpose8(p.mid_im + (y0 + half) * n + x0, n, p.im + half, p.reverse + x0, W);
    }
  lanes_fft_of<V, W>(p.re, p.im, n, p.cs, p.sn);
  for (int kx = 0; kx < n; ++kx) {
    std::memcpy(out_re + kx * p.stride + y0, p.re + W * kx, sizeof(V));
    std::memcpy(out_im + kx * p.stride + y0, p.im + W * kx, sizeof(V));
  }
}

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
  // Along x, eight rows ky a transform.
  for (int y0 = 0; y0 < rows; y0 += 8) rows_along_x<Lanes, 8>(p, y0, out_re, out_im);
}

#if defined(__x86_64__)
// The forward pass sixteen lanes a step (AVX-512): the same arithmetic per
// lane, and the same two columns paired in a complex transform (x and x + 8),
// so the spectrum is bit for bit forward_lanes'. (Without contraction: a
// fused multiply-add rounds once where the eight-lane code rounds twice.)
typedef float Lanes16 __attribute__((vector_size(64)));

// Sixteen lanes at `lanes`: 0-7 from `first`, 8-15 from `second`; and back.
SACCADE_AVX512_EXACT __attribute__((always_inline)) inline void load_halves(float* lanes, const float* first,
                                                                            const float* second) {
  std::memcpy(lanes, first, 8 * sizeof(float));
  std::memcpy(lanes + 8, second, 8 * sizeof(float));
}
SACCADE_AVX512_EXACT __attribute__((always_inline)) inline void store_halves(float* first, float* second,
                                                                             const Lanes16& v) {
  const float* lanes = reinterpret_cast<const float*>(&v);
  std::memcpy(first, lanes, 8 * sizeof(float));
  std::memcpy(second, lanes + 8, 8 * sizeof(float));
}

// forward_lanes for n >= 32, sixteen lanes a transform: along y, columns x0 ..
// x0+7 and x0+16 .. x0+23 as the real parts, each paired with the column 8
// further as its imaginary part; along x, sixteen rows ky a transform (the
// last rows of the padded half spectrum eight, as forward_lanes does them).
SACCADE_AVX512_EXACT void forward_lanes16(const Plan& p, const float* pixels, std::ptrdiff_t step, float* out_re,
                                          float* out_im) {
  const int n = p.n, rows = n / 2 + 1;
  float* re = p.re;
  float* im = p.im;
  for (int x0 = 0; x0 < n; x0 += 32) {
    for (int e = 0; e < n; ++e) {
      const float* row = pixels + p.reverse[e] * step + x0;
      load_halves(re + 16 * e, row, row + 16);
      load_halves(im + 16 * e, row + 8, row + 24);
    }
    lanes_fft_of<Lanes16, 16>(re, im, n, p.cs, p.sn);
    for (int ky = 0; ky < p.stride; ++ky) {
      float* mr = p.mid_re + ky * n + x0;
      float* mi = p.mid_im + ky * n + x0;
      if (ky >= rows) {
        std::fill(mr, mr + 32, 0.0f);
        std::fill(mi, mi + 32, 0.0f);
        continue;
      }
      const int m = (n - ky) % n;
      Lanes16 zr, zi, wr, wi;
      load(zr, re + 16 * ky), load(zi, im + 16 * ky), load(wr, re + 16 * m), load(wi, im + 16 * m);
      // Lanes 0-7: columns x0 .. x0+7 (a) and x0+8 .. x0+15 (b); lanes 8-15: 16 further.
      store_halves(mr, mr + 16, 0.5f * (zr + wr));
      store_halves(mi, mi + 16, 0.5f * (zi - wi));
      store_halves(mr + 8, mr + 24, 0.5f * (zi + wi));
      store_halves(mi + 8, mi + 24, 0.5f * (wr - zr));
    }
  }
  int y0 = 0;
  for (; y0 + 16 <= p.stride; y0 += 16) rows_along_x<Lanes16, 16>(p, y0, out_re, out_im);
  for (; y0 < rows; y0 += 8) rows_along_x<Lanes, 8>(p, y0, out_re, out_im);
}

#endif

std::atomic<bool> sixteen_lanes_allowed{true};

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

bool allow_sixteen_lanes(bool allowed) {
  sixteen_lanes_allowed.store(allowed, std::memory_order_relaxed);
#if defined(__x86_64__)
  return avx512f_usable();
#else
  return false;
#endif
}

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
  lane_re_.resize(16 * static_cast<std::size_t>(n_));  // sixteen lanes with AVX-512, eight otherwise
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
  const Plan plan{n_,
                  stride_,
                  reverse_.data(),
                  cos_.data(),
                  sin_.data(),
                  lane_re_.data(),
                  lane_im_.data(),
                  mid_re_.data(),
                  mid_im_.data()};
#if defined(__x86_64__)
  if (n >= 32 && avx512f_usable() && sixteen_lanes_allowed.load(std::memory_order_relaxed)) {
    forward_lanes16(plan, image.ptr<float>(), static_cast<std::ptrdiff_t>(image.step1()), out.re.data(), out.im.data());
    return;
  }
#endif
  forward_lanes(plan, image.ptr<float>(), static_cast<std::ptrdiff_t>(image.step1()), out.re.data(), out.im.data());
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
