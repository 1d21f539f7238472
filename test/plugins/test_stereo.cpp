// The stereo node on synthetic pairs with a known disparity everywhere
// (synthetic data: a random texture and its copy shifted by D pixels).
#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/imgproc.hpp>

#include "retina_stereo.hpp"
#include "support.hpp"

namespace saccade::stereo {
namespace {

struct Pair {
  std::shared_ptr<const Retina> left, right;
};

// right(x) = left(x + d): every left pixel is seen d pixels further left.
Pair make_pair(int d, cv::Point2d fovea) {
  // Texture at every scale (as real scenes have), so the coarse levels, which
  // sample every 20 pixels, still see structure that shifts coherently.
  cv::Mat texture(480, 640 + d, CV_32F, cv::Scalar(0));
  int seed = 11;
  for (int scale : {1, 4, 16, 48}) {
    cv::Mat small = test::random_image({(640 + d) / scale + 2, 480 / scale + 2}, seed++), big;
    small.convertTo(small, CV_32F);
    cv::resize(small, big, {}, scale, scale, scale == 1 ? cv::INTER_NEAREST : cv::INTER_CUBIC);
    texture += big(cv::Rect(0, 0, 640 + d, 480)) * 0.25;
  }
  texture.convertTo(texture, CV_8U);
  cv::Mat left = texture(cv::Rect(0, 0, 640, 480)).clone();
  cv::Mat right = texture(cv::Rect(d, 0, 640, 480)).clone();
  auto retina = testing::NodeHarness::create(R"(<node plugin="retina"/>)");
  Pair p;
  for (int side = 0; side < 2; ++side) {
    auto image = std::make_shared<Image>();
    image->mat = side == 0 ? left : right;
    auto f = std::make_shared<Region>();
    f->center = fovea;
    retina->set("image", image);
    retina->set("fovea", f);
    EXPECT_TRUE(retina->process().ok());
    (side == 0 ? p.left : p.right) = retina->last<Retina>("retina");
    retina->clear_outputs();
  }
  return p;
}

// Share of valid pixels within `tolerance` source pixels of d, and density.
std::pair<double, double> accuracy(const cv::Mat& disparity, double d, double tolerance) {
  int valid = 0, good = 0;
  for (int y = 0; y < disparity.rows; ++y)
    for (int x = 0; x < disparity.cols; ++x) {
      float v = disparity.at<float>(y, x);
      if (v < 0) continue;
      ++valid;
      good += std::abs(v - d) <= tolerance;
    }
  return {valid ? static_cast<double>(good) / valid : 0.0, static_cast<double>(valid) / static_cast<double>(disparity.total())};
}

// Runs one pair through two configurations.
void run_both(const Pair& p, const RetinaStereoConfig& first, const RetinaStereoConfig& second,
              std::vector<LevelDisparity>& a, std::vector<LevelDisparity>& b) {
  ASSERT_EQ(RetinaStereo(first).run(*p.left, *p.right, a), "");
  ASSERT_EQ(RetinaStereo(second).run(*p.left, *p.right, b), "");
}

TEST(RetinaStereo, FindsAKnownDisparityOnEveryLevel) {
  const int d = 12;
  Pair p = make_pair(d, {320, 240});
  RetinaStereoConfig config;
  config.max_disparity = 64;
  RetinaStereo stereo(config);
  std::vector<LevelDisparity> out;
  ASSERT_EQ(stereo.run(*p.left, *p.right, out), "");
  ASSERT_EQ(out.size(), 5u);
  for (std::size_t k = 0; k < out.size(); ++k) {
    const double step = p.left->geometry[k].step_x;
    auto [share, density] = accuracy(out[k].disparity, d, std::max(1.0, 0.5 * step));
    std::printf("level %zu (step %.2f): %.3f of valid pixels within tolerance, density %.3f\n", k, step, share, density);
    // Measured 0.88 on level 0 (12 px is 0.6 of its pixels), 0.97 and up inside.
    EXPECT_GE(share, k == 0 ? 0.85 : 0.95) << "level " << k;
    // On the fovea (32 px wide) a 12 px disparity leaves only the right part matchable.
    EXPECT_GE(density, k + 1 == out.size() ? 0.35 : 0.5) << "level " << k;
  }
  // The fovea level (step 1) is exact to sub-pixel accuracy.
  auto [fovea_share, fovea_density] = accuracy(out.back().disparity, d, 0.25);
  EXPECT_GE(fovea_share, 0.95);
  // Right -> left finds the same disparity.
  auto [rl_share, rl_density] = accuracy(out.back().reverse, d, 0.25);
  EXPECT_GE(rl_share, 0.9);  // measured 0.93: right->left has no check of its own
  EXPECT_GT(rl_density, 0.35);
}

TEST(RetinaStereo, SoftwareVergenceLetsTheFoveaMatchWhatItCouldNotSee) {
  // 40 px disparity: more than the 32-px fovea can match against a right fovea at
  // the same place; with vergence the right frame is sampled where the scene is.
  const int d = 40;
  Pair p = make_pair(d, {320, 240});
  RetinaStereoConfig plain, verged;
  plain.max_disparity = verged.max_disparity = 96;
  verged.vergence = true;
  std::vector<LevelDisparity> a, b;
  ASSERT_NO_FATAL_FAILURE(run_both(p, plain, verged, a, b));
  auto [plain_share, plain_density] = accuracy(a.back().disparity, d, 0.25);
  auto [verged_share, verged_density] = accuracy(b.back().disparity, d, 0.25);
  std::printf("fovea, 40 px: plain density %.3f, verged density %.3f (share %.3f), moved by %.1f px\n", plain_density,
              verged_density, verged_share, b.back().vergence);
  EXPECT_LT(plain_density, 0.05);
  EXPECT_GT(verged_density, 0.6);
  EXPECT_GE(verged_share, 0.95);
  EXPECT_NEAR(b.back().vergence, d, 1.0);
}

TEST(RetinaStereo, CoarseToFineAgreesWithAFullSearch) {
  Pair p = make_pair(9, {300, 200});
  RetinaStereoConfig fine, full;
  fine.max_disparity = full.max_disparity = 48;
  full.coarse_to_fine = false;
  std::vector<LevelDisparity> a, b;
  ASSERT_NO_FATAL_FAILURE(run_both(p, fine, full, a, b));
  for (std::size_t k = 1; k < a.size(); ++k) {
    int both = 0, agree = 0;
    for (int y = 0; y < a[k].disparity.rows; ++y)
      for (int x = 0; x < a[k].disparity.cols; ++x) {
        float u = a[k].disparity.at<float>(y, x), v = b[k].disparity.at<float>(y, x);
        if (u < 0 || v < 0) continue;
        ++both;
        agree += std::abs(u - v) <= 0.25 * p.left->geometry[k].step_x;
      }
    EXPECT_GT(both, 200) << "level " << k;
    EXPECT_GE(static_cast<double>(agree) / both, 0.93) << "level " << k;  // measured 0.95 and up
  }
}

TEST(RetinaStereo, TheRetinasOwnPixelsStandInForSamplingThemAgain) {
  // Without keep_images the left level's pixels come from the retina and
  // only a window's half width around them from the frame, and the verged
  // right level takes the right retina's pixels where it overlaps them
  // (moved by the vergence); with it both padded levels are sampled whole.
  // Same matches to the bit, at fractional steps (15.25, 10.5, 5.75 here)
  // and with the fovea at the frame's edge.
  for (cv::Point2d fovea : {cv::Point2d(320, 240), cv::Point2d(20, 470)}) {
    Pair p = make_pair(12, fovea);
    RetinaStereoConfig reused, sampled;
    reused.vergence = sampled.vergence = true;
    reused.max_disparity = sampled.max_disparity = 48;
    sampled.keep_images = true;
    std::vector<LevelDisparity> a, b;
    ASSERT_NO_FATAL_FAILURE(run_both(p, reused, sampled, a, b));
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_GT(a[k].density, 0.3) << "level " << k;
      for (auto [u, v] : {std::pair{&a[k].disparity, &b[k].disparity}, std::pair{&a[k].reverse, &b[k].reverse},
                          std::pair{&a[k].score, &b[k].score}})
        EXPECT_EQ(cv::countNonZero(*u != *v), 0) << "level " << k << " fovea " << fovea;
    }
  }
}

TEST(RetinaStereo, RefusesMismatchedRetinas) {
  Pair p = make_pair(5, {320, 240});
  Pair q = make_pair(5, {100, 100});  // another fovea: regions differ in rows
  std::vector<LevelDisparity> out;
  EXPECT_NE(RetinaStereo({}).run(*p.left, *q.right, out).find("regions differ"), std::string::npos);
}

// A stereo node made from `node_xml`, run once on the pair; null (and a
// failure) when it cannot be made or fails.
std::unique_ptr<testing::NodeHarness> stereo_node_on(const Pair& p, const std::string& node_xml) {
  std::string error;
  auto h = testing::NodeHarness::create(node_xml, &error);
  EXPECT_NE(h, nullptr) << error;
  if (h == nullptr) return nullptr;
  h->set("left", p.left);
  h->set("right", p.right);
  const Status s = h->process();
  EXPECT_TRUE(s.ok()) << s.message();
  return s.ok() ? std::move(h) : nullptr;
}

TEST(StereoNode, EmitsDisparityConfidenceAndBothWays) {
  Pair p = make_pair(12, {320, 240});
  auto h = stereo_node_on(p, R"(<node plugin="stereo"><param name="max_disparity" value="64"/></node>)");
  ASSERT_NE(h, nullptr);
  auto maps = h->last<FeatureMaps>("maps");
  ASSERT_NE(maps, nullptr);
  EXPECT_EQ(maps->names, (std::vector<std::string>{"disparity", "disparity_rl", "confidence"}));
  EXPECT_EQ(maps->retina.get(), p.left.get());
  const cv::Mat& fovea = maps->find("disparity")->back();
  const cv::Mat& confidence = maps->find("confidence")->back();
  EXPECT_NEAR(fovea.at<float>(12, 20), 12.0, 0.25);
  EXPECT_GT(confidence.at<float>(12, 20), 0.9f);
}

TEST(StereoNode, SemiGlobalIsAParameterAndChecksItsPenalties) {
  Pair p = make_pair(12, {320, 240});
  for (const char* paths : {"4", "8"}) {
    auto h = stereo_node_on(p, std::string(R"(<node plugin="stereo"><param name="max_disparity" value="64"/>)") +
                                   R"(<param name="semi_global" value="true"/><param name="fill_gaps" value="2"/>)" +
                                   R"(<param name="sgm_paths" value=")" + paths + R"("/></node>)");
    ASSERT_NE(h, nullptr);
    auto maps = h->last<FeatureMaps>("maps");
    ASSERT_NE(maps, nullptr);
    EXPECT_NEAR(maps->find("disparity")->back().at<float>(12, 20), 12.0, 0.25) << paths << " paths";
  }
  std::string error;
  auto bad = testing::NodeHarness::create(
      R"(<node plugin="stereo"><param name="sgm_p1" value="1"/><param name="sgm_p2" value="0.5"/></node>)", &error);
  EXPECT_EQ(bad, nullptr);
  EXPECT_NE(error.find("sgm_p2"), std::string::npos) << error;
  auto six = testing::NodeHarness::create(R"(<node plugin="stereo"><param name="sgm_paths" value="6"/></node>)", &error);
  EXPECT_EQ(six, nullptr);
  EXPECT_NE(error.find("sgm_paths"), std::string::npos) << error;
}

TEST(StereoNode, EmitsTheFixationDisparityAndDepthFromFocalAndBaseline) {
  Pair p = make_pair(40, {320, 240});
  auto h = stereo_node_on(p, R"(<node plugin="stereo">
      <param name="max_disparity" value="64"/>
      <param name="focal" value="500"/><param name="baseline" value="0.1"/></node>)");
  ASSERT_NE(h, nullptr);
  auto fixation = h->last<Region>("fixation");
  ASSERT_NE(fixation, nullptr);
  EXPECT_NEAR(fixation->score, 40.0, 0.25);
  EXPECT_NEAR(fixation->depth, 500 * 0.1 / 40.0, 0.01);
  EXPECT_EQ(fixation->center, cv::Point2d(320, 240));
  auto maps = h->last<FeatureMaps>("maps");
  ASSERT_NE(maps->find("depth"), nullptr);
  const cv::Mat& disparity = maps->find("disparity")->back();
  const cv::Mat& depth = maps->find("depth")->back();
  int checked = 0;
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x) {
      const float d = disparity.at<float>(y, x);
      if (d <= 0) {
        EXPECT_LT(depth.at<float>(y, x), 0.0f);
        continue;
      }
      ++checked;
      EXPECT_NEAR(depth.at<float>(y, x), 50.0 / d, 1e-4);
    }
  EXPECT_GT(checked, 600) << "verged, the fovea matches nearly everywhere";

  std::string error;
  EXPECT_EQ(testing::NodeHarness::create(R"(<node plugin="stereo"><param name="focal" value="500"/></node>)", &error),
            nullptr);
  EXPECT_NE(error.find("baseline"), std::string::npos) << error;
}

TEST(FillHoles, TakesTheFartherNeighbourOnTheRowAndTheFallbackOnEmptyRows) {
  cv::Mat d = (cv::Mat_<float>(3, 6) << 10, -1, -1, 20, -1, -1,  //
               -1, -1, -1, -1, -1, -1,                             //
               -1, 30, -1, -1, -1, 40);
  cv::Mat c = (cv::Mat_<float>(3, 6) << 0.9f, -1, -1, 0.8f, -1, -1,  //
               -1, -1, -1, -1, -1, -1,                                  //
               -1, 0.7f, -1, -1, -1, 0.6f);
  EXPECT_DOUBLE_EQ(fill_holes(d, c, 15.0), 1.0);
  const cv::Mat expected = (cv::Mat_<float>(3, 6) << 10, 10, 10, 20, 20, 20,  //
                            15, 15, 15, 15, 15, 15,                           //
                            30, 30, 30, 30, 30, 40);
  EXPECT_EQ(cv::norm(d, expected, cv::NORM_INF), 0.0);
  EXPECT_FLOAT_EQ(c.at<float>(0, 1), 0.0f) << "filled: confidence 0";
  EXPECT_FLOAT_EQ(c.at<float>(0, 0), 0.9f) << "matched pixels keep theirs";
  cv::Mat empty(2, 3, CV_32F, cv::Scalar(-1)), none(2, 3, CV_32F, cv::Scalar(-1));
  EXPECT_DOUBLE_EQ(fill_holes(empty, none, -1.0), 0.0);
}

TEST(FillGaps, FillsOnlyShortRunsBetweenAgreeingEndsOfARow) {
  // Row 0: a gap of 2 between 10 and 10.5 (filled with 10), then one of 3
  // (too long). Row 1: a gap of 1 between 10 and 20 (ends disagree), and runs
  // at the row's ends (one end only). Row 2: a matched pixel with score 0 (as
  // semi-global gives) is an end, not a gap.
  cv::Mat d = (cv::Mat_<float>(3, 8) << 10, -1, -1, 10.5f, -1, -1, -1, 10.5f,  //
               -1, 10, -1, 20, 20, -1, -1, -1,                                  //
               12, 12, -1, 12.5f, -1, 13, 13, 13);
  cv::Mat c = (cv::Mat_<float>(3, 8) << 0.9f, -1, -1, 0.8f, -1, -1, -1, 0.7f,  //
               -1, 0.9f, -1, 0.9f, 0.9f, -1, -1, -1,                             //
               0.9f, 0.9f, -1, 0.0f, -1, 0.9f, 0.9f, 0.9f);
  const double density = fill_gaps(d, c, 2, 1.0);
  const cv::Mat expected = (cv::Mat_<float>(3, 8) << 10, 10, 10, 10.5f, -1, -1, -1, 10.5f,  //
                            -1, 10, -1, 20, 20, -1, -1, -1,                                 //
                            12, 12, 12, 12.5f, 12.5f, 13, 13, 13);
  EXPECT_EQ(cv::norm(d, expected, cv::NORM_INF), 0.0) << d;
  EXPECT_DOUBLE_EQ(density, 16.0 / 24.0);
  EXPECT_FLOAT_EQ(c.at<float>(0, 1), 0.0f) << "filled: confidence 0";
  EXPECT_FLOAT_EQ(c.at<float>(0, 4), -1.0f) << "left unmatched";
  EXPECT_FLOAT_EQ(c.at<float>(2, 3), 0.0f) << "matched with score 0: kept";
}

TEST(StereoCalibration, ReadsFocalAndBaselineFromQOrP2OrM1AndT) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(SACCADE_BINARY_DIR) / "test_out" / "calibration";
  fs::create_directories(dir);
  auto write = [&](const std::string& name, auto&& body) {
    cv::FileStorage fs((dir / name).string(), cv::FileStorage::WRITE);
    body(fs);
    return (dir / name).string();
  };
  StereoCalibration c;
  // As cv::stereoRectify writes it: Q(2,3) = f, Q(3,2) = -1/Tx with Tx = -B.
  const std::string q = write("q.yml", [](cv::FileStorage& fs) {
    fs << "Q" << (cv::Mat_<double>(4, 4) << 1, 0, 0, -320, 0, 1, 0, -240, 0, 0, 0, 534.8, 0, 0, 1 / 0.06, 0);
  });
  ASSERT_EQ(read_calibration(q, c), "");
  EXPECT_NEAR(c.focal_px, 534.8, 1e-9);
  EXPECT_NEAR(c.baseline_m, 0.06, 1e-12);
  const std::string p2 = write("p2.xml", [](cv::FileStorage& fs) {
    fs << "P2" << (cv::Mat_<double>(3, 4) << 500, 0, 320, -500 * 0.12, 0, 500, 240, 0, 0, 0, 1, 0);
  });
  c = {};
  ASSERT_EQ(read_calibration(p2, c), "");
  EXPECT_NEAR(c.focal_px, 500, 1e-9);
  EXPECT_NEAR(c.baseline_m, 0.12, 1e-12);
  const std::string mt = write("mt.yml", [](cv::FileStorage& fs) {
    fs << "M1" << (cv::Mat_<double>(3, 3) << 600, 0, 320, 0, 600, 240, 0, 0, 1);
    fs << "T" << (cv::Mat_<double>(3, 1) << -0.09, 0, 0);
  });
  c = {};
  ASSERT_EQ(read_calibration(mt, c), "");
  EXPECT_NEAR(c.baseline_m, 0.09, 1e-12);
  // OpenCV's own intrinsics.yml (M1, D1, M2, D2, no extrinsics): a clear error.
  c = {};
  const std::string only_intrinsics = test::sample_path("intrinsics.yml");
  EXPECT_NE(read_calibration(only_intrinsics, c).find("expected Q"), std::string::npos);
  EXPECT_NE(read_calibration("/nonexistent.yml", c).find("/nonexistent.yml"), std::string::npos);
}

}  // namespace
}  // namespace saccade::stereo
