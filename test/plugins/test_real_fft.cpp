// The box tracker's two-dimensional real DFT against OpenCV's cv::dft, for
// the sizes it transforms itself (powers of two) and those it hands to
// OpenCV, with random images (synthetic data: the transform is exact up to
// rounding whatever the image).
#include <gtest/gtest.h>

#include <complex>
#include <cstring>

#include <opencv2/core.hpp>

#include "real_fft.hpp"

namespace saccade::fovea {
namespace {

cv::Mat random_image(int n, int seed) {
  cv::Mat image(n, n, CV_32F);
  cv::RNG rng(static_cast<uint64_t>(seed));
  rng.fill(image, cv::RNG::UNIFORM, -100.0f, 100.0f);
  return image;
}

std::complex<float> at(const HalfSpectrum& s, const RealFft2d& fft, int ky, int kx) {
  const std::size_t i = static_cast<std::size_t>(kx * fft.stride() + ky);
  return {s.re[i], s.im[i]};
}

class RealFft : public ::testing::TestWithParam<int> {};

TEST_P(RealFft, ForwardIsTheUpperHalfOfOpenCvsSpectrumAndThePaddingIsZero) {
  const int n = GetParam();
  const cv::Mat image = random_image(n, n);
  RealFft2d fft(n);
  HalfSpectrum half;
  fft.forward(image, half);
  ASSERT_EQ(half.re.size(), fft.plane());
  cv::Mat full;
  cv::dft(image, full, cv::DFT_COMPLEX_OUTPUT);
  const double tolerance = 2e-5 * 100 * n * n;  // float rounding of sums of n^2 values up to 100
  double worst = 0;
  for (int ky = 0; ky <= n / 2; ++ky)
    for (int kx = 0; kx < n; ++kx) {
      const cv::Vec2f v = full.at<cv::Vec2f>(ky, kx);
      worst = std::max(worst, static_cast<double>(std::abs(at(half, fft, ky, kx) - std::complex<float>(v[0], v[1]))));
    }
  EXPECT_LT(worst, tolerance) << "n " << n;
  for (int kx = 0; kx < n; ++kx)
    for (int ky = n / 2 + 1; ky < fft.stride(); ++ky) EXPECT_EQ(at(half, fft, ky, kx), std::complex<float>()) << ky;
}

TEST_P(RealFft, InverseOfAProductIsOpenCvsCircularCorrelation) {
  // What the tracker does: the response of a filter is the inverse of a
  // product of spectra (Hermitian, as both factors are).
  const int n = GetParam();
  const cv::Mat a = random_image(n, 2 * n), b = random_image(n, 2 * n + 1);
  RealFft2d fft(n);
  HalfSpectrum fa, fb, product;
  fft.forward(a, fa);
  fft.forward(b, fb);
  product.re.resize(fft.plane());
  product.im.resize(fft.plane());
  for (std::size_t i = 0; i < fft.plane(); ++i) {
    const std::complex<float> p =
        std::complex<float>(fa.re[i], fa.im[i]) * std::conj(std::complex<float>(fb.re[i], fb.im[i]));
    product.re[i] = p.real();
    product.im[i] = p.imag();
  }
  cv::Mat ours;
  fft.inverse(product, ours);
  cv::Mat sa, sb, sp, theirs;
  cv::dft(a, sa, cv::DFT_COMPLEX_OUTPUT);
  cv::dft(b, sb, cv::DFT_COMPLEX_OUTPUT);
  cv::mulSpectrums(sa, sb, sp, 0, /*conjB=*/true);
  cv::idft(sp, theirs, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  ASSERT_EQ(ours.size(), theirs.size());
  ASSERT_EQ(ours.type(), CV_32F);
  double peak = 0;
  cv::minMaxLoc(cv::abs(theirs), nullptr, &peak);
  EXPECT_LT(cv::norm(ours, theirs, cv::NORM_INF), 1e-5 * peak) << "n " << n;
}

TEST_P(RealFft, InverseGivesTheImageBack) {
  const int n = GetParam();
  const cv::Mat image = random_image(n, 3 * n);
  RealFft2d fft(n);
  HalfSpectrum half;
  cv::Mat back;
  fft.forward(image, half);
  fft.inverse(half, back);
  EXPECT_LT(cv::norm(image, back, cv::NORM_INF), 1e-3) << "n " << n;
}

// Powers of two from 8 are transformed by the vector lanes; 12, 48 and 5 by cv::dft.
INSTANTIATE_TEST_SUITE_P(Sizes, RealFft, ::testing::Values(8, 16, 32, 64, 128, 256, 5, 12, 48));

TEST(RealFft, SixteenLanesGiveTheEightLanesSpectrumBitForBit) {
  const bool here = allow_sixteen_lanes(true);
  if (!here) GTEST_SKIP() << "no AVX-512 here (the CPU, or SACCADE_AVX512=0): only the eight-lane code runs";
  for (const int n : {32, 64, 128, 256}) {
    for (int seed = 1; seed <= 3; ++seed) {
      const cv::Mat image = random_image(n, 100 * n + seed);
      RealFft2d fft(n);
      HalfSpectrum sixteen, eight;
      allow_sixteen_lanes(true);
      fft.forward(image, sixteen);
      allow_sixteen_lanes(false);
      fft.forward(image, eight);
      ASSERT_EQ(sixteen.re.size(), eight.re.size());
      EXPECT_EQ(std::memcmp(sixteen.re.data(), eight.re.data(), eight.re.size() * sizeof(float)), 0) << n;
      EXPECT_EQ(std::memcmp(sixteen.im.data(), eight.im.data(), eight.im.size() * sizeof(float)), 0) << n;
      // Not merely equal to each other: the same spectrum OpenCV's transform gives.
      cv::Mat full;
      cv::dft(image, full, cv::DFT_COMPLEX_OUTPUT);
      const cv::Vec2f dc = full.at<cv::Vec2f>(0, 0), some = full.at<cv::Vec2f>(3, 5);
      EXPECT_NEAR(at(sixteen, fft, 0, 0).real(), dc[0], 1e-2 * n);
      EXPECT_NEAR(at(sixteen, fft, 3, 5).imag(), some[1], 1e-2 * n);
    }
  }
  allow_sixteen_lanes(true);
}

TEST(RealFft, ARowOrColumnOfTheImageIsNotMistakenForAnother) {
  // One bright pixel: its spectrum's phase says where it is; a transposed or
  // mirrored pass would put it elsewhere.
  for (int n : {8, 64}) {
    cv::Mat image = cv::Mat::zeros(n, n, CV_32F);
    image.at<float>(1, n / 2 + 3) = 1.0f;
    RealFft2d fft(n);
    HalfSpectrum half;
    fft.forward(image, half);
    // X(ky, kx) = exp(-2 pi i (ky y + kx x) / n)
    for (int ky : {0, 1, n / 2})
      for (int kx : {0, 1, 5, n - 1}) {
        const double phase = -2 * CV_PI * (ky * 1 + kx * (n / 2 + 3)) / n;
        EXPECT_NEAR(at(half, fft, ky, kx).real(), std::cos(phase), 1e-5) << n << " " << ky << " " << kx;
        EXPECT_NEAR(at(half, fft, ky, kx).imag(), std::sin(phase), 1e-5) << n << " " << ky << " " << kx;
      }
    cv::Mat back;
    fft.inverse(half, back);
    cv::Point where;
    cv::minMaxLoc(back, nullptr, nullptr, nullptr, &where);
    EXPECT_EQ(where, cv::Point(n / 2 + 3, 1));
  }
}

}  // namespace
}  // namespace saccade::fovea
