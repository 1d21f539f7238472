#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "retina.hpp"
#include "support.hpp"

namespace saccade::retina {
namespace {

cv::Mat ramp(int w, int h) {
  cv::Mat m(h, w, CV_8UC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) m.at<uint8_t>(y, x) = static_cast<uint8_t>(x + 10 * y);
  return m;
}

TEST(RetinaGeometry, LevelsAreNestedInsideTheFrameAndGrowLinearly) {
  RetinaConfig c;
  for (cv::Size frame : {cv::Size(1024, 768), cv::Size(640, 480), cv::Size(1282, 1110), cv::Size(33, 25)}) {
    for (cv::Point2d f : {cv::Point2d(frame.width / 2.0, frame.height / 2.0), cv::Point2d(0, 0),
                          cv::Point2d(frame.width, frame.height), cv::Point2d(-500, 1e6), cv::Point2d(100, 50)}) {
      auto g = retina_geometry(c, frame, f);
      ASSERT_EQ(g.size(), 5u);
      cv::Rect whole(0, 0, frame.width, frame.height);
      EXPECT_EQ(g[0].region, whole);
      EXPECT_EQ(g[4].region.size(), c.size);
      EXPECT_DOUBLE_EQ(g[4].step_x, 1.0);
      for (std::size_t k = 0; k < g.size(); ++k) {
        EXPECT_EQ(g[k].region & whole, g[k].region) << "level " << k << " leaves the frame";
        if (k > 0) {
          EXPECT_EQ(g[k].region & g[k - 1].region, g[k].region) << "level " << k << " not inside level " << k - 1;
          EXPECT_LE(g[k].region.width, g[k - 1].region.width);
        }
        EXPECT_DOUBLE_EQ(g[k].step_x, static_cast<double>(g[k].region.width) / c.size.width);
      }
      // Linear growth: the width steps differ by at most a rounding pixel.
      int d0 = g[0].region.width - g[1].region.width;
      for (std::size_t k = 1; k + 1 < g.size(); ++k) EXPECT_NEAR(g[k].region.width - g[k + 1].region.width, d0, 1);
    }
  }
}

TEST(RetinaGeometry, FoveaIsClampedSoTheCropStaysInside) {
  RetinaConfig c;
  EXPECT_EQ(clamp_fovea_corner(c, {640, 480}, {-100, -100}), cv::Point(0, 0));
  EXPECT_EQ(clamp_fovea_corner(c, {640, 480}, {1000, 1000}), cv::Point(640 - 32, 480 - 24));
  EXPECT_EQ(clamp_fovea_corner(c, {640, 480}, {320, 240}), cv::Point(304, 228));
}

// Algorithm 1 by hand on a 12x9 ramp (value x + 10y), 2 levels of 4x3.
// Level 0 covers the frame with step 3: centres x = 1, 4, 7, 10; y = 1, 4, 7;
// s = ceil(3/3) = 1, so pixel (i, j) = mean of the ramp at the centre and its
// 4 neighbours = the centre's value (a ramp is linear).
// The fovea centre (6, 4.5) gives the crop corner (4, 3).
TEST(RetinaSampling, MatchesAlgorithm1ByHandOnARamp) {
  RetinaConfig c;
  c.levels = 2;
  c.size = {4, 3};
  RetinaSampler s(c);
  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> g;
  s.sample(ramp(12, 9), {6, 4.5}, levels, g);
  cv::Mat expected0 = (cv::Mat_<uint8_t>(3, 4) << 11, 14, 17, 20, 41, 44, 47, 50, 71, 74, 77, 80);
  cv::Mat expected1 = (cv::Mat_<uint8_t>(3, 4) << 34, 35, 36, 37, 44, 45, 46, 47, 54, 55, 56, 57);
  EXPECT_EQ(cv::norm(levels[0], expected0, cv::NORM_INF), 0) << levels[0];
  EXPECT_EQ(cv::norm(levels[1], expected1, cv::NORM_INF), 0) << levels[1];
  EXPECT_EQ(g[1].region, cv::Rect(4, 3, 4, 3));
}

// A non-linear pattern, where the five-point mean differs from the centre: a
// single bright pixel at (4, 4) reaches level-0 pixel (1, 1) (centre (4, 4)) as
// 255/5 = 51 and pixel (1,1)'s neighbours not at all.
TEST(RetinaSampling, FivePointMeanOfAnImpulse) {
  RetinaConfig c;
  c.levels = 2;
  c.size = {4, 3};
  cv::Mat frame = cv::Mat::zeros(9, 12, CV_8UC1);
  frame.at<uint8_t>(4, 5) = 255;  // right neighbour of centre (4, 4)
  RetinaSampler s(c);
  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> g;
  s.sample(frame, {6, 4.5}, levels, g);
  EXPECT_EQ(levels[0].at<uint8_t>(1, 1), 51);
  EXPECT_EQ(cv::countNonZero(levels[0]), 1);
}

TEST(RetinaSampling, AreaMeanByHand) {
  RetinaConfig c;
  c.levels = 2;
  c.size = {4, 3};
  c.mode = SamplingMode::kAreaMean;
  RetinaSampler s(c);
  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> g;
  s.sample(ramp(12, 9), {6, 4.5}, levels, g);
  // Cell (i, j) covers x in [3i, 3i+3), y in [3j, 3j+3): its mean is the ramp at (3i+1, 3j+1).
  cv::Mat expected0 = (cv::Mat_<uint8_t>(3, 4) << 11, 14, 17, 20, 41, 44, 47, 50, 71, 74, 77, 80);
  EXPECT_EQ(cv::norm(levels[0], expected0, cv::NORM_INF), 0) << levels[0];
}

TEST(RetinaSampling, FastSamplerEqualsTheReferenceEverywhere) {
  for (int type : {CV_8UC1, CV_8UC3}) {
    for (cv::Size frame :
         {cv::Size(1024, 768), cv::Size(640, 480), cv::Size(1282, 1110), cv::Size(97, 61), cv::Size(32, 24)}) {
      for (int levels : {1, 3, 5, 7}) {
        RetinaConfig c;
        c.levels = levels;
        cv::Mat image = test::random_image({frame.width, frame.height}, frame.width + levels, type);
        RetinaSampler s(c);
        for (cv::Point2d f :
             {cv::Point2d(frame.width * 0.3, frame.height * 0.7), cv::Point2d(0, 0), cv::Point2d(1e5, 1e5)}) {
          std::vector<cv::Mat> fast, ref;
          std::vector<LevelGeometry> g;
          s.sample(image, f, fast, g);
          sample_reference(c, image, g, ref);
          for (int k = 0; k < levels; ++k)
            ASSERT_EQ(cv::norm(fast[static_cast<std::size_t>(k)], ref[static_cast<std::size_t>(k)], cv::NORM_INF), 0)
                << frame << " levels " << levels << " level " << k << " type " << type;
        }
      }
    }
  }
}

TEST(RetinaSampling, WorksOnRoiViews) {
  cv::Mat big = test::random_image({800, 600}, 3, CV_8UC1);
  cv::Mat view = big(cv::Rect(50, 40, 640, 480));
  RetinaConfig c;
  RetinaSampler s(c);
  std::vector<cv::Mat> a, b;
  std::vector<LevelGeometry> g;
  s.sample(view, {200, 100}, a, g);
  RetinaSampler s2(c);
  s2.sample(view.clone(), {200, 100}, b, g);
  ASSERT_EQ(a.size(), 5u);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(cv::norm(a[k], b[k], cv::NORM_INF), 0);
}

TEST(RetinaSampling, FivePointIsCloseToTheAreaMeanOnARealFrame) {
  cv::Mat frame = cv::imread(test::sample_path("aloeL.jpg"), cv::IMREAD_GRAYSCALE);
  RetinaConfig five, area;
  area.mode = SamplingMode::kAreaMean;
  RetinaSampler a(five), b(area);
  std::vector<cv::Mat> la, lb;
  std::vector<LevelGeometry> g;
  a.sample(frame, {640, 555}, la, g);
  b.sample(frame, {640, 555}, lb, g);
  ASSERT_EQ(la.size(), 5u);
  ASSERT_EQ(lb.size(), la.size());
  for (std::size_t k = 0; k < la.size(); ++k) {
    double mean_diff = cv::norm(la[k], lb[k], cv::NORM_L1) / static_cast<double>(la[k].total());
    EXPECT_LT(mean_diff, 20.0) << "level " << k;
  }
  EXPECT_EQ(cv::norm(la.back(), lb.back(), cv::NORM_INF), 0) << "the fovea is the same crop";
}

TEST(RetinaNode, EmitsLevelsGeometryAndFollowsTheFoveaInput) {
  auto created = testing::NodeHarness::create(R"(<node plugin="retina"><param name="levels" value="4"/></node>)");
  ASSERT_TRUE(created.ok()) << created.error();
  auto h = std::move(created).value();
  auto image = std::make_shared<Image>();
  image->mat = test::random_image({640, 480}, 9, CV_8UC1);
  image->frame_id = 12;
  image->timestamp_ns = 1234;
  h->set("image", image);
  ASSERT_TRUE(h->process().ok());
  auto r = h->last<Retina>("retina");
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->levels.size(), 4u);
  EXPECT_EQ(r->frame_id, 12);
  EXPECT_EQ(r->timestamp_ns, 1234);
  EXPECT_EQ(r->fovea, cv::Point(320, 240));
  EXPECT_EQ(r->source.get(), image.get()) << "the retina refers to its frame without copying it";
  auto fovea = std::make_shared<Region>();
  fovea->center = {10, 10};
  h->set("fovea", fovea);
  ASSERT_TRUE(h->process().ok());
  r = h->last<Retina>("retina");
  EXPECT_EQ(r->geometry.back().region, cv::Rect(0, 0, 32, 24));
  EXPECT_EQ(cv::norm(r->levels.back(), image->mat(cv::Rect(0, 0, 32, 24)), cv::NORM_INF), 0);
}

TEST(RetinaNode, ReusesItsBuffersInSteadyState) {
  auto h = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto image = std::make_shared<Image>();
  image->mat = test::random_image({640, 480}, 1, CV_8UC1);
  h->set("image", image);
  ASSERT_TRUE(h->process().ok());
  const Retina* first = h->last<Retina>("retina").get();
  const uchar* pixels = first->levels[0].data;
  h->clear_outputs();
  ASSERT_TRUE(h->process().ok());
  EXPECT_EQ(h->last<Retina>("retina").get(), first);
  EXPECT_EQ(h->last<Retina>("retina")->levels[0].data, pixels);
}

TEST(RetinaNode, LevelsAreMadeTogetherInTheAllocatorAConsumerOffers) {
  test::NamedAllocator ring;  // outlives the harnesses' pooled retinas it made
  auto plain = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  auto offered = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  ASSERT_TRUE(plain && offered);
  offered->set_frame_allocator("retina", &ring);
  for (int i = 0; i < 3; ++i) {
    auto image = std::make_shared<Image>();
    image->mat = test::random_image({640, 480}, i, CV_8UC1);
    plain->set("image", image);
    offered->set("image", image);
    ASSERT_TRUE(plain->process().ok());
    ASSERT_TRUE(offered->process().ok());
    auto a = plain->last<Retina>("retina");
    auto b = offered->last<Retina>("retina");
    ASSERT_EQ(b->levels.size(), a->levels.size());
    for (std::size_t k = 0; k < b->levels.size(); ++k) {
      ASSERT_NE(b->levels[k].u, nullptr);
      EXPECT_EQ(b->levels[k].u, b->levels[0].u) << "one buffer for all levels";
      EXPECT_EQ(b->levels[k].u->currAllocator, &ring);
      EXPECT_EQ(b->levels[k].data, b->levels[0].data + k * 768) << "32x24 bytes a level, 64-byte aligned";
      EXPECT_EQ(test::max_abs_diff(a->levels[k], b->levels[k]), 0) << "frame " << i << " level " << k;
    }
  }
  EXPECT_EQ(ring.made, 3) << "one buffer a frame";
}

TEST(RetinaNode, RefusesFramesSmallerThanALevel) {
  auto h = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto image = std::make_shared<Image>();
  image->mat = cv::Mat::zeros(20, 20, CV_8UC1);
  h->set("image", image);
  Status s = h->process();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("smaller than a level"));
}

}  // namespace
}  // namespace saccade::retina
