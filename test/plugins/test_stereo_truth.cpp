// The ground-truth mask the stereo benchmark and the accuracy tests score
// "seen" and "hidden" pixels by, on rows whose answer is known by hand; and
// the chessboard's disparity from its corners.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "stereo_truth.hpp"

namespace saccade::bench {
namespace {

constexpr int kWidth = 120;

// One row of disparities, d(x) for each x.
cv::Mat row_of(const std::function<float(int)>& d) {
  cv::Mat truth(1, kWidth, CV_32F);
  for (int x = 0; x < kWidth; ++x) truth.at<float>(0, x) = d(x);
  return truth;
}

std::vector<int> hidden_columns(const cv::Mat& truth) {
  const cv::Mat hidden = hidden_from_right_camera(truth);
  std::vector<int> out;
  for (int x = 0; x < kWidth; ++x)
    if (hidden.at<uint8_t>(0, x)) out.push_back(x);
  return out;
}

std::vector<int> range(int first, int last) {
  std::vector<int> out;
  for (int x = first; x <= last; ++x) out.push_back(x);
  return out;
}

// A background at 10 px, known from x = 10 on (left of it, it would land off
// the right image).
float background(int x) { return x < 10 ? -1.0f : 10.0f; }

TEST(HiddenFromRightCamera, WhatLandsOffTheRightImageIsHidden) {
  EXPECT_EQ(hidden_columns(row_of([](int) { return 10.0f; })), range(0, 9));
  EXPECT_EQ(hidden_columns(row_of([](int x) { return x < 5 ? 4.0f : -1.0f; })), range(0, 3))
      << "x = 4 lands on the right image's first pixel";
}

TEST(HiddenFromRightCamera, BehindADepthStepAsManyPixelsAsTheStepIsHigh) {
  // A nearer plane at 20 px from x = 50 on lands from x' = 30 on, over the
  // background of x = 40..49.
  EXPECT_EQ(hidden_columns(row_of([](int x) { return x < 50 ? background(x) : 20.0f; })), range(40, 49));
}

TEST(HiddenFromRightCamera, AThinStructureHidesOnlyWhatIsBehindIt) {
  // A one-pixel stem at 30 px lands on x' = 30, where the background pixel
  // x = 40 does; the background between them lands right of the stem and is
  // seen.
  EXPECT_EQ(hidden_columns(row_of([](int x) { return x == 60 ? 30.0f : background(x); })), std::vector<int>{40});
}

TEST(HiddenFromRightCamera, ASurfaceStretchedInTheRightViewLeavesNoGaps) {
  // A plane slanting away from 40 px at x = 50 by 0.9 px per pixel: its
  // pixels land 1.9 px apart in the right image, from x' = 10 on, over the
  // background of x = 20..49, every one of which it hides. Past x = 83 it
  // is farther than the background and lands right of it: seen.
  EXPECT_EQ(
      hidden_columns(row_of([](int x) { return x < 50 ? background(x) : 40.0f - 0.9f * static_cast<float>(x - 50); })),
      range(20, 49));
}

TEST(HiddenFromRightCamera, UnknownPixelsAreNeitherHiddenNorHide) {
  EXPECT_TRUE(hidden_columns(row_of([](int x) {
                return x == 60 ? std::nanf("") : (x >= 50 && x < 70 ? -1.0f : background(x));
              })).empty());
  EXPECT_EQ(hidden_columns(row_of([](int x) { return x < 50 ? background(x) : (x < 55 ? -1.0f : 20.0f); })),
            range(45, 49))
      << "the nearer plane from x = 55 lands from x' = 35 on";
}

// A 4x3-corner board whose squares are 20 px wide in the left image from
// (100, 50), on a slanted plane: disparity 30 + 0.1 x - 0.05 y, so the right
// corners lie that far left, and 0.5 px lower.
TEST(BoardDisparity, InterpolatesTheCornersDisparitiesOverTheBoardsSquaresOnly) {
  const auto plane = [](double x, double y) { return 30 + 0.1 * x - 0.05 * y; };
  std::vector<cv::Point2f> left, right;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 4; ++col) {
      const cv::Point2f l(100.0f + 20.0f * static_cast<float>(col), 50.0f + 20.0f * static_cast<float>(row));
      left.push_back(l);
      right.emplace_back(l.x - static_cast<float>(plane(l.x, l.y)), l.y + 0.5f);
    }
  const BoardDisparity board(left, right, cv::Size(4, 3));
  EXPECT_NEAR(board.row_error_max(), 0.5, 1e-5);
  EXPECT_NEAR(board.row_error_mean(), 0.5, 1e-5);
  const cv::Point2d middle = board.on_board(1.5, 1);
  EXPECT_NEAR(middle.x, 130, 1e-6);
  EXPECT_NEAR(middle.y, 70, 1e-6);
  // Inside the corners, across a square, and over the outer squares (extrapolated): the plane.
  for (const cv::Point2d p : {cv::Point2d(100, 50), cv::Point2d(133, 61), cv::Point2d(85, 42), cv::Point2d(175, 105)})
    EXPECT_NEAR(board.at(p), plane(p.x, p.y), 1e-3) << p;
  const cv::Mat truth = board.truth(cv::Size(240, 160));
  EXPECT_NEAR(truth.at<float>(61, 133), plane(133, 61), 1e-3);
  EXPECT_NEAR(truth.at<float>(35, 85), plane(85, 35), 1e-3) << "the outer squares reach 20 px beyond the corners";
  EXPECT_EQ(truth.at<float>(25, 133), -1.0f) << "above the board";
  EXPECT_EQ(truth.at<float>(70, 190), -1.0f) << "right of it";
}

}  // namespace
}  // namespace saccade::bench
