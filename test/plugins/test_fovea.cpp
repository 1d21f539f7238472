// The fovea controller's parts (saliency, inhibition of return, template
// tracking, the state machine, gaze requests) and its plugin.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "controller.hpp"
#include "fovea_params.hpp"
#include "retina.hpp"
#include "support.hpp"

namespace saccade {
namespace {

using namespace saccade::fovea;

// A smooth, dim background: nothing salient on it.
cv::Mat plain_background(cv::Size size = {640, 480}) {
  cv::Mat bg(size, CV_8UC1);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) bg.at<uint8_t>(y, x) = static_cast<uint8_t>(90 + 20.0 * x / size.width);
  return bg;
}

// A 16x16 checkerboard target (2 px cells, dark and light) centred on `c`.
void draw_target(cv::Mat& frame, cv::Point2d c, int seed = 1, int size = 16) {
  cv::Mat texture = test::random_image({size, size}, seed);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const bool dark = ((x / 2) + (y / 2)) % 2 == 0;
      texture.at<uint8_t>(y, x) = static_cast<uint8_t>((dark ? 30 : 220) + texture.at<uint8_t>(y, x) / 16);
    }
  const cv::Point corner(static_cast<int>(std::lround(c.x - size / 2.0)),
                         static_cast<int>(std::lround(c.y - size / 2.0)));
  texture.copyTo(frame(cv::Rect(corner, cv::Size(size, size))));
}

std::shared_ptr<Retina> make_retina(const cv::Mat& frame, cv::Point2d fovea, int64_t id = 0) {
  static retina::RetinaSampler sampler({});
  auto r = std::make_shared<Retina>();
  sampler.sample(frame, fovea, *r);
  auto image = std::make_shared<Image>();
  image->mat = frame;
  r->source = image;
  r->frame_id = id;
  return r;
}

TEST(Saliency, PeaksOnATargetAnywhereInTheFrame) {
  for (cv::Point2d where : {cv::Point2d(100, 90), cv::Point2d(500, 380), cv::Point2d(330, 250)}) {
    cv::Mat frame = plain_background();
    draw_target(frame, where);
    auto retina = make_retina(frame, {320, 240});
    Saliency s({});
    s.compute(*retina, nullptr);
    InhibitionOfReturn none(40, 10);
    const Candidate c = s.peak(none);
    ASSERT_TRUE(c.valid());
    const double step = retina->geometry[static_cast<std::size_t>(c.level)].step_x;
    // Within the target (8 px from its centre) plus one cell of the level it was found on.
    EXPECT_LE(cv::norm(c.point - where), 8 + step) << where << " found at " << c.point << " on level " << c.level;
  }
}

TEST(Saliency, BlobCenterIsTheObjectsCenterNotItsMostSalientCorner) {
  cv::Mat frame = plain_background();
  const cv::Point2d where(323, 245);
  draw_target(frame, where);
  auto retina = make_retina(frame, {320, 240});
  Saliency s({});
  s.compute(*retina, nullptr);
  const int inner = static_cast<int>(retina->levels.size()) - 1;
  const Candidate c = s.peak_on_level(inner, 0, 0);
  bool cut = true;
  const cv::Point2d center = s.blob_center(inner, c.point, 0.5, &cut);
  EXPECT_FALSE(cut);
  EXPECT_LE(cv::norm(center - where), 2.0) << center;
  // Half outside the fovea: the blob is cut, and says so.
  auto off = make_retina(frame, {323 + 16, 245});
  s.compute(*off, nullptr);
  s.blob_center(inner, where, 0.5, &cut);
  EXPECT_TRUE(cut);
}

TEST(Saliency, MotionMakesTheMovingOneOfTwoTwinsWin) {
  cv::Mat frame = plain_background();
  draw_target(frame, {150, 240}, 7);
  draw_target(frame, {490, 240}, 7);
  auto retina = make_retina(frame, {320, 240});
  // dI: the right twin moved (difference on its area only).
  std::vector<cv::Mat> dI;
  for (std::size_t k = 0; k < retina->levels.size(); ++k) {
    cv::Mat d(retina->levels[k].size(), CV_32F, cv::Scalar(0));
    const auto& g = retina->geometry[k];
    for (int y = 0; y < d.rows; ++y)
      for (int x = 0; x < d.cols; ++x)
        if (cv::norm(g.to_source(x, y) - cv::Point2d(490, 240)) < 12) d.at<float>(y, x) = 60;
    dI.push_back(d);
  }
  Saliency s({});
  s.compute(*retina, &dI);
  const Candidate c = s.peak(InhibitionOfReturn(40, 10));
  EXPECT_LT(cv::norm(c.point - cv::Point2d(490, 240)), 30) << c.point;
}

TEST(Saliency, ColorTermPrefersTheWantedColor) {
  cv::Mat frame(480, 640, CV_8UC3, cv::Scalar(100, 100, 100));
  cv::circle(frame, {150, 240}, 10, cv::Scalar(0, 0, 255), cv::FILLED);  // red
  cv::circle(frame, {490, 240}, 10, cv::Scalar(255, 0, 0), cv::FILLED);  // blue
  auto retina = make_retina(frame, {320, 240});
  SaliencyConfig config;
  config.color = cv::Vec3d(255, 0, 0);
  config.color_weight = 4.0;
  Saliency s(config);
  s.compute(*retina, nullptr);
  EXPECT_LT(cv::norm(s.peak(InhibitionOfReturn(40, 10)).point - cv::Point2d(490, 240)), 30);
}

TEST(InhibitionOfReturn, InhibitsADiscThatFadesAndMovesWithTheScene) {
  InhibitionOfReturn ior(20, 4);
  ior.add({100, 100});
  EXPECT_DOUBLE_EQ(ior.at({110, 100}), 1.0);
  EXPECT_DOUBLE_EQ(ior.at({125, 100}), 0.0);
  ior.tick();
  ior.tick();
  EXPECT_DOUBLE_EQ(ior.at({100, 100}), 0.5);
  ior.shift({50, 0});
  EXPECT_DOUBLE_EQ(ior.at({100, 100}), 0.0);
  EXPECT_DOUBLE_EQ(ior.at({150, 100}), 0.5);
  ior.tick();
  ior.tick();
  EXPECT_DOUBLE_EQ(ior.at({150, 100}), 0.0);
}

TEST(InhibitionOfReturn, MovesAttentionToTheNextPlace) {
  cv::Mat frame = plain_background();
  const std::vector<cv::Point2d> places = {{120, 100}, {520, 120}, {300, 380}};
  for (std::size_t i = 0; i < places.size(); ++i) draw_target(frame, places[i], static_cast<int>(i) + 1);
  auto retina = make_retina(frame, {320, 240});
  Saliency s({});
  s.compute(*retina, nullptr);
  InhibitionOfReturn ior(60, 100);
  std::vector<bool> seen(places.size(), false);
  for (std::size_t n = 0; n < places.size(); ++n) {
    const Candidate c = s.peak(ior);
    ASSERT_TRUE(c.valid());
    for (std::size_t i = 0; i < places.size(); ++i)
      if (cv::norm(c.point - places[i]) < 40) {
        EXPECT_FALSE(seen[i]) << "place " << i << " visited twice";
        seen[i] = true;
      }
    ior.add(c.point);
  }
  for (std::size_t i = 0; i < places.size(); ++i) EXPECT_TRUE(seen[i]) << "place " << i << " never visited";
}

TEST(MatchTemplateNormed, IsOpenCvsNormalisedCorrelationCoefficient) {
  CorrelationScratch scratch;
  for (int trial = 0; trial < 4; ++trial) {
    cv::Mat window, templ, ours, theirs;
    test::random_image({40, 32}, 60 + trial).convertTo(window, CV_32F);
    window(cv::Rect(0, 0, 14, 14)).setTo(90);        // flat placements score 0 in both
    window(cv::Rect(20, 10, 12, 12)).copyTo(templ);  // one perfect match
    match_template_normed(window, templ, ours, scratch);
    cv::matchTemplate(window, templ, theirs, cv::TM_CCOEFF_NORMED);
    ASSERT_EQ(ours.size(), theirs.size());
    double worst = 0;
    cv::Point at;
    for (int y = 0; y < ours.rows; ++y)
      for (int x = 0; x < ours.cols; ++x)
        worst = std::max(worst, std::fabs(double(ours.at<float>(y, x)) - theirs.at<float>(y, x)));
    EXPECT_LT(worst, 1e-4) << "trial " << trial;
    cv::minMaxLoc(ours, nullptr, nullptr, nullptr, &at);
    EXPECT_EQ(at, cv::Point(20, 10));
    EXPECT_EQ(ours.at<float>(0, 0), 0.0f) << "flat window";
  }
}

// The placements' sums are slid along four result rows at a time: results of
// one to nine rows (a block part-filled, whole, and one over), from one
// scratch reused across the sizes, are OpenCV's too.
TEST(MatchTemplateNormed, IsOpenCvsForResultsOfAnyNumberOfRows) {
  CorrelationScratch scratch;
  cv::Mat templ, ours, theirs;
  test::random_image({7, 5}, 3).convertTo(templ, CV_32F);
  for (int rows = 1; rows <= 9; ++rows) {
    cv::Mat window;
    test::random_image({30, templ.rows + rows - 1}, 70 + rows).convertTo(window, CV_32F);
    match_template_normed(window, templ, ours, scratch);
    cv::matchTemplate(window, templ, theirs, cv::TM_CCOEFF_NORMED);
    ASSERT_EQ(ours.size(), theirs.size()) << rows << " rows";
    EXPECT_LT(cv::norm(ours, theirs, cv::NORM_INF), 1e-4) << rows << " rows";
  }
}

// Normalised, a nearly flat window's faint shading matches any template: the
// box tracker's whole-frame search asks for windows of at least a quarter of
// its look's contrast (a white wall took one of its places on every search).
TEST(MatchTemplateNormed, AWindowOfTooLittleContrastScoresZeroWhenAsked) {
  CorrelationScratch scratch;
  cv::Mat texture, templ, window(40, 60, CV_32F, cv::Scalar(200)), scores;
  test::random_image({12, 12}, 9).convertTo(texture, CV_32F);
  texture.copyTo(templ);
  texture.copyTo(window(cv::Rect(4, 4, 12, 12)));                // the look itself
  cv::Mat faint = 200 + (texture - cv::mean(texture)[0]) * 0.1;  // the same shading at a tenth of its contrast
  faint.copyTo(window(cv::Rect(36, 20, 12, 12)));
  match_template_normed(window, templ, scores, scratch);
  EXPECT_GT(scores.at<float>(4, 4), 0.999f);
  EXPECT_GT(scores.at<float>(20, 36), 0.999f) << "normalised, a faint copy matches as well";
  match_template_normed(window, templ, scores, scratch, 0.25);
  EXPECT_GT(scores.at<float>(4, 4), 0.999f);
  EXPECT_EQ(scores.at<float>(20, 36), 0.0f);
  match_template_normed(window, templ, scores, scratch, 0.05);
  EXPECT_GT(scores.at<float>(20, 36), 0.999f) << "a tenth of the contrast passes a floor of a twentieth";
}

TEST(TemplateTracker, FindsATextureShiftedByWholeAndHalfPixels) {
  cv::Mat base = test::random_image({640, 480}, 3);
  cv::GaussianBlur(base, base, cv::Size(5, 5), 1.2);
  TemplateTracker tracker({});
  const cv::Point2d start(320, 240);
  ASSERT_TRUE(tracker.acquire(*make_retina(base, start), start));
  // The default window (40x32) with a 12x12 template reaches 14 px across and 10 down.
  for (cv::Point2d shift : {cv::Point2d(7, -5), cv::Point2d(-13, 9), cv::Point2d(0.5, 0), cv::Point2d(3.5, -2.5)}) {
    cv::Mat moved;
    const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, shift.x, 0, 1, shift.y);
    cv::warpAffine(base, moved, m, base.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    const auto match = tracker.match(*make_retina(moved, start));
    ASSERT_TRUE(match.found) << shift;
    EXPECT_GT(match.score, 0.9);
    // Whole pixels: the parabola through a symmetric peak barely moves it;
    // half pixels: the parabola's known bias on a sharp texture.
    const double tolerance = shift.x == std::floor(shift.x) && shift.y == std::floor(shift.y) ? 0.05 : 0.3;
    EXPECT_NEAR(match.point.x, start.x + shift.x, tolerance) << shift;
    EXPECT_NEAR(match.point.y, start.y + shift.y, tolerance) << shift;
  }
}

TEST(TemplateTracker, RefusesFlatPatchesAndReportsNoMatchWhenTheTargetIsGone) {
  cv::Mat flat(480, 640, CV_8UC1, cv::Scalar(128));
  TemplateTracker tracker({});
  EXPECT_FALSE(tracker.acquire(*make_retina(flat, {320, 240}), {320, 240}));
  cv::Mat frame = plain_background();
  draw_target(frame, {320, 240});
  ASSERT_TRUE(tracker.acquire(*make_retina(frame, {320, 240}), {320, 240}));
  EXPECT_FALSE(tracker.match(*make_retina(plain_background(), {320, 240})).found);
}

// A target moving on a straight line at `speed` px/frame, seen through the
// controller's own fovea (fed back as the retina's fovea on the next frame).
struct Loop {
  FoveaController controller;
  cv::Point2d fovea{320, 240};
  explicit Loop(ControllerConfig c = {}) : controller(c) {}
  Decision step(const cv::Mat& frame, int64_t id) {
    auto retina = make_retina(frame, fovea, id);
    Decision d = controller.step(*retina, nullptr, nullptr);
    fovea = d.next;
    return d;
  }
};

// The fovea node's box_* parameters are the box tracker's: with
// box_unsure_frames and box_lost_frames 1 the target is lost on the first
// frame it is gone, with the defaults (30, 5) it is only uncertain then. (Until the tenth session of
// 2026-11-29 the controller's box tracker was made with the defaults, and
// every box_* parameter of a graph was checked and then ignored.)
TEST(FoveaController, ItsBoxTrackerTakesTheNodesBoxParameters) {
  auto first_frame_without_the_target = [](ControllerConfig c) {
    Loop loop(c);
    cv::Mat frame = plain_background();
    draw_target(frame, {320, 240});
    EXPECT_TRUE(loop.controller.track_box(frame, {312, 232, 16, 16}).ok());
    loop.step(frame, 0);
    loop.step(frame, 1);
    return loop.step(plain_background(), 2).state;
  };
  ControllerConfig quick;
  quick.box.unsure_frames = quick.box.lost_frames = 1;
  EXPECT_EQ(first_frame_without_the_target(quick), FoveaState::State::kLost);
  EXPECT_EQ(first_frame_without_the_target({}), FoveaState::State::kUncertain);
}

TEST(FoveaController, LocksOnTheSalientTargetAndFollowsItWithPrediction) {
  Loop loop;
  cv::Point2d p(300, 250);
  const cv::Point2d v(6, -3);
  int tracking = 0;
  double error_sum = 0;
  for (int k = 0; k < 40; ++k, p += v) {
    cv::Mat frame = plain_background();
    draw_target(frame, p);
    const cv::Point2d fovea_used = loop.fovea;
    Decision d = loop.step(frame, k);
    if (k >= 5) {
      EXPECT_EQ(d.state, FoveaState::State::kTracking) << "frame " << k;
      tracking += d.state == FoveaState::State::kTracking;
      EXPECT_LE(cv::norm(d.target - p), 1.0) << "frame " << k;
      error_sum += cv::norm(fovea_used - p);
    }
  }
  EXPECT_EQ(tracking, 35);
  EXPECT_LE(error_sum / 35, 1.5) << "the fovea is put where the target will be";
}

TEST(FoveaController, ReportsLostThenSearchesAndFindsTheTargetAgain) {
  ControllerConfig config;
  config.coast_frames = 2;
  Loop loop(config);
  cv::Mat frame = plain_background();
  draw_target(frame, {320, 240});
  for (int k = 0; k < 5; ++k) loop.step(frame, k);
  ASSERT_EQ(loop.step(frame, 5).state, FoveaState::State::kTracking);
  // It vanishes: lost, coasting, then searching the frame.
  cv::Mat empty = plain_background();
  for (int k = 6; k < 10; ++k) EXPECT_EQ(loop.step(empty, k).state, FoveaState::State::kLost);
  EXPECT_GT(loop.controller.frames_lost(), 3);
  // It reappears elsewhere: found again.
  cv::Mat back = plain_background();
  draw_target(back, {150, 380});
  bool reacquired = false;
  for (int k = 10; k < 20 && !reacquired; ++k) reacquired = loop.step(back, k).reacquired;
  EXPECT_TRUE(reacquired);
  EXPECT_LT(cv::norm(loop.fovea - cv::Point2d(150, 380)), 3.0);
}

TEST(FoveaController, AsksTheHeadToTurnWhenTheFoveaReachesTheMarginAndRecentersAfterwards) {
  ControllerConfig config;
  config.border_margin = 20;
  config.hfov_deg = 90;  // focal = half the width: direction x = (u - cx) / 320
  Loop loop(config);
  cv::Point2d p(400, 240);
  std::optional<GazeRequest> request;
  int64_t request_frame = -1;
  for (int k = 0; k < 60 && !request; ++k, p.x += 5) {
    cv::Mat frame = plain_background();
    draw_target(frame, p);
    Decision d = loop.step(frame, k);
    const bool near = d.next.x + 16 > 640 - 20;
    if (!near) { EXPECT_FALSE(d.gaze) << "frame " << k; }
    if (d.gaze) {
      request = d.gaze;
      request_frame = k;
      EXPECT_TRUE(near);
    }
  }
  ASSERT_TRUE(request) << "no gaze request";
  EXPECT_EQ(request->reason, "border");
  EXPECT_EQ(request->image_size, cv::Size(640, 480));
  const cv::Vec3d expected =
      cv::normalize(cv::Vec3d((request->pixel.x - 320) / 320, (request->pixel.y - 240) / 320, 1));
  EXPECT_LT(cv::norm(request->direction - expected), 1e-9);
  // The head turns so that the requested pixel comes to the centre: the scene
  // shifts, and the fovea follows the target there.
  const cv::Point2d shift = cv::Point2d(320, 240) - request->pixel;
  loop.controller.head_moved(request->pixel, {640, 480});
  p += shift;
  for (int k = 0; k < 4; ++k, p.x += 5) {
    cv::Mat frame = plain_background();
    draw_target(frame, p);
    Decision d = loop.step(frame, request_frame + 1 + k);
    EXPECT_EQ(d.state, FoveaState::State::kTracking) << k;
    EXPECT_FALSE(d.gaze);
  }
  EXPECT_LT(cv::norm(loop.fovea - p), 8.0) << "recentred near the image centre";
  EXPECT_EQ(loop.controller.gaze_requests(), 1);
}

TEST(FoveaController, AttendModeVisitsEverySalientPlaceInTurn) {
  ControllerConfig config;
  config.mode = FoveaMode::kAttend;
  config.saliency.level_boost = 0.5;  // the places off the fovea are seen on outer levels only
  config.dwell_frames = 4;
  config.ior_radius = 60;
  config.ior_frames = 200;
  Loop loop(config);
  cv::Mat frame = plain_background();
  const std::vector<cv::Point2d> places = {{120, 100}, {520, 120}, {300, 380}, {560, 420}};
  for (std::size_t i = 0; i < places.size(); ++i) draw_target(frame, places[i], static_cast<int>(i) + 1);
  std::vector<int> visits(places.size(), 0);
  for (int k = 0; k < 40; ++k) {
    Decision d = loop.step(frame, k);
    if (std::getenv("SACCADE_TEST_VERBOSE"))
      std::printf("%d %s next %.1f %.1f target %.1f %.1f shift %d\n", k, to_string(d.state), d.next.x, d.next.y,
                  d.target.x, d.target.y, d.attention_shift);
    if (d.state != FoveaState::State::kTracking) continue;
    for (std::size_t i = 0; i < places.size(); ++i)
      if (cv::norm(d.target - places[i]) < 10) ++visits[i];
  }
  for (std::size_t i = 0; i < places.size(); ++i) EXPECT_GE(visits[i], 3) << "place " << i;
  EXPECT_GE(loop.controller.attention_shifts(), 4);
}

TEST(FoveaController, FindsAGivenTemplateTopDownAmongDistractors) {
  cv::Mat frame = plain_background();
  draw_target(frame, {150, 120}, 1);
  draw_target(frame, {480, 360}, 2);
  draw_target(frame, {500, 110}, 3);
  // The template: the middle 12x12 of target 2.
  cv::Mat wanted = frame(cv::Rect(480 - 6, 360 - 6, 12, 12)).clone();
  Loop loop;
  ASSERT_TRUE(loop.controller.set_template(wanted));
  bool found = false;
  for (int k = 0; k < 30 && !found; ++k) found = loop.step(frame, k).state == FoveaState::State::kTracking;
  ASSERT_TRUE(found);
  EXPECT_LT(cv::norm(loop.fovea - cv::Point2d(480, 360)), 1.5);
}

TEST(FoveaPlugin, EmitsTheNextFoveaStateAndRejectsBadParameters) {
  auto h = testing::NodeHarness::create(R"(<node plugin="fovea"/>)").value_or(nullptr);
  ASSERT_TRUE(h);
  cv::Mat frame = plain_background();
  draw_target(frame, {300, 250});
  h->set("retina", make_retina(frame, {320, 240}, 0));
  ASSERT_TRUE(h->process().ok());
  auto fovea = h->last<Region>("fovea");
  auto state = h->last<FoveaState>("state");
  ASSERT_TRUE(fovea && state);
  EXPECT_EQ(fovea->label, "searching");
  EXPECT_LT(cv::norm(fovea->center - cv::Point2d(300, 250)), 20);
  EXPECT_TRUE(state->attention_shift);
  EXPECT_TRUE(state->retina);
  EXPECT_EQ(h->outputs("gaze").size(), 0u);
  // It looks, centres on the target, and locks on it within a few frames.
  for (int64_t k = 1; k < 5 && h->last<Region>("fovea")->label != "tracking"; ++k) {
    h->set("retina", make_retina(frame, h->last<Region>("fovea")->center, k));
    ASSERT_TRUE(h->process().ok());
  }
  EXPECT_EQ(h->last<Region>("fovea")->label, "tracking");
  EXPECT_LT(cv::norm(h->last<Region>("fovea")->center - cv::Point2d(300, 250)), 1.5);

  const auto bad_color =
      testing::NodeHarness::create(R"(<node plugin="fovea"><param name="color" value="255,0"/></node>)");
  EXPECT_FALSE(bad_color.ok());
  EXPECT_THAT(bad_color.error(), ::testing::HasSubstr("B,G,R"));
  const auto no_template =
      testing::NodeHarness::create(R"(<node plugin="fovea"><param name="template" value="/nonexistent.png"/></node>)");
  EXPECT_FALSE(no_template.ok());
  EXPECT_THAT(no_template.error(), ::testing::HasSubstr("/nonexistent.png"));
}

// A textured 40x30 target (a real photograph's patch) on the plain
// background, so that the box tracker has something to learn.
cv::Mat frame_with_patch(cv::Point2d center) {
  static const cv::Mat patch = [] {
    cv::Mat image = cv::imread(test::sample_path("baboon.jpg"), cv::IMREAD_GRAYSCALE), p;
    cv::resize(image(cv::Rect(180, 40, 160, 120)), p, {40, 30}, 0, 0, cv::INTER_AREA);
    return p;
  }();
  cv::Mat frame = plain_background();
  patch.copyTo(frame(cv::Rect(static_cast<int>(center.x) - 20, static_cast<int>(center.y) - 15, 40, 30)));
  return frame;
}

TEST(FoveaPlugin, FollowsTheBoxGivenByInitAndReportsItsBoxConfidenceAndState) {
  auto h = testing::NodeHarness::create(R"(<node plugin="fovea"><param name="init" value="180,135,40,30,2"/></node>)")
               .value_or(nullptr);
  ASSERT_TRUE(h);
  cv::Point2d at(200, 150), fovea(320, 240);
  for (int64_t k = 0; k < 40; ++k, at += cv::Point2d(3, 1)) {
    h->set("retina", make_retina(frame_with_patch(k < 2 ? cv::Point2d(200, 150) : at - cv::Point2d(6, 2)), fovea, k));
    ASSERT_TRUE(h->process().ok()) << k;
    fovea = h->last<Region>("fovea")->center;
  }
  auto state = h->last<FoveaState>("state");
  ASSERT_TRUE(state);
  EXPECT_EQ(state->state, FoveaState::State::kTracking);
  EXPECT_TRUE(state->target_valid);
  const cv::Point2d truth = at - cv::Point2d(9, 3);  // where the last frame drew it
  EXPECT_LT(cv::norm(state->target.center() - truth), 2.0) << state->target.x << "," << state->target.y;
  EXPECT_NEAR(state->target.w, 40, 4);
  EXPECT_NEAR(state->target.h, 30, 3);
  EXPECT_GT(state->confidence, 6.0);
  EXPECT_LT(cv::norm(fovea - truth), 2.0) << "the fovea follows the target";
}

TEST(FoveaPlugin, ASizedTargetStartsTheBoxTrackerAndABadOneChangesNothing) {
  auto h = testing::NodeHarness::create(R"(<node plugin="fovea"/>)").value_or(nullptr);
  ASSERT_TRUE(h);
  const cv::Mat frame = frame_with_patch({400, 300});
  auto bad = std::make_shared<Region>();
  bad->center = {700, 300};  // outside the 640x480 frame
  bad->size = {40, 30};
  h->set("target", bad);
  h->set("retina", make_retina(frame, {320, 240}, 0));
  ASSERT_TRUE(h->process().ok());
  EXPECT_EQ(h->counter("bad_targets"), 1u);
  EXPECT_EQ(h->last<FoveaState>("state")->state, FoveaState::State::kSearching) << "no state change";
  auto good = std::make_shared<Region>();
  good->center = {400, 300};
  good->size = {40, 30};
  h->set("target", good);
  h->set("retina", make_retina(frame, {320, 240}, 1));
  ASSERT_TRUE(h->process().ok());
  h->set("retina", make_retina(frame, h->last<Region>("fovea")->center, 2));
  ASSERT_TRUE(h->process().ok());
  auto state = h->last<FoveaState>("state");
  EXPECT_EQ(state->state, FoveaState::State::kTracking);
  EXPECT_LT(cv::norm(state->target.center() - cv::Point2d(400, 300)), 1.5);
  EXPECT_EQ(h->counter("bad_targets"), 1u);
}

TEST(FoveaPlugin, BadBoxesAndTemplatesAreErrorsAtOpenNamingTheValue) {
  for (const char* bad : {"10,10,40", "10,10,40,30,x", "a,b,c,d", "10,10,4,30", "10,10,40,30,-1", "10,10,40,30,1.5"}) {
    const auto h = testing::NodeHarness::create(std::string(R"(<node plugin="fovea"><param name="init" value=")") +
                                                bad + R"("/></node>)");
    EXPECT_FALSE(h.ok()) << bad;
    EXPECT_THAT(h.error(), ::testing::HasSubstr(bad));
  }
  const auto too_large =
      testing::NodeHarness::create(R"(<node plugin="fovea"><param name="template_size" value="50x20"/>
      <param name="search_size" value="40x32"/></node>)");
  EXPECT_FALSE(too_large.ok());
  EXPECT_THAT(too_large.error(), ::testing::HasSubstr("template_size 50x20 is larger than search_size 40x32"));
  // A box outside the frame is known only with the first frame: an error then, naming both.
  auto h = testing::NodeHarness::create(R"(<node plugin="fovea"><param name="init" value="900,10,40,30"/></node>)")
               .value_or(nullptr);
  ASSERT_TRUE(h);
  h->set("retina", make_retina(plain_background(), {320, 240}, 0));
  const Status s = h->process();
  EXPECT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("900,10,40,30"));
  EXPECT_THAT(s.message(), ::testing::HasSubstr("640x480"));
}

// A box tracker parameter bound on the node (once for the node and the
// benchmark's --set): `expected` by default, "0" turns it off, and
// `refused` is an error naming it.
template <class T>
void expect_default_off_and_refused(const std::string& name, T BoxTrackerConfig::*member, T expected,
                                    const std::string& refused) {
  const Result<ControllerConfig> defaults = configure(&bind_fovea_params, {});
  ASSERT_TRUE(defaults.ok()) << defaults.error();
  EXPECT_EQ(defaults->box.*member, expected) << name;
  const Result<ControllerConfig> off = configure(&bind_fovea_params, {{name, "0"}});
  ASSERT_TRUE(off.ok()) << off.error();
  EXPECT_EQ(off->box.*member, T{0}) << name;
  EXPECT_THAT(configure(&bind_fovea_params, {{name, refused}}).error(), ::testing::HasSubstr(name));
}

// The node's parameters, bound once for the node and the benchmark's --set:
// the box tracker's colour histogram check asks a quarter of the colours by
// default (docs/tracking.md), 0 turns it off, and a share outside 0..1 is
// refused by name.
TEST(FoveaParams, TheSharedColoursCheckAsksAQuarterByDefaultAndItsShareIsChecked) {
  expect_default_off_and_refused("box_min_shared_colors", &BoxTrackerConfig::min_shared_colors, 0.25, "1.5");
  const Result<ControllerConfig> asked = configure(&bind_fovea_params, {{"box_min_shared_colors", "0.45"}});
  ASSERT_TRUE(asked.ok()) << asked.error();
  EXPECT_DOUBLE_EQ(asked->box.min_shared_colors, 0.45);
}

// The re-detection's size limit: 3% a frame by default, 0 lifts it, a
// negative share is refused by name.
TEST(FoveaParams, TheReDetectionsSizeLimitIsThreePercentAFrameByDefaultAndChecked) {
  expect_default_off_and_refused("box_max_size_change", &BoxTrackerConfig::max_size_change, 0.03, "-0.1");
}

// From a re-detection, unsure frames measure the size for 10 frames (its own
// counted) by default; 0 leaves it to tracked frames; a negative count is
// refused by name.
TEST(FoveaParams, TheSizeIsMeasuredForTenFramesAfterAReDetectionByDefaultAndChecked) {
  expect_default_off_and_refused("box_rescale_frames", &BoxTrackerConfig::rescale_frames, 10, "-1");
}

// A target that left the view is looked for within its size of the border
// it left by, plus how far the camera turned back, plus 0.05 of its size a
// frame (box_reentry_speed); 0 looks anywhere; a negative speed is refused
// by name.
TEST(FoveaParams, AReentryIsLookedForNearTheBorderTheTargetLeftByByDefaultAndChecked) {
  expect_default_off_and_refused("box_reentry_speed", &BoxTrackerConfig::reentry_speed, 0.05, "-0.1");
}

// A target not tracked is looked for elsewhere only within its size of where
// it was last tracked, moved with the image, plus 0.1 of its size a frame
// (box_reach_speed); 0 looks anywhere; a negative speed is refused by name.
TEST(FoveaParams, TheReachIsATenthOfTheTargetsSizeAFrameByDefaultAndChecked) {
  expect_default_off_and_refused("box_reach_speed", &BoxTrackerConfig::reach_speed, 0.1, "-0.1");
}

// Unsure, a look where the tracker sits at a larger size that peaks a
// quarter higher than at the target's gives it that size (box_resize_ratio);
// 0 never; a negative ratio is refused by name.
TEST(FoveaParams, AnUnsureTargetTakesASizeThatPeaksAQuarterHigherByDefaultAndChecked) {
  expect_default_off_and_refused("box_resize_ratio", &BoxTrackerConfig::resize_ratio, 1.25, "-1");
}

// For 30 frames from a re-detection, a tracked frame whose scale filter
// finds no size better than the others looks at 1.1 times the target's size
// and 1 / 1.1 (box_look_size_frames); 0 never; a negative count, a flatness
// over 1 and a step under 1 are refused by name.
TEST(FoveaParams, AFlatScaleAfterAReDetectionLooksAtOtherSizesFor30FramesByDefaultAndChecked) {
  expect_default_off_and_refused("box_look_size_frames", &BoxTrackerConfig::look_size_frames, 30, "-1");
  const Result<ControllerConfig> defaults = configure(&bind_fovea_params, {});
  ASSERT_TRUE(defaults.ok()) << defaults.error();
  EXPECT_DOUBLE_EQ(defaults->box.flat_scale, 0.75);
  EXPECT_DOUBLE_EQ(defaults->box.look_size_step, 1.1);
  EXPECT_THAT(configure(&bind_fovea_params, {{"box_flat_scale", "1.5"}}).error(),
              ::testing::HasSubstr("box_flat_scale"));
  EXPECT_THAT(configure(&bind_fovea_params, {{"box_look_size_step", "0.5"}}).error(),
              ::testing::HasSubstr("box_look_size_step"));
}

// A target without colours found near where it went, under the full bar,
// must share nine tenths of its tones (box_near_shared_tones); 0 asks the
// full bar of it; a share over 1 is refused by name.
TEST(FoveaParams, AColourlessTargetNearWhereItWentSharesNineTenthsOfItsTonesByDefaultAndChecked) {
  expect_default_off_and_refused("box_near_shared_tones", &BoxTrackerConfig::near_shared_tones, 0.9, "1.5");
}

TEST(FoveaParams, ColourProposalsAndTheTurnedScaleFilterAreOnByDefaultAndChecked) {
  const Result<ControllerConfig> defaults = configure(&bind_fovea_params, {});
  ASSERT_TRUE(defaults.ok()) << defaults.error();
  EXPECT_EQ(defaults->box.color_proposals, 1);
  EXPECT_EQ(defaults->box.scale_turn_min, 20.0);
  const Result<ControllerConfig> off =
      configure(&bind_fovea_params, {{"box_color_proposals", "0"}, {"box_scale_turn_min", "360"}});
  ASSERT_TRUE(off.ok()) << off.error();
  EXPECT_EQ(off->box.color_proposals, 0);
  EXPECT_EQ(off->box.scale_turn_min, 360.0);
  EXPECT_THAT(configure(&bind_fovea_params, {{"box_color_proposals", "-1"}}).error(),
              ::testing::HasSubstr("box_color_proposals"));
  EXPECT_THAT(configure(&bind_fovea_params, {{"box_scale_turn_min", "400"}}).error(),
              ::testing::HasSubstr("box_scale_turn_min"));
}

}  // namespace
}  // namespace saccade
