// The full-resolution baseline nodes against direct OpenCV calls and, for
// stereo, against the Aloe ground truth.
#include <gtest/gtest.h>

#include <opencv2/core/utility.hpp>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "baseline.hpp"
#include "support.hpp"

// OpenCV's own parallel loops run on TBB, whose synchronisation ThreadSanitizer
// cannot see; these tests do not need them, so OpenCV stays on the calling thread.
static const bool kOpenCvSingleThread = (cv::setNumThreads(1), true);

namespace saccade::baseline {
namespace {

std::shared_ptr<Image> gray_image(const std::string& name, double scale = 1.0) {
  auto image = std::make_shared<Image>();
  image->mat = cv::imread(test::sample_path(name), cv::IMREAD_GRAYSCALE);
  if (scale != 1.0) cv::resize(image->mat, image->mat, {}, scale, scale, cv::INTER_AREA);
  return image;
}

TEST(BaselineFilters, EqualTheOpenCvCallsTheyWrap) {
  auto h =
      testing::NodeHarness::create(R"(<node plugin="baseline.filters"><param name="features" value="all"/></node>)")
          .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto image = gray_image("basketball1.png");
  h->set("image", image);
  ASSERT_TRUE(h->process().ok());
  auto maps = h->last<FeatureMaps>("maps");
  ASSERT_EQ(maps->names.size(), 6u);
  cv::Mat g, sx, sy, mag, lap, log, gf;
  cv::GaussianBlur(image->mat, g, {3, 3}, 0);
  cv::Sobel(image->mat, sx, CV_32F, 1, 0);
  cv::Sobel(image->mat, sy, CV_32F, 0, 1);
  cv::magnitude(sx, sy, mag);
  cv::Laplacian(image->mat, lap, CV_32F, 1);
  g.convertTo(gf, CV_32F);
  cv::Laplacian(gf, log, CV_32F, 1);
  EXPECT_EQ(test::max_abs_diff((*maps->find("gauss"))[0], g), 0);
  EXPECT_EQ(test::max_abs_diff((*maps->find("sobel_x"))[0], sx), 0);
  EXPECT_EQ(test::max_abs_diff((*maps->find("sobel_y"))[0], sy), 0);
  EXPECT_LE(test::max_abs_diff((*maps->find("grad_mag"))[0], mag), 1e-3);
  EXPECT_EQ(test::max_abs_diff((*maps->find("laplacian"))[0], lap), 0);
  EXPECT_EQ(test::max_abs_diff((*maps->find("log"))[0], log), 0);
}

TEST(BaselineFilters, AnUnknownFeatureIsAnError) {
  cv::Mat gray(8, 8, CV_8UC1, cv::Scalar(1)), out, scratch;
  const Status s = compute_feature("blur", gray, out, scratch);
  EXPECT_TRUE(s.is_error());
  EXPECT_EQ(s.message(), "unknown full-frame feature 'blur'");
  EXPECT_TRUE(compute_feature("gauss", gray, out, scratch).ok());
}

TEST(BaselineMotion, AbsdiffOfConsecutiveFrames) {
  auto h = testing::NodeHarness::create(R"(<node plugin="baseline.motion"/>)").value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto a = gray_image("basketball1.png"), b = gray_image("basketball2.png");
  h->set("image", a);
  ASSERT_TRUE(h->process().ok());
  EXPECT_EQ(cv::countNonZero((*h->last<FeatureMaps>("maps")->find("absdiff"))[0]), 0);
  h->set("image", b);
  ASSERT_TRUE(h->process().ok());
  cv::Mat expected;
  cv::absdiff(b->mat, a->mat, expected);
  auto maps = h->last<FeatureMaps>("maps");
  EXPECT_EQ(test::max_abs_diff((*maps->find("absdiff"))[0], expected), 0);
  EXPECT_EQ(cv::countNonZero((*maps->find("mask"))[0]), cv::countNonZero(expected > 15));
}

// Aloe at a quarter size (disparities up to ~53 px): StereoBM and SGBM both
// ways, scored against aloeGT (scale 1, so divided by 4 here).
struct AloeScore {
  double density = 0, bad2 = 0;
};
AloeScore score(const cv::Mat& disparity, const cv::Mat& truth) {
  int known = 0, valid = 0, bad = 0;
  for (int y = 0; y < truth.rows; ++y)
    for (int x = 0; x < truth.cols; ++x) {
      float t = truth.at<float>(y, x);
      if (t <= 0) continue;
      ++known;
      float d = disparity.at<float>(y, x);
      if (d < 0) continue;
      ++valid;
      bad += std::abs(d - t) > 2.0f;
    }
  return {static_cast<double>(valid) / known, valid ? static_cast<double>(bad) / valid : 1.0};
}

TEST(BaselineStereo, AloeBothWaysWithBmAndSgbm) {
  const double s = 0.25;
  auto l = gray_image("aloeL.jpg", s), r = gray_image("aloeR.jpg", s);
  cv::Mat gt8 = cv::imread(test::sample_path("aloeGT.png"), cv::IMREAD_GRAYSCALE), gt;
  cv::resize(gt8, gt8, l->mat.size(), 0, 0, cv::INTER_NEAREST);
  gt8.convertTo(gt, CV_32F, s);
  for (const char* algorithm : {"bm", "sgbm"}) {
    auto h = testing::NodeHarness::create(
                 std::string("<node plugin=\"baseline.stereo\"><param name=\"algorithm\" value=\"") + algorithm +
                 "\"/><param name=\"num_disparities\" value=\"64\"/></node>")
                 .value_or(nullptr);
    ASSERT_NE(h, nullptr);
    h->set("left", l);
    h->set("right", r);
    ASSERT_TRUE(h->process().ok());
    auto maps = h->last<FeatureMaps>("maps");
    const cv::Mat& lr = (*maps->find("disparity_lr"))[0];
    const cv::Mat& rl = (*maps->find("disparity_rl"))[0];
    AloeScore a = score(lr, gt);
    std::printf("%s left->right on Aloe/4: density %.3f bad-2 %.3f\n", algorithm, a.density, a.bad2);
    EXPECT_GT(a.density, 0.5) << algorithm;
    EXPECT_LT(a.bad2, 0.25) << algorithm;
    // Right->left agrees with left->right mapped through the disparity.
    int checked = 0, agree = 0;
    for (int y = 0; y < lr.rows; ++y)
      for (int x = 0; x < lr.cols; ++x) {
        float d = lr.at<float>(y, x);
        int xr = static_cast<int>(std::lround(x - d));
        if (d < 0 || xr < 0 || rl.at<float>(y, xr) < 0) continue;
        ++checked;
        agree += std::abs(rl.at<float>(y, xr) - d) <= 1.0f;
      }
    std::printf("%s right->left agrees with left->right on %.3f of %d pixels\n", algorithm,
                static_cast<double>(agree) / checked, checked);
    EXPECT_GT(static_cast<double>(agree) / checked, 0.8) << algorithm;
  }
}

}  // namespace
}  // namespace saccade::baseline
