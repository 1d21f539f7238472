#pragma once
// The two-dimensional DFT of a real square image, to the half of its
// spectrum that determines the rest (the spectrum of a real image is
// Hermitian: X(-ky, -kx) = conj X(ky, kx)), and back: what the box tracker's
// correlation filter transforms per look (six 64x64 transforms: five
// channels forward, the response back). OpenCV's cv::dft and cv::idft take
// 26 us for a 64x64 image and back here; this, eight columns or rows at a
// time as vector lanes and two real columns per complex transform, 7 us
// (saccade_bench BM_Tracker_Fft64_*). With AVX-512 the forward transform of
// 32 pixels and more takes sixteen lanes a step, bit for bit the same.
#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

namespace saccade::fovea {

// A half spectrum, transposed: two planes (real and imaginary parts) of n
// rows (kx = 0 .. n-1) by `stride` columns (ky = 0 .. n/2, then zeros up to
// the stride), entry (kx, ky) at kx * stride + ky. Frequencies above n/2 are
// negative ones (k - n), as in cv::dft.
struct HalfSpectrum {
  std::vector<float> re, im;
};

// Whether RealFft2d::forward may take sixteen lanes a step where the CPU has
// AVX-512 (it does by default, unless SACCADE_AVX512=0 is in the
// environment); off, eight, which gives the same spectrum to the bit (tests
// compare them). Returns whether the sixteen-lane code can run here. Not for
// use while another thread transforms.
bool allow_sixteen_lanes(bool allowed);

class RealFft2d {
 public:
  // Any n >= 1; powers of two from 8 on are the fast ones (others go
  // through cv::dft).
  explicit RealFft2d(int n);
  int size() const { return n_; }
  int stride() const { return stride_; }
  int rows() const { return n_ / 2 + 1; }  // the ky the half spectrum holds
  std::size_t plane() const { return static_cast<std::size_t>(n_) * static_cast<std::size_t>(stride_); }
  // `image`: n x n, CV_32F.
  void forward(const cv::Mat& image, HalfSpectrum& out);
  // The real image whose half spectrum `in` is, scaled by 1 / n^2 (as
  // cv::idft with DFT_SCALE): `out` becomes n x n, CV_32F.
  void inverse(const HalfSpectrum& in, cv::Mat& out);

 private:
  bool fast() const { return !reverse_.empty(); }
  int n_, stride_;
  std::vector<int> reverse_;              // bit reversal of the element indices (fast path)
  std::vector<float> cos_, sin_;          // exp(-2 pi i k / n), k < n/2
  std::vector<float> lane_re_, lane_im_;  // n elements of 16 lanes (8 without AVX-512)
  std::vector<float> mid_re_, mid_im_;    // stride rows (ky) x n columns (x), between the passes
  cv::Mat full_;                          // the other sizes' cv::dft buffer
};

}  // namespace saccade::fovea
