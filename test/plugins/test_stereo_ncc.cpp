// The NCC stereo matcher's building blocks on synthetic pairs with known
// disparity (synthetic data: random texture shifted by a known amount).
#include <gtest/gtest.h>

#include "ncc.hpp"
#include "support.hpp"

namespace saccade::stereo {
namespace {

// right(x) = left(x + d): a left pixel x is seen in the right image at x - d.
cv::Mat shifted_right(const cv::Mat& left, int d) {
  cv::Mat right(left.size(), left.type(), cv::Scalar(0));
  left(cv::Rect(d, 0, left.cols - d, left.rows)).copyTo(right(cv::Rect(0, 0, left.cols - d, left.rows)));
  return right;
}

double share_near(const cv::Mat& disparity, float expected, float tolerance, cv::Rect interior) {
  int n = 0, good = 0;
  for (int y = interior.y; y < interior.br().y; ++y)
    for (int x = interior.x; x < interior.br().x; ++x) {
      ++n;
      good += std::fabs(disparity.at<float>(y, x) - expected) <= tolerance;
    }
  return static_cast<double>(good) / n;
}

TEST(NccReference, IsTheCorrelationCoefficient) {
  cv::Mat a = test::random_image({16, 16}, 1);
  cv::Mat b;
  a.convertTo(b, CV_8U, 0.5, 40);  // gain and offset: still perfectly correlated
  EXPECT_NEAR(ncc_reference(a, 8, 8, a, 8, 8, 5), 1.0, 1e-12);
  EXPECT_NEAR(ncc_reference(a, 8, 8, b, 8, 8, 5), 1.0, 2e-2);  // rounding of the 8-bit copy
  cv::Mat inv = 255 - a;
  EXPECT_NEAR(ncc_reference(a, 8, 8, inv, 8, 8, 5), -1.0, 1e-12);
}

TEST(NccMatch, FindsAKnownDisparityBothWays) {
  const int d = 5;
  cv::Mat left = test::random_image({48, 36}, 2);
  cv::Mat right = shifted_right(left, d);
  NccConfig config;
  cv::Mat lr, lr_score, rl, rl_score;
  ncc_match(left, right, Direction::kLeftToRight, 0, 12, config, lr, lr_score);
  ncc_match(left, right, Direction::kRightToLeft, 0, 12, config, rl, rl_score);
  // Left pixels whose match lies in the right image, away from the borders.
  EXPECT_GE(share_near(lr, d, 0.25f, cv::Rect(d + 3, 3, 48 - d - 6, 30)), 0.98);
  EXPECT_GE(share_near(rl, d, 0.25f, cv::Rect(3, 3, 48 - d - 6, 30)), 0.98);
  // The score is the correlation coefficient at the chosen disparity.
  EXPECT_NEAR(lr_score.at<float>(18, 20), ncc_reference(left, 20, 18, right, 20 - d, 18, 5), 1e-4);
  EXPECT_NEAR(lr_score.at<float>(18, 20), 1.0, 1e-4);
}

TEST(NccMatch, IsInsensitiveToGainAndOffset) {
  cv::Mat left = test::random_image({48, 36}, 3);
  cv::Mat right;
  shifted_right(left, 7).convertTo(right, CV_8U, 0.7, 30);
  cv::Mat lr, score;
  ncc_match(left, right, Direction::kLeftToRight, 0, 15, {}, lr, score);
  EXPECT_GE(share_near(lr, 7, 0.25f, cv::Rect(10, 3, 30, 30)), 0.98);
}

TEST(NccMatch, PerPixelRangesRestrictTheSearch) {
  cv::Mat left = test::random_image({48, 36}, 4);
  cv::Mat right = shifted_right(left, 6);
  cv::Mat lo(left.size(), CV_32S, cv::Scalar(6)), hi(left.size(), CV_32S, cv::Scalar(6));
  cv::Mat lr, score;
  ncc_match(left, right, Direction::kLeftToRight, lo, hi, {}, lr, score);
  EXPECT_GE(share_near(lr, 6, 0.0f, cv::Rect(9, 3, 30, 30)), 0.98) << "a one-value range gives that value, no subpixel";
  lo.setTo(0);
  hi.setTo(3);  // the truth is outside: nothing correlates well enough
  ncc_match(left, right, Direction::kLeftToRight, lo, hi, {}, lr, score);
  EXPECT_LE(cv::countNonZero(lr >= 0), 60);
}

TEST(NccMatch, FlatWindowsAreNotMatched) {
  cv::Mat left(36, 48, CV_8UC1, cv::Scalar(90)), right = left.clone();
  cv::Mat lr, score;
  ncc_match(left, right, Direction::kLeftToRight, 0, 8, {}, lr, score);
  EXPECT_EQ(cv::countNonZero(lr >= 0), 0);
}

TEST(LeftRightCheck, KeepsConsistentPixelsAndDropsOthers) {
  const int d = 4;
  cv::Mat left = test::random_image({48, 36}, 5), right = shifted_right(left, d);
  cv::Mat lr, rl, s1, s2;
  ncc_match(left, right, Direction::kLeftToRight, 0, 10, {}, lr, s1);
  ncc_match(left, right, Direction::kRightToLeft, 0, 10, {}, rl, s2);
  cv::Mat corrupted = lr.clone();
  corrupted.at<float>(18, 20) = 9;  // a wrong match
  cv::Mat valid(lr.size(), CV_8U, cv::Scalar(255));
  double kept = left_right_check(corrupted, s1, rl, s2, 1.0f, valid);
  EXPECT_GT(kept, 0.95);
  EXPECT_EQ(valid.at<uint8_t>(18, 20), 0);
  EXPECT_EQ(valid.at<uint8_t>(18, 22), 255);
  EXPECT_NEAR(corrupted.at<float>(18, 22), d, 0.25);
}

}  // namespace
}  // namespace saccade::stereo
