// hello.invert on its own, through the harness (the same checks as in a graph).
#include <gtest/gtest.h>

#include "saccade/testing.hpp"

namespace {

std::shared_ptr<saccade::Image> gray(int value) {
  auto image = std::make_shared<saccade::Image>();
  image->mat = cv::Mat(24, 32, CV_8U, cv::Scalar(value));
  return image;
}

TEST(HelloInvert, TurnsAFrameIntoItsNegative) {
  auto made = saccade::testing::NodeHarness::create(R"(<node plugin="hello.invert"/>)");
  ASSERT_TRUE(made.ok()) << made.error();
  auto& h = *made;
  h->set("image", gray(200));
  ASSERT_TRUE(h->process().ok());
  auto out = h->last<saccade::Image>("inverted");
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(out->mat.at<uint8_t>(0, 0), 55);
}

TEST(HelloInvert, LevelSetsWhatBlackBecomesAndSaturates) {
  auto h =
      saccade::testing::NodeHarness::create(R"(<node plugin="hello.invert"><param name="level" value="100"/></node>)")
          .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  h->set("image", gray(150));
  ASSERT_TRUE(h->process().ok());
  EXPECT_EQ(h->last<saccade::Image>("inverted")->mat.at<uint8_t>(0, 0), 0);
}

TEST(HelloInvert, CountsWhatItSkips) {
  auto h = saccade::testing::NodeHarness::create(R"(<node plugin="hello.invert"/>)").value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto image = std::make_shared<saccade::Image>();
  image->mat = cv::Mat(24, 32, CV_32F, cv::Scalar(0.5));
  h->set("image", image);
  ASSERT_TRUE(h->process().ok());
  EXPECT_EQ(h->last<saccade::Image>("inverted"), nullptr);
  EXPECT_EQ(h->counter("skipped"), 1u);
}

TEST(HelloInvert, ALevelOutOfRangeIsRefusedBeforeItRuns) {
  auto made =
      saccade::testing::NodeHarness::create(R"(<node plugin="hello.invert"><param name="level" value="300"/></node>)");
  EXPECT_FALSE(made.ok());
  EXPECT_NE(made.error().find("level"), std::string::npos) << made.error();
}

}  // namespace
