// The fused filter bank against its scalar reference and against OpenCV's
// filter2D with the same masks and border, on every level, borders included.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "kernels.hpp"
#include "retina.hpp"
#include "support.hpp"

namespace saccade::filters {
namespace {

BankConfig all_features(Border border) {
  BankConfig c;
  c.wanted.fill(true);
  c.border = border;
  c.grad_threshold = 60;
  c.ggrad_threshold = 8;
  return c;
}

// Levels of a real vtest.avi frame, plus noise and flat levels.
std::vector<cv::Mat> test_levels() {
  cv::VideoCapture cap(test::sample_path("vtest.avi"));
  cv::Mat frame, gray;
  for (int i = 0; i < 40; ++i) cap.read(frame);
  cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
  retina::RetinaSampler sampler({});
  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> g;
  sampler.sample(gray, {400, 300}, levels, g);
  cv::Mat noise(24, 32, CV_8UC1);
  cv::randu(noise, 0, 256);
  levels.push_back(noise);
  levels.push_back(cv::Mat(24, 32, CV_8UC1, cv::Scalar(77)));
  return levels;
}

double tolerance(int f) {
  switch (f) {
    case kGGradX:
    case kGGradY:
    case kGGradMag: return 2e-4;
    case kGradDir: return 1e-4;
    default: return 1e-5;  // integer masks: exact up to float rounding
  }
}

TEST(FilterBank, FusedEqualsReferenceOnEveryLevelAndBorder) {
  for (Border border : {Border::kReflect101, Border::kReplicate}) {
    BankConfig config = all_features(border);
    FilterBank bank(config);
    for (const cv::Mat& level : test_levels()) {
      std::array<cv::Mat, kFeatureCount> fused, ref;
      bank.run(level, fused);
      bank_reference(level, config, ref);
      for (int f = 0; f < kFeatureCount; ++f) {
        const auto i = static_cast<std::size_t>(f);
        ASSERT_FALSE(fused[i].empty()) << kFeatureNames[i];
        if (f == kGradMask || f == kGGradMask) {
          // A mask may differ only where the magnitude sits on the threshold.
          cv::Mat diff;
          cv::absdiff(fused[i], ref[i], diff);
          EXPECT_LE(cv::countNonZero(diff), 1) << kFeatureNames[i];
        } else {
          EXPECT_LE(test::max_abs_diff(fused[i], ref[i]), tolerance(f)) << kFeatureNames[i];
        }
      }
    }
  }
}

TEST(FilterBank, MatchesOpenCvFilter2DWithTheSameMasksAndBorder) {
  for (Border border : {Border::kReflect101, Border::kReplicate}) {
    BankConfig config = all_features(border);
    FilterBank bank(config);
    const int b = to_cv_border(border);
    auto [g, dg] = gaussian_derivative_kernels(config.ggrad_sigma);
    for (const cv::Mat& level : test_levels()) {
      std::array<cv::Mat, kFeatureCount> out;
      bank.run(level, out);
      cv::Mat gauss, sx, sy, lap, log, ggx, ggy;
      cv::filter2D(level, gauss, CV_32F, gaussian3_kernel(), {-1, -1}, 0, b);
      cv::filter2D(level, sx, CV_32F, sobel_x_kernel(), {-1, -1}, 0, b);
      cv::filter2D(level, sy, CV_32F, sobel_y_kernel(), {-1, -1}, 0, b);
      cv::filter2D(level, lap, CV_32F, laplacian4_kernel(), {-1, -1}, 0, b);
      cv::filter2D(gauss, log, CV_32F, laplacian4_kernel(), {-1, -1}, 0, b);
      cv::sepFilter2D(level, ggx, CV_32F, dg, g.t(), {-1, -1}, 0, b);
      cv::sepFilter2D(level, ggy, CV_32F, g, dg.t(), {-1, -1}, 0, b);
      cv::Mat mag, dir;
      cv::magnitude(sx, sy, mag);
      cv::phase(sx, sy, dir);  // [0, 2pi)
      EXPECT_LE(test::max_abs_diff(out[kGauss], gauss), 1e-4);
      EXPECT_LE(test::max_abs_diff(out[kSobelX], sx), 1e-4);
      EXPECT_LE(test::max_abs_diff(out[kSobelY], sy), 1e-4);
      EXPECT_LE(test::max_abs_diff(out[kLaplacian], lap), 1e-4);
      EXPECT_LE(test::max_abs_diff(out[kLoG], log), 1e-4);
      EXPECT_LE(test::max_abs_diff(out[kGradMag], mag), 1e-3);
      EXPECT_LE(test::max_abs_diff(out[kGGradX], ggx), 1e-3);
      EXPECT_LE(test::max_abs_diff(out[kGGradY], ggy), 1e-3);
      // Direction: compare as angles, where the gradient is not zero.
      for (int y = 0; y < level.rows; ++y)
        for (int x = 0; x < level.cols; ++x) {
          if (mag.at<float>(y, x) < 1) continue;
          double d = std::remainder(out[kGradDir].at<float>(y, x) - dir.at<float>(y, x), 2 * CV_PI);
          ASSERT_LE(std::abs(d), 2e-3) << "at " << x << "," << y;  // cv::phase is itself approximate
        }
    }
  }
}

TEST(FilterBank, WorksOnRoiViews) {
  cv::Mat big(60, 80, CV_8UC1);
  cv::randu(big, 0, 256);
  cv::Mat view = big(cv::Rect(7, 5, 32, 24));
  BankConfig config = all_features(Border::kReflect101);
  FilterBank bank(config);
  std::array<cv::Mat, kFeatureCount> a, b;
  bank.run(view, a);
  bank.run(view.clone(), b);
  for (int f = 0; f < kFeatureCount; ++f)
    EXPECT_EQ(test::max_abs_diff(a[static_cast<std::size_t>(f)], b[static_cast<std::size_t>(f)]), 0)
        << kFeatureNames[static_cast<std::size_t>(f)];
}

TEST(FilterBank, GaussianGradientOfARampIsExactlyItsSlope) {
  cv::Mat ramp(24, 32, CV_8UC1);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) ramp.at<uint8_t>(y, x) = static_cast<uint8_t>(3 * x + y);
  BankConfig config = all_features(Border::kReflect101);
  FilterBank bank(config);
  std::array<cv::Mat, kFeatureCount> out;
  bank.run(ramp, out);
  // Away from the border (where reflection bends the ramp): d/dx = 3, d/dy = 1.
  for (int y = 5; y < 19; ++y)
    for (int x = 5; x < 27; ++x) {
      EXPECT_NEAR(out[kGGradX].at<float>(y, x), 3.0f, 1e-4);
      EXPECT_NEAR(out[kGGradY].at<float>(y, x), 1.0f, 1e-4);
      EXPECT_FLOAT_EQ(out[kSobelX].at<float>(y, x), 24.0f);
    }
}

TEST(FastAtan2, IsWithin1e5RadiansOfStdAtan2) {
  double worst = 0;
  for (int i = 0; i < 100000; ++i) {
    float a = static_cast<float>(i) * 0.0000628318f * 10 - 3.14159f;
    for (float r : {0.5f, 30.0f, 1000.0f}) {
      float y = r * std::sin(a), x = r * std::cos(a);
      worst = std::max(worst,
                       static_cast<double>(std::abs(std::remainder(fast_atan2(y, x) - std::atan2(y, x), 2 * CV_PI))));
    }
  }
  EXPECT_LT(worst, 2e-5);
  EXPECT_EQ(fast_atan2(0, 0), 0.0f);
}

Retina make_retina(const cv::Mat& level, int n) {
  Retina r;
  for (int i = 0; i < n; ++i) {
    r.levels.push_back(level.clone());
    r.geometry.push_back({cv::Rect(0, 0, level.cols, level.rows), 1, 1});
  }
  return r;
}

TEST(FilterBankNode, FlatRetinaStaysFlat) {
  auto created =
      testing::NodeHarness::create(R"(<node plugin="filters.bank"><param name="features" value="all"/></node>)");
  ASSERT_TRUE(created.ok()) << created.error();
  auto h = std::move(created).value();
  auto r = std::make_shared<Retina>(make_retina(cv::Mat(24, 32, CV_8UC1, cv::Scalar(90)), 5));
  h->set("retina", r);
  ASSERT_TRUE(h->process().ok());
  auto maps = h->last<FeatureMaps>("maps");
  ASSERT_NE(maps, nullptr);
  EXPECT_EQ(maps->names.size(), static_cast<std::size_t>(kFeatureCount));
  EXPECT_EQ(maps->retina.get(), r.get());
  for (const char* name : {"gauss", "sobel_x", "sobel_y", "grad_mag", "laplacian", "log", "ggrad_mag", "grad_mask"})
    ASSERT_EQ(maps->find(name)->size(), 5u) << name << ": a map per level";
  for (const auto& level : *maps->find("gauss"))
    EXPECT_EQ(cv::norm(level, cv::Mat(24, 32, CV_32F, cv::Scalar(90)), cv::NORM_INF), 0);
  for (const char* name : {"sobel_x", "sobel_y", "grad_mag", "laplacian", "log", "ggrad_mag"})
    for (const auto& level : *maps->find(name)) EXPECT_LE(cv::norm(level, cv::NORM_INF), 1e-3) << name;
  for (const auto& level : *maps->find("grad_mask")) EXPECT_EQ(cv::countNonZero(level), 0);
}

TEST(FilterBankNode, ImpulseGivesThe121Mask) {
  auto h = testing::NodeHarness::create(
               R"(<node plugin="filters.bank"><param name="features" value="gauss,laplacian"/></node>)")
               .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  cv::Mat impulse = cv::Mat::zeros(24, 32, CV_8UC1);
  impulse.at<uint8_t>(10, 10) = 16;
  h->set("retina", std::make_shared<Retina>(make_retina(impulse, 2)));
  ASSERT_TRUE(h->process().ok());
  auto maps = h->last<FeatureMaps>("maps");
  ASSERT_EQ(maps->names, (std::vector<std::string>{"gauss", "laplacian"}));
  const cv::Mat& g = (*maps->find("gauss"))[1];
  cv::Mat expected = (cv::Mat_<float>(3, 3) << 1, 2, 1, 2, 4, 2, 1, 2, 1);
  EXPECT_EQ(cv::norm(g(cv::Rect(9, 9, 3, 3)), expected, cv::NORM_INF), 0);
  EXPECT_EQ(cv::countNonZero(g), 9);
  const cv::Mat& l = (*maps->find("laplacian"))[0];
  EXPECT_EQ(l.at<float>(10, 10), -64.0f);
  EXPECT_EQ(l.at<float>(9, 10), 16.0f);
}

TEST(FilterBankNode, RefusesColorLevelsWithAHint) {
  auto h = testing::NodeHarness::create(R"(<node plugin="filters.bank"/>)").value_or(nullptr);
  ASSERT_NE(h, nullptr);
  h->set("retina", std::make_shared<Retina>(make_retina(cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 2, 3)), 2)));
  Status s = h->process();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("channels=gray"));
}

}  // namespace
}  // namespace saccade::filters
