// The box tracker on scenes made of real images (opencv-doc) with exact truth:
// a target cut from one photograph moving over another, seen by a panning
// camera. Each test is one state change: acquire and track, scale change,
// lighting change, occlusion -> uncertain/lost -> re-detection, the camera's
// own move, and the boxes it refuses.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "box_tracker.hpp"
#include "view_motion.hpp"
#include "support.hpp"

// OpenCV's own parallel loops (the scenes' warps and forEach) run on TBB,
// whose synchronisation ThreadSanitizer cannot see; these tests do not need them.
static const bool kOpenCvSingleThread = (cv::setNumThreads(1), true);

namespace saccade {
namespace {

using namespace saccade::fovea;

cv::Mat read(const std::string& name) { return test::read_sample(name, cv::IMREAD_COLOR); }

// One frame: the background seen through a 320x240 window at `camera`, the
// target (scaled by `scale`, its brightness times `gain`) centred on
// `target`, and optionally an occluder (a patch of another part of the
// background) covering `occluder`.
struct Scene {
  cv::Mat background = read("fruits.jpg");
  cv::Mat target = read("baboon.jpg")(cv::Rect(180, 40, 150, 120)).clone();  // the mandrill's nose and eyes
  cv::Size frame{320, 240};

  cv::Mat render(cv::Point2d camera, cv::Point2d center, double scale = 0.3, double gain = 1.0,
                 cv::Rect occluder = {}) const {
    cv::Mat out =
        background(cv::Rect(cv::Point(static_cast<int>(camera.x), static_cast<int>(camera.y)), frame)).clone();
    cv::Mat t;
    cv::resize(target, t, cv::Size(), scale, scale, cv::INTER_AREA);
    const cv::Rect where(static_cast<int>(std::lround(center.x - t.cols / 2.0)),
                         static_cast<int>(std::lround(center.y - t.rows / 2.0)), t.cols, t.rows);
    const cv::Rect inside = where & cv::Rect(cv::Point(), frame);
    if (inside.area() > 0) t(inside - where.tl()).copyTo(out(inside));
    if (gain != 1.0) out.convertTo(out, -1, gain);
    if (occluder.area() > 0) {
      const cv::Rect o = occluder & cv::Rect(cv::Point(), frame);
      background(cv::Rect(0, 300, o.width, o.height)).copyTo(out(o));
    }
    return out;
  }
  cv::Rect2d box(cv::Point2d center, double scale = 0.3) const {
    const double w = std::round(target.cols * scale), h = std::round(target.rows * scale);
    return {center.x - w / 2, center.y - h / 2, w, h};
  }
};

cv::Point2d center(const cv::Rect2d& b) { return {b.x + b.width / 2, b.y + b.height / 2}; }

TEST(BoxTracker, FollowsATargetAcrossARealBackgroundWhileTheCameraPans) {
  const Scene scene;
  BoxTracker tracker;
  const auto path = [](int k) {
    return cv::Point2d(100 + 1.2 * k + 10 * std::sin(k * 0.1), 110 + 25 * std::sin(k * 0.05));
  };
  const auto camera = [](int k) { return cv::Point2d(50 + 0.5 * k, 40 + 5 * std::sin(k * 0.3)); };
  ASSERT_TRUE(tracker.init(scene.render(camera(0), path(0)), scene.box(path(0))).ok());
  double total = 0;
  for (int k = 1; k < 100; ++k) {
    const TrackEstimate e = tracker.update(scene.render(camera(k), path(k)));
    const double error = cv::norm(center(e.box) - path(k));
    total += error;
    EXPECT_EQ(e.state, TrackState::kTracking) << "frame " << k << " confidence " << e.confidence;
    EXPECT_LT(error, 4.0) << "frame " << k;
  }
  EXPECT_LT(total / 99, 1.5);
}

TEST(BoxTracker, PatchSidesOtherThanTheDefaultTrackToo) {
  // The filter's transform is the tracker's own for powers of two and
  // OpenCV's for other sides: both must follow the same pan.
  const Scene scene;
  const auto path = [](int k) { return cv::Point2d(100 + 1.2 * k, 110 + 20 * std::sin(k * 0.05)); };
  const auto camera = [](int k) { return cv::Point2d(50 + 0.5 * k, 40); };
  for (int side : {32, 48, 128}) {
    BoxTrackerConfig config;
    config.patch = side;
    BoxTracker tracker(config);
    ASSERT_TRUE(tracker.init(scene.render(camera(0), path(0)), scene.box(path(0))).ok()) << side;
    double total = 0;
    int tracked = 0;
    for (int k = 1; k < 60; ++k) {
      const TrackEstimate e = tracker.update(scene.render(camera(k), path(k)));
      total += cv::norm(center(e.box) - path(k));
      tracked += e.state == TrackState::kTracking;
    }
    std::printf("patch %d: mean centre error %.2f px, %d of 59 frames tracked\n", side, total / 59, tracked);
    EXPECT_LT(total / 59, 3.0) << "patch " << side;
    EXPECT_GE(tracked, 55) << "patch " << side;
  }
}

TEST(BoxTracker, TheBoxFollowsTheTargetsScale) {
  const Scene scene;
  BoxTracker tracker;
  const cv::Point2d c(160, 120);
  ASSERT_TRUE(tracker.init(scene.render({60, 60}, c, 0.25), scene.box(c, 0.25)).ok());
  TrackEstimate e;
  for (int k = 1; k <= 120; ++k) {
    const double scale = 0.25 * std::pow(1.6, k / 120.0);  // 1.6x over 4 s at 30 Hz
    e = tracker.update(scene.render({60, 60}, c, scale));
  }
  const cv::Rect2d truth = scene.box(c, 0.4);
  EXPECT_EQ(e.state, TrackState::kTracking);
  EXPECT_NEAR(e.box.width / truth.width, 1.0, 0.1) << e.box.width << " vs " << truth.width;
  EXPECT_LT(cv::norm(center(e.box) - c), 3.0);
}

TEST(BoxTracker, KeepsTheTargetThroughAChangeOfLight) {
  const Scene scene;
  BoxTracker tracker;
  const auto path = [](int k) { return cv::Point2d(120 + k, 120); };
  ASSERT_TRUE(tracker.init(scene.render({60, 60}, path(0)), scene.box(path(0))).ok());
  for (int k = 1; k <= 80; ++k) {
    const double gain = k < 20 ? 1.0 : std::max(0.45, 1.0 - (k - 20) * 0.02);  // dims to less than half
    const TrackEstimate e = tracker.update(scene.render({60, 60}, path(k), 0.3, gain));
    EXPECT_LT(cv::norm(center(e.box) - path(k)), 4.0) << "frame " << k;
    EXPECT_NE(e.state, TrackState::kLost) << "frame " << k;
  }
}

// The honest states: hidden for 40 frames, the target is not claimed
// (uncertain, then lost); when it comes back elsewhere in view, the
// whole-frame search finds it again within 15 frames.
TEST(BoxTracker, AHiddenTargetIsLostAndFoundAgainWhenItReappears) {
  const Scene scene;
  BoxTracker tracker;
  const cv::Point2d before(100, 120), after(230, 90);
  ASSERT_TRUE(tracker.init(scene.render({60, 60}, before), scene.box(before)).ok());
  for (int k = 1; k <= 20; ++k) ASSERT_EQ(tracker.update(scene.render({60, 60}, before)).state, TrackState::kTracking);
  int claimed = 0, lost = 0;
  for (int k = 0; k < 40; ++k) {
    const TrackEstimate e = tracker.update(scene.render({60, 60}, before, 0.3, 1.0, cv::Rect(50, 70, 110, 100)));
    if (std::getenv("SACCADE_TEST_VERBOSE")) std::printf("hidden %d %s %.1f\n", k, to_string(e.state), e.confidence);
    claimed += e.state == TrackState::kTracking;
    lost += e.state == TrackState::kLost;
  }
  EXPECT_LE(claimed, 4) << "at most 10% of the hidden frames claimed";
  EXPECT_GT(lost, 20) << "the target is given up, not followed for ever";
  int found_after = -1;
  for (int k = 0; k < 40 && found_after < 0; ++k) {
    const TrackEstimate e = tracker.update(scene.render({60, 60}, after));
    if (std::getenv("SACCADE_TEST_VERBOSE"))
      std::printf("after %d %s %.1f %.1f,%.1f\n", k, to_string(e.state), e.confidence, center(e.box).x,
                  center(e.box).y);
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - after) < 6) found_after = k;
  }
  EXPECT_GE(found_after, 0) << "never found again";
  EXPECT_LE(found_after, 15);
}

// Gray video has no colours: the colour histogram's check (on by default)
// must not refuse every re-detection there.
TEST(BoxTracker, AHiddenTargetInGrayVideoIsFoundAgainToo) {
  const Scene scene;
  BoxTracker tracker;
  ASSERT_GT(tracker.config().min_shared_colors, 0.0);
  const auto gray = [](const cv::Mat& frame) {
    cv::Mat out;
    cv::cvtColor(frame, out, cv::COLOR_BGR2GRAY);
    return out;
  };
  const cv::Point2d before(100, 120), after(230, 90);
  ASSERT_TRUE(tracker.init(gray(scene.render({60, 60}, before)), scene.box(before)).ok());
  for (int k = 1; k <= 20; ++k) tracker.update(gray(scene.render({60, 60}, before)));
  for (int k = 0; k < 40; ++k)
    tracker.update(gray(scene.render({60, 60}, before, 0.3, 1.0, cv::Rect(50, 70, 110, 100))));
  int found_after = -1;
  for (int k = 0; k < 40 && found_after < 0; ++k) {
    const TrackEstimate e = tracker.update(gray(scene.render({60, 60}, after)));
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - after) < 6) found_after = k;
  }
  EXPECT_GE(found_after, 0) << "never found again";
  EXPECT_LE(found_after, 15);
}

// A target that came closer while hidden: it reappears elsewhere 1.9x as
// large, beyond the sizes the whole-frame search tried before (up to 1.25x,
// which never found it), and is found again at about its new size.
TEST(BoxTracker, AHiddenTargetThatReappearsLargerIsFoundAtItsNewSize) {
  const Scene scene;
  BoxTracker tracker;
  const cv::Point2d before(100, 120), after(210, 120);
  const double small = 0.25, large = 0.25 * 1.9;
  ASSERT_TRUE(tracker.init(scene.render({60, 60}, before, small), scene.box(before, small)).ok());
  for (int k = 1; k <= 20; ++k)
    ASSERT_EQ(tracker.update(scene.render({60, 60}, before, small)).state, TrackState::kTracking);
  for (int k = 0; k < 40; ++k) tracker.update(scene.render({60, 60}, {-200, -200}, small));  // out of view
  EXPECT_NE(tracker.last().state, TrackState::kTracking);
  int found_after = -1;
  TrackEstimate e;
  for (int k = 0; k < 40 && found_after < 0; ++k) {
    e = tracker.update(scene.render({60, 60}, after, large));
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - after) < 10) found_after = k;
  }
  ASSERT_GE(found_after, 0) << "never found again";
  EXPECT_LE(found_after, 15);
  EXPECT_NEAR(e.box.width / scene.box(after, large).width, 1.0, 0.2) << "found at about its new size";
}

// The target, tracked at one size, leaves the view and comes back elsewhere
// `grow` times as large. Returns its box's width over its true width on the
// frame it is found again (0: not within 40 frames).
double size_found_after_growing(double grow, double resize_ratio) {
  const Scene scene;
  BoxTrackerConfig config;
  config.resize_ratio = resize_ratio;
  BoxTracker tracker(config);
  const cv::Point2d before(100, 120), after(200, 130);
  const double small = 0.25, large = small * grow;
  if (!tracker.init(scene.render({60, 60}, before, small), scene.box(before, small)).ok()) return -1;
  for (int k = 1; k <= 20; ++k) tracker.update(scene.render({60, 60}, before, small));
  for (int k = 0; k < 30; ++k) tracker.update(scene.render({60, 60}, {-200, -200}, small));  // out of view
  for (int k = 0; k < 40; ++k) {
    const TrackEstimate e = tracker.update(scene.render({60, 60}, after, large));
    if (std::getenv("SACCADE_TEST_VERBOSE"))
      std::printf("grow %.2f ratio %.2f: %d %s %.1f width %.1f\n", grow, resize_ratio, k, to_string(e.state),
                  e.confidence, e.box.width);
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - after) < 10)
      return e.box.width / scene.box(after, large).width;
  }
  return 0;
}

// The whole-frame search proposes a returning target at one of a few sizes
// (0.51-1.95 times its last), and the filter, which knows it smaller, peaks
// on part of it at a size too small; the scale filter's 17 scales span
// 0.85-1.17 and do not make up the rest. Confirmed elsewhere, the place is
// looked at larger too, and the size whose peak is resize_ratio times higher
// is taken: the box is then about the target's size on the frame it is found.
TEST(BoxTracker, ATargetFoundAgainLargerGetsItsSizeFromLargerLooksAtThePlace) {
  // (Back 1.5-1.6 times as large it is found by the 1.95 times larger
  // proposal, at 1.24-1.33 of its width, with or without: no smaller look
  // there peaks 1.25 times as high.)
  for (const double grow : {1.3, 1.4}) {
    const double grown = size_found_after_growing(grow, BoxTrackerConfig{}.resize_ratio);
    const double not_grown = size_found_after_growing(grow, 0);
    std::printf("back %.1f times as large: found at %.2f of its width (%.2f without the larger looks)\n", grow, grown,
                not_grown);
    EXPECT_GT(not_grown, 0) << grow << ": not found without the larger looks";
    EXPECT_LT(not_grown, 0.85) << grow << ": the scene no longer needs the larger looks";
    EXPECT_NEAR(grown, 1.0, 0.12) << grow;
  }
}

// A target hidden by something passing comes back near where it was, but
// changed (nearer, turned, in dimmer light): the filter's peaks on it fall
// under the whole-frame re-detection's bar. Near where it was last tracked
// and of its colour, a lower bar takes it back; with that off
// (redetect_near 0) it is found much later or not at all. Returns the frames
// it took (-1: not within 40).
// With `flicker`, the target's colour on every other frame is cast far
// beyond the colour check's tolerance (blue up, red down). With `claimed`,
// the changed target is shown `then` more frames once found, and the frames
// the tracker claimed it on (within 8 px) are counted there; with
// `hidden_every` N, every Nth of those frames hides it behind the occluder.
// With `head_turn`, the head turns the camera by that many pixels halfway
// through the hidden frames (the scene, occluder and target move the other
// way in the frame), and the tracker is told (camera_moved).
int frames_to_find_a_changed_target(double redetect_near, double grow, double turn_deg, double gain,
                                    bool flicker = false, int then = 0, int* claimed = nullptr, int hidden_every = 0,
                                    cv::Point2d head_turn = {}) {
  const Scene scene;
  BoxTrackerConfig config;
  config.redetect_near = redetect_near;
  BoxTracker tracker(config);
  cv::Point2d camera(60, 60), before(140, 120), after(150, 126);
  cv::Rect occluder(70, 60, 140, 120);
  if (!tracker.init(scene.render(camera, before), scene.box(before)).ok()) return -2;
  for (int k = 1; k <= 20; ++k) tracker.update(scene.render(camera, before));
  for (int k = 0; k < 20; ++k) {
    if (k == 10 && head_turn != cv::Point2d()) {
      camera += head_turn, before -= head_turn, after -= head_turn;
      occluder -= cv::Point(cv::Point2d(head_turn));
      tracker.camera_moved(-head_turn);
    }
    tracker.update(scene.render(camera, before, 0.3, 1.0, occluder));
  }
  Scene changed;
  cv::Mat turned;
  const cv::Point2f middle(changed.target.cols / 2.0f, changed.target.rows / 2.0f);
  cv::warpAffine(changed.target, turned, cv::getRotationMatrix2D(middle, turn_deg, 1.0), changed.target.size(),
                 cv::INTER_LINEAR, cv::BORDER_REFLECT);
  changed.target = turned;
  Scene cast = changed;
  cast.target = turned.clone();
  cast.target.forEach<cv::Vec3b>([](cv::Vec3b& bgr, const int*) {
    bgr[0] = cv::saturate_cast<uint8_t>(bgr[0] * 1.25);
    bgr[2] = cv::saturate_cast<uint8_t>(bgr[2] * 0.8);
  });
  for (int k = 0; k < 40; ++k) {
    const Scene& shown = flicker && k % 2 == 1 ? cast : changed;
    const TrackEstimate e = tracker.update(shown.render(camera, after, 0.3 * grow, gain));
    if (std::getenv("SACCADE_TEST_VERBOSE"))
      std::printf("near %.0f: after %d %s %.1f\n", redetect_near, k, to_string(e.state), e.confidence);
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - after) < 8) {
      for (int j = 0; j < then && claimed; ++j) {
        const bool hidden = hidden_every > 0 && j % hidden_every == hidden_every - 1;
        const TrackEstimate f =
            tracker.update(changed.render(camera, after, 0.3 * grow, gain, hidden ? occluder : cv::Rect()));
        if (std::getenv("SACCADE_TEST_VERBOSE"))
          std::printf("  then %d %s %.1f\n", j, to_string(f.state), f.confidence);
        *claimed += f.state == TrackState::kTracking && cv::norm(center(f.box) - after) < 8;
      }
      return k;
    }
  }
  return -1;
}

TEST(BoxTracker, AChangedTargetBackNearWhereItWasHiddenIsFoundSooner) {
  // 1.3x as large and turned 22 degrees, or 1.4x and 20, in 80% of the light.
  for (const auto& [grow, turn] : {std::pair{1.3, 22.0}, std::pair{1.4, 20.0}}) {
    const int near = frames_to_find_a_changed_target(2.0, grow, turn, 0.8);
    const int anywhere = frames_to_find_a_changed_target(0.0, grow, turn, 0.8);
    std::printf("grown %.1fx, turned %.0f deg: found after %d frames, %d with one bar everywhere (-1: never)\n", grow,
                turn, near, anywhere);
    EXPECT_GE(near, 0) << "never found again";
    EXPECT_LE(near, 15);
    EXPECT_TRUE(anywhere < 0 || anywhere > near) << "the scene no longer needs the lower bar";
  }
}

// The same while the head turns 120 px while the target is hidden: where it
// was last tracked moves with the image, so the lower bar near that place
// still applies where the target comes back. (Until the ninth session of
// 2026-11-29 only the next frame's prediction moved: a hidden or lost
// target's places stayed where the image had been, 120 px off, and the
// changed target was not found in 40 frames.)
TEST(BoxTracker, AChangedTargetBackNearWhereItWasHiddenIsFoundSoonerAlsoAfterAHeadTurn) {
  const cv::Point2d turn(120, 0);
  const int near = frames_to_find_a_changed_target(2.0, 1.3, 22.0, 0.8, false, 0, nullptr, 0, turn);
  const int anywhere = frames_to_find_a_changed_target(0.0, 1.3, 22.0, 0.8, false, 0, nullptr, 0, turn);
  std::printf("after a head turn: found after %d frames, %d with one bar everywhere (-1: never)\n", near, anywhere);
  EXPECT_GE(near, 0) << "never found again";
  EXPECT_LE(near, 15);
  EXPECT_TRUE(anywhere < 0 || anywhere > near) << "the scene no longer needs the lower bar";
}

// The changed target, found again, is the target from then on: its peaks
// stay under those it gave before it changed (the usual peak the tracked
// frames' bar is a share of), yet over the absolute bar, unrivalled and of
// its colour. After warmup_frames such frames the usual peak is made anew
// from them and it is tracked again, instead of staying unsure until it is
// given up as lost (and found again, and so on) while it is in plain view.
TEST(BoxTracker, AChangedTargetFoundAgainIsTrackedAgain) {
  int claimed = 0;
  const int found = frames_to_find_a_changed_target(2.0, 1.4, 20.0, 0.8, false, 60, &claimed);
  std::printf("found after %d frames, then claimed on %d of 60\n", found, claimed);
  ASSERT_GE(found, 0) << "never found again";
  EXPECT_GE(claimed, 45);
}

// The frames that make the usual peak anew must follow one another: the
// changed target seen between frames where it is hidden (an occluder passing
// back and forth) is not taken for the target's new look by adding up its runs.
TEST(BoxTracker, AChangedLookSeenBetweenHiddenFramesIsNotLearnt) {
  int claimed = 0;
  // After it is found: nine frames in view, one hidden, nine in view, ...
  const int found = frames_to_find_a_changed_target(2.0, 1.4, 20.0, 0.8, false, 28, &claimed, 10);
  std::printf("found after %d frames, then claimed on %d of 28, hidden on every tenth\n", found, claimed);
  ASSERT_GE(found, 0) << "never found again";
  EXPECT_EQ(claimed, 0) << "never ten frames in view in a row, yet the changed look was taken";
}

// Found near where it was hidden and of its colour, the changed target is
// confirmed on the next frame by its peak there, whatever its colour then: a
// colour at the tolerance's edge flickers from frame to frame (the light, a
// camera's white balance), and each recheck that failed would start the
// count again.
TEST(BoxTracker, AReacquisitionNearWhereTheTargetWasHiddenIsNotUndoneByAFlickeringColour) {
  const int steady = frames_to_find_a_changed_target(2.0, 1.3, 22.0, 0.8);
  const int flickering = frames_to_find_a_changed_target(2.0, 1.3, 22.0, 0.8, /*flicker=*/true);
  std::printf("found after %d frames, %d with its colour cast on every other frame (-1: never)\n", steady, flickering);
  ASSERT_GE(steady, 0);
  EXPECT_GE(flickering, 0) << "never found again";
  EXPECT_LE(flickering, steady + 2);
}

// Gray and gradient features barely see colour: a look-alike of another
// colour (here the target with its red and blue swapped) in the target's
// place gives as sure a peak. The target's chromaticity, learnt while it is
// tracked, keeps such frames unsure (nothing learnt from them); a whole
// untracked second later its colour is learnt again.
TEST(BoxTracker, ALookAlikeOfAnotherColorIsNotClaimed) {
  Scene scene;
  BoxTracker tracker;
  const cv::Point2d c(150, 120);
  ASSERT_TRUE(tracker.init(scene.render({60, 60}, c), scene.box(c)).ok());
  for (int k = 1; k <= 30; ++k) ASSERT_EQ(tracker.update(scene.render({60, 60}, c)).state, TrackState::kTracking);
  cv::Mat swapped;
  cv::cvtColor(scene.target, swapped, cv::COLOR_BGR2RGB);
  scene.target = swapped;
  int claimed = 0;
  for (int k = 0; k < 40; ++k) claimed += tracker.update(scene.render({60, 60}, c)).state == TrackState::kTracking;
  EXPECT_LE(claimed, 12) << "at most 30% of the frames claimed";
  int tracked_again = -1;
  for (int k = 0; k < 80 && tracked_again < 0; ++k)
    if (tracker.update(scene.render({60, 60}, c)).state == TrackState::kTracking &&
        tracker.update(scene.render({60, 60}, c)).state == TrackState::kTracking)
      tracked_again = k;
  EXPECT_GE(tracked_again, 0) << "a target that changed colour for good is followed again";
}

// `target` as the benchmark's look-alike is tinted: 0.85 of its brightness,
// blue up 20, green down 10, red up 10.
cv::Mat tinted_look_alike(const cv::Mat& target) {
  cv::Mat tinted;
  target.convertTo(tinted, CV_8UC3, 0.85, 0);
  cv::add(tinted, cv::Scalar(20, -10, 10), tinted);
  return tinted;
}

// The target, hidden, is not in view; a look-alike of another tint
// (tinted_look_alike()) shows elsewhere for 30 frames; then the target
// itself comes back there, a quarter of it covered. Returns the frames the
// look-alike was claimed on, and in `found` the frames the target then took
// to be re-acquired (-1: not within 30).
int look_alike_claims(double min_shared_colors, int& found) {
  Scene scene;
  BoxTrackerConfig config;
  config.min_shared_colors = min_shared_colors;
  BoxTracker tracker(config);
  const cv::Point2d before(100, 120), after(230, 110);
  const cv::Rect occluder(40, 60, 120, 110);
  if (!tracker.init(scene.render({60, 60}, before), scene.box(before)).ok()) return -1;
  for (int k = 1; k <= 20; ++k) tracker.update(scene.render({60, 60}, before));
  for (int k = 0; k < 10; ++k) tracker.update(scene.render({60, 60}, before, 0.3, 1.0, occluder));
  Scene look_alike = scene;
  look_alike.target = tinted_look_alike(scene.target);  // (a new image: a copy shares the target's pixels)
  int claimed = 0;
  for (int k = 0; k < 30; ++k) {
    const TrackEstimate e = tracker.update(look_alike.render({60, 60}, after));
    if (std::getenv("SACCADE_TEST_VERBOSE"))
      std::printf("look-alike %d %s %.1f\n", k, to_string(e.state), e.confidence);
    claimed += e.state == TrackState::kTracking && cv::norm(center(e.box) - after) < 8;
  }
  // A quarter of the target's box covered on the left (a third leaves the
  // filter's peak under the bar, the colours asked or not).
  const cv::Rect2d b = scene.box(after);
  const cv::Rect cover(static_cast<int>(b.x), static_cast<int>(b.y), static_cast<int>(b.width / 4),
                       static_cast<int>(b.height));
  found = -1;
  for (int k = 0; k < 30 && found < 0; ++k) {
    const TrackEstimate e = tracker.update(scene.render({60, 60}, after, 0.3, 1.0, cover));
    if (std::getenv("SACCADE_TEST_VERBOSE")) std::printf("target %d %s %.1f\n", k, to_string(e.state), e.confidence);
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - after) < 8) found = k;
  }
  return claimed;
}

// box_min_shared_colors: a sure peak on a look-alike of another tint is not
// taken for the hidden target once most of its colours must be the target's
// (without it, it is: gray and gradients barely see a tint, and a sure
// re-detection is not asked its mean colour, which a target partly hidden
// moves as far); the target, back a quarter covered, still is.
TEST(BoxTracker, ALookAlikeOfAnotherTintIsNotReacquiredWhenItsColoursAreAsked) {
  int found_asked = -1, found_not_asked = -1;
  const int asked = look_alike_claims(0.45, found_asked);
  const int not_asked = look_alike_claims(0.0, found_not_asked);
  std::printf("look-alike claimed on %d of 30 frames (%d without the check); the target then found after %d\n", asked,
              not_asked, found_asked);
  EXPECT_GT(not_asked, 0) << "the scene no longer needs the check";
  EXPECT_EQ(asked, 0);
  EXPECT_GE(found_asked, 0) << "the target, partly covered, was not found again";
  EXPECT_LE(found_asked, 15);
}

// The target 0.9 as bright, blurred, at the scene's scale: a look-alike
// whose peak is higher than the target's with a third of it covered, but not
// by half as much again.
cv::Mat dim_blurred_copy(const Scene& scene) {
  cv::Mat twin;
  scene.target.convertTo(twin, -1, 0.9);
  cv::GaussianBlur(twin, twin, {0, 0}, 2.0);
  cv::resize(twin, twin, {}, 0.3, 0.3, cv::INTER_AREA);
  return twin;
}

cv::Rect centred(cv::Size size, cv::Point2d at) {
  return {static_cast<int>(at.x) - size.width / 2, static_cast<int>(at.y) - size.height / 2, size.width, size.height};
}

// The tracker's estimate on covered frame k (printed with SACCADE_TEST_VERBOSE).
TrackEstimate covered_update(BoxTracker& tracker, const cv::Mat& frame, int k) {
  const TrackEstimate e = tracker.update(frame);
  if (std::getenv("SACCADE_TEST_VERBOSE"))
    std::printf("covered %d %s %.1f %.1f,%.1f\n", k, to_string(e.state), e.confidence, center(e.box).x,
                center(e.box).y);
  return e;
}

// The target, a third of it covered, stays in view where it is while a
// look-alike of its colour (the target a little dimmer and blurred) shows
// elsewhere, its peak higher than the covered target's but not by half as
// much again. Returns the frames the tracker claimed the look-alike on; in
// `held`, the covered frames its box stayed on the target; in `back`, whether
// the target, uncovered, was tracked again where it is.
int twin_claims(BoxTrackerConfig config, int& held, bool& back) {
  Scene scene;
  BoxTracker tracker(config);
  const cv::Point2d at(100, 120), twin_at(230, 110);
  held = 0, back = false;
  if (!tracker.init(scene.render({60, 60}, at), scene.box(at)).ok()) return -1;
  for (int k = 1; k <= 20; ++k) tracker.update(scene.render({60, 60}, at));
  cv::Mat twin = dim_blurred_copy(scene);
  const cv::Rect twin_box = centred(twin.size(), twin_at);
  const cv::Rect2d b = scene.box(at);
  const cv::Rect cover(static_cast<int>(b.x), static_cast<int>(b.y), static_cast<int>(b.width / 3),
                       static_cast<int>(b.height));
  int claimed = 0;
  for (int k = 0; k < 25; ++k) {
    cv::Mat frame = scene.render({60, 60}, at, 0.3, 1.0, cover);
    twin.copyTo(frame(twin_box));
    const TrackEstimate e = covered_update(tracker, frame, k);
    claimed += e.state == TrackState::kTracking && cv::norm(center(e.box) - twin_at) < 10;
    held += cv::norm(center(e.box) - at) < 8;
  }
  for (int k = 0; k < 10 && !back; ++k) {
    cv::Mat frame = scene.render({60, 60}, at);
    twin.copyTo(frame(twin_box));
    const TrackEstimate e = tracker.update(frame);
    back = e.state == TrackState::kTracking && cv::norm(center(e.box) - at) < 4;
  }
  return claimed;
}

// box_redetect_margin: while the target is unsure but its peak, of its
// colour, still trusted where it sits (partly hidden: a lamp post, a passer-by),
// a look-alike elsewhere whose peak is only somewhat higher is not taken for it
// (without the margin it is: vtest.avi's pedestrians, docs/tracking.md).
TEST(BoxTracker, ALookAlikeIsNotTakenForAPartlyHiddenTargetThatIsStillThere) {
  int held = 0, held_without = 0, held_never = 0;
  bool back = false, back_without = false, back_never = false;
  // (The look-alike here is within box_reach_speed's reach, which is not
  // what this test is about.)
  BoxTrackerConfig defaults;
  defaults.reach_speed = 0;
  BoxTrackerConfig without = defaults, never = defaults;
  without.redetect_margin = 0;
  // Asked during no unsure frame, the margin is still asked while the covered
  // target's peak reaches the re-detection bar (box_redetect_psr): it does
  // here, and the look-alike is refused as with the margin's frames.
  never.redetect_margin_frames = 0;
  const int claimed = twin_claims(defaults, held, back);
  const int claimed_without = twin_claims(without, held_without, back_without);
  const int claimed_never = twin_claims(never, held_never, back_never);
  std::printf(
      "look-alike claimed on %d of 25 covered frames (%d without the margin, %d asked for no unsure frame); box "
      "on the target %d (%d, %d)\n",
      claimed, claimed_without, claimed_never, held, held_without, held_never);
  EXPECT_GT(claimed_without, 0) << "the scene no longer needs the margin";
  EXPECT_EQ(claimed_never, 0);
  EXPECT_EQ(claimed, 0);
  EXPECT_EQ(held, 25);
  EXPECT_TRUE(back) << "the target, uncovered, is tracked again";
}

// box_reach_speed: the same partly hidden target and its look-alike 130 px
// away, the margin not asked. A target not tracked for a few frames can only
// have gone as far as the camera's move and its own could take it (here the
// camera is still, and its own reach grows by a tenth of its size a frame):
// the look-alike, nearly three of its widths away, is out of that reach for
// the 25 covered frames.
TEST(BoxTracker, ALookAlikeFartherThanThePartlyHiddenTargetCouldHaveGoneIsNotTakenForIt) {
  int held = 0, held_anywhere = 0;
  bool back = false, back_anywhere = false;
  BoxTrackerConfig within_reach;
  within_reach.redetect_margin = 0;
  BoxTrackerConfig anywhere = within_reach;
  anywhere.reach_speed = 0;
  const int claimed = twin_claims(within_reach, held, back);
  const int claimed_anywhere = twin_claims(anywhere, held_anywhere, back_anywhere);
  std::printf("look-alike claimed on %d of 25 covered frames (%d taken anywhere); box on the target %d (%d)\n", claimed,
              claimed_anywhere, held, held_anywhere);
  EXPECT_GT(claimed_anywhere, 0) << "the scene no longer needs the reach";
  EXPECT_EQ(claimed, 0);
  EXPECT_EQ(held, 25);
  EXPECT_TRUE(back) << "the target, uncovered, is tracked again";
}

// The target, a third of it covered by something red (its mean colour moves
// 0.05 from the learnt one; most of its colours are still there: its
// central half shares 0.82 of its histogram), stays in view where it is,
// while elsewhere a look-alike shows whose pixels are tinted green and red by
// turns: its mean colour is the target's (0.01 from it), but it shares only
// 0.48 of its colours, and its peak is higher than the covered target's but
// not by half as much again. The margin is asked on every covered frame.
// Returns the frames the tracker claimed the look-alike on.
int split_twin_claims(double min_shared_colors) {
  Scene scene;
  BoxTrackerConfig config;
  config.min_shared_colors = min_shared_colors;
  config.redetect_margin_frames = 100;  // asked on every covered frame
  BoxTracker tracker(config);
  const cv::Point2d at(100, 120), twin_at(230, 110);
  if (!tracker.init(scene.render({60, 60}, at), scene.box(at)).ok()) return -1;
  for (int k = 1; k <= 20; ++k) tracker.update(scene.render({60, 60}, at));
  cv::Mat twin = dim_blurred_copy(scene);
  for (int y = 0; y < twin.rows; ++y)
    for (int x = 0; x < twin.cols; ++x) {
      const int d = (x + y) % 2 ? 15 : -15;
      cv::Vec3b& v = twin.at<cv::Vec3b>(y, x);
      v[1] = cv::saturate_cast<uchar>(v[1] + d);
      v[2] = cv::saturate_cast<uchar>(v[2] - d);
    }
  const cv::Rect twin_box = centred(twin.size(), twin_at);
  const cv::Rect2d b = scene.box(at);
  const cv::Rect cover(static_cast<int>(b.x), static_cast<int>(b.y), static_cast<int>(b.width * 0.34),
                       static_cast<int>(b.height));
  int claimed = 0;
  for (int k = 0; k < 25; ++k) {
    cv::Mat frame = scene.render({60, 60}, at, 0.3, 1.0, cover);
    cv::add(frame(cover), cv::Scalar(-50, -50, 160), frame(cover));
    twin.copyTo(frame(twin_box));
    const TrackEstimate e = covered_update(tracker, frame, k);
    claimed += e.state == TrackState::kTracking && cv::norm(center(e.box) - twin_at) < 10;
  }
  return claimed;
}

TEST(BoxTracker, ALookAlikeOfNearerMeanColourButFewerOfTheTargetsColoursIsNotTakenForIt) {
  // Colours not asked, its mean colour, nearer the target's than the covered
  // target's by more than the tolerance, let it beat the margin; asked, it
  // must also share as much of the target's colours as where the tracker sits.
  const int not_asked = split_twin_claims(0.0);
  const int asked = split_twin_claims(BoxTrackerConfig{}.min_shared_colors);
  std::printf("look-alike claimed on %d of 25 covered frames (%d with the colours not asked)\n", asked, not_asked);
  EXPECT_GT(not_asked, 0) << "the scene no longer needs the colours";
  EXPECT_EQ(asked, 0);
}

// The tracker sits on a look-alike of another tint (tinted_look_alike())
// where the target was, and two copies of the target with its colour
// channels swapped stand in the view: four things of the target's look,
// which the whole-frame search's two places a size by look alone need not
// include the target among. Then the target shows beside them, partly
// covered. Returns the frames until it is tracked (-1: not within 30), and
// in `claimed` the frames the look-alike was claimed on before.
int frames_to_find_the_target_beside_a_look_alike(int& claimed) {
  Scene scene;
  BoxTracker tracker;
  const cv::Point2d at(110, 120), target_at(190, 150);
  const std::array<cv::Point2d, 2> decoys_at{{{250, 60}, {60, 190}}};
  if (!tracker.init(scene.render({60, 60}, at), scene.box(at)).ok()) return -2;
  for (int k = 1; k <= 20; ++k) tracker.update(scene.render({60, 60}, at));
  cv::Mat look_alike, target;
  cv::resize(tinted_look_alike(scene.target), look_alike, {}, 0.3, 0.3, cv::INTER_AREA);
  cv::resize(scene.target, target, {}, 0.3, 0.3, cv::INTER_AREA);
  std::array<cv::Mat, 2> decoys;
  cv::cvtColor(target, decoys[0], cv::COLOR_BGR2RGB);
  cv::mixChannels(std::vector<cv::Mat>{target}, std::vector<cv::Mat>{decoys[1] = target.clone()}, {0, 1, 1, 2, 2, 0});
  const auto frame_with = [&](bool target_shown) {
    cv::Mat frame = scene.render({60, 60}, {-200, -200});  // (the target out of view)
    look_alike.copyTo(frame(centred(look_alike.size(), at)));
    for (std::size_t i = 0; i < decoys.size(); ++i) decoys[i].copyTo(frame(centred(decoys[i].size(), decoys_at[i])));
    if (!target_shown) return frame;
    const cv::Rect box = centred(target.size(), target_at);
    target.copyTo(frame(box));
    // A quarter of it still covered on the left: its look then matches
    // less well than the look-alike's and the copies' whole ones.
    scene.background(cv::Rect(0, 300, box.width / 4, box.height)).copyTo(frame(box).colRange(0, box.width / 4));
    return frame;
  };
  claimed = 0;
  for (int k = 0; k < 15; ++k) claimed += tracker.update(frame_with(false)).state == TrackState::kTracking;
  // (Sitting on the look-alike, unsure, at a peak as sure as a re-detection's.)
  EXPECT_EQ(tracker.last().state, TrackState::kUncertain);
  EXPECT_GE(tracker.last().confidence, BoxTrackerConfig{}.redetect_psr);
  EXPECT_LT(cv::norm(center(tracker.last().box) - at), 8.0);
  for (int k = 0; k < 30; ++k) {
    const TrackEstimate e = tracker.update(frame_with(true));
    if (std::getenv("SACCADE_TEST_VERBOSE"))
      std::printf("target shown %d: %s %.1f at %.0f,%.0f\n", k, to_string(e.state), e.confidence, center(e.box).x,
                  center(e.box).y);
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - target_at) < 8) return k;
  }
  return -1;
}

// Unsure on a peak as sure as a re-detection's but of another colour, the
// tracker sits on a look-alike: the whole-frame search then also proposes the
// best place by look and colour together, as it does for a lost target, and
// the target is found there (by look alone it is not: the look-alike and the
// swapped copies take the places).
TEST(BoxTracker, ATargetBackBesideTheLookAlikeTheTrackerSitsOnIsFoundByItsColour) {
  int claimed = -1;
  const int found = frames_to_find_the_target_beside_a_look_alike(claimed);
  std::printf("look-alike claimed on %d of 15 frames; the target found after %d\n", claimed, found);
  EXPECT_LE(claimed, 2);
  EXPECT_GE(found, 0) << "never found";
  EXPECT_LE(found, 10);
}

// The target hidden, another of its kind shows elsewhere at 0.64 of its size
// (further away: vtest.avi's pedestrian who walked out of the view, and a
// smaller one across the hall taken for him). Returns the hidden frame on
// which the tracker claimed the other (-1: not within `frames`).
int frames_until_a_smaller_twin_is_taken(double max_size_change, int frames) {
  const Scene scene;
  BoxTrackerConfig config;
  config.max_size_change = max_size_change;
  config.reach_speed = 0;  // (the twin is out of its reach too, which is not what this test is about)
  BoxTracker tracker(config);
  const cv::Point2d at(100, 120), twin_at(230, 100);
  if (!tracker.init(scene.render({60, 60}, at), scene.box(at)).ok()) return -2;
  for (int k = 1; k <= 20; ++k) tracker.update(scene.render({60, 60}, at));
  cv::Mat twin;
  cv::resize(scene.target, twin, {}, 0.3 * 0.64, 0.3 * 0.64, cv::INTER_AREA);
  const cv::Rect twin_box = centred(twin.size(), twin_at);
  for (int k = 0; k < frames; ++k) {
    cv::Mat frame = scene.render({60, 60}, at, 0.3, 1.0, cv::Rect(40, 70, 120, 100));
    twin.copyTo(frame(twin_box));
    const TrackEstimate e = covered_update(tracker, frame, k);
    if (e.state == TrackState::kTracking && cv::norm(center(e.box) - twin_at) < 10) return k;
  }
  return -1;
}

// box_max_size_change: a re-detection's size may differ from the size the
// target was last tracked at by 3% a frame since; a target does not become
// 0.64 of its size in a few frames, so what is seen at that size soon after
// is something else. After 16 frames (1.03^16 > 1 / 0.64) it may be the
// target, gone further while hidden, and is taken (on two frames in a row, so
// on the 17th at the earliest). Without the limit it is taken at once.
TEST(BoxTracker, AnotherOfItsKindAtASizeTheTargetCouldNotYetHaveIsNotTakenForIt) {
  const int unlimited = frames_until_a_smaller_twin_is_taken(0, 15);
  EXPECT_GE(unlimited, 0) << "without the limit the smaller twin is taken within 15 frames";
  const int limited = frames_until_a_smaller_twin_is_taken(BoxTrackerConfig{}.max_size_change, 40);
  EXPECT_GE(limited, 16) << "with it, not before 0.64 of the size is within 3% a frame of it";
  EXPECT_LT(limited, 40) << "and then taken";
}

TEST(BoxTracker, TheCamerasOwnMoveIsNotTakenForTheTargets) {
  const Scene scene;
  BoxTracker told, untold;
  const cv::Point2d c(160, 120);
  ASSERT_TRUE(told.init(scene.render({60, 60}, c), scene.box(c)).ok());
  ASSERT_TRUE(untold.init(scene.render({60, 60}, c), scene.box(c)).ok());
  // The head turns: the whole image shifts by 70 px (the target with it).
  const cv::Point2d shift(-70, 0);
  const cv::Mat turned = scene.render({60, 60}, c + shift);
  told.camera_moved(shift);
  const TrackEstimate a = told.update(turned), b = untold.update(turned);
  EXPECT_LT(cv::norm(center(a.box) - (c + shift)), 3.0);
  EXPECT_EQ(a.state, TrackState::kTracking);
  EXPECT_GT(cv::norm(center(b.box) - (c + shift)), 10.0) << "70 px is beyond what one frame's search covers";
}

// Frames from the head's turn back until the target is tracked again, when
// the head turns the camera away from it by 6 px a frame and, once it has
// been out of view for 5 frames, back 150 px in one frame (frame 26), that
// turn `told` (camera_moved) or not; -1 if the target never left the view or
// is not found again.
constexpr int kTurnBackFrame = 26;
int frames_until_found_after_a_head_turn(bool told, const BoxTrackerConfig& config) {
  const Scene scene;
  const cv::Point2d world(400, 120);  // the target, where the camera at x = 0 sees it
  const auto at = [&](double camera_x) { return world - cv::Point2d(camera_x, 0); };
  BoxTracker tracker(config);
  double camera_x = 150;
  EXPECT_TRUE(tracker.init(scene.render({camera_x, 60}, at(camera_x)), scene.box(at(camera_x))).ok());
  int left = -1;
  for (int k = 1; k < 80; ++k) {
    const double before = camera_x;
    if (k <= 20) camera_x -= 6;
    if (k == kTurnBackFrame) camera_x += 150;
    if (told && camera_x != before) tracker.camera_moved({before - camera_x, 0});
    const TrackEstimate e = tracker.update(scene.render({camera_x, 60}, at(camera_x)));
    if (left < 0 && at(camera_x).x > 320) left = k;
    if (k >= kTurnBackFrame && e.state == TrackState::kTracking && cv::norm(center(e.box) - at(camera_x)) < 5)
      return left > 0 ? k - kTurnBackFrame : -1;
  }
  return -1;
}

// A target that left the view is looked for only as far in as the camera has
// turned back towards it since (box_reentry_speed): here 100 px in, where its
// own motion could not have brought it. The turn counts whether the head tells
// it or the image's measured move shows it (view_motion.hpp; told, it counts
// once), and the target is found as soon as without the limit: two
// frames after the turn, or one when told (the lost target's place moves
// with the turn, and the local look with it).
TEST(BoxTracker, ATargetTheHeadTurnsBackToIsFoundWhereTheTurnBroughtIt) {
  BoxTrackerConfig anywhere;
  anywhere.reentry_speed = 0;
  const int told = frames_until_found_after_a_head_turn(true, {});
  const int untold = frames_until_found_after_a_head_turn(false, {});
  const int told_anywhere = frames_until_found_after_a_head_turn(true, anywhere);
  const int untold_anywhere = frames_until_found_after_a_head_turn(false, anywhere);
  std::printf("found %d frames after the turn, %d with the turn untold (looked for anywhere: %d, %d)\n", told, untold,
              told_anywhere, untold_anywhere);
  EXPECT_GE(told, 0) << "the target never left the view, or was not found again";
  EXPECT_LE(told, 1) << "told, the lost target's place moves with the turn";
  EXPECT_LE(untold, 2) << "untold, the image's measured move brings the limit along";
  EXPECT_LT(told, untold) << "the head's word saves the frame the image's move is measured on";
  EXPECT_EQ(told, told_anywhere);
  EXPECT_EQ(untold, untold_anywhere);
}

// A cut: the target leaves the view across its right edge, and 10 frames
// later the view is another (another part of the background), the target in
// its middle. Nothing relates that view to the one the target left, so the
// border it left by says nothing of where it is.
TEST(BoxTracker, AfterACutTheTargetIsLookedForAnywhere) {
  const Scene scene;
  BoxTracker tracker;
  cv::Point2d camera(150, 60), target(250, 120);
  ASSERT_TRUE(tracker.init(scene.render(camera, target), scene.box(target)).ok());
  int found = -1;
  for (int k = 1; k < 80 && found < 0; ++k) {
    if (k <= 20) camera.x -= 6, target.x += 6;             // out across the right edge from frame 13
    if (k == 30) camera = {20, 200}, target = {160, 120};  // the cut
    const TrackEstimate e = tracker.update(scene.render(camera, target));
    if (k >= 30 && e.state == TrackState::kTracking && cv::norm(center(e.box) - target) < 5) found = k - 30;
  }
  std::printf("found %d frames after the cut\n", found);
  EXPECT_GE(found, 0);
  EXPECT_LE(found, 5);
}

// The image's move while the target is not tracked (view_motion.hpp): a pan
// of 3 px a frame across and 2 down, 45 frames (135 px across, over 40% of
// the view: measured against newer keyframes as it goes), every frame's move
// measured within a pixel; a still camera with a sensor's noise, within half a
// pixel over 60 frames (nothing adds up).
TEST(ViewMotion, FollowsALongPanAndAStillCamerasNoiseDoesNotAddUp) {
  const Scene scene;
  ViewMotion motion;
  double worst = 0;
  for (int k = 0; k <= 45; ++k) {
    motion.measure(scene.render({20.0 + 3 * k, 20.0 + 2 * k}, {-100, -100}));
    ASSERT_TRUE(motion.measuring()) << "frame " << k << ", peak " << motion.peak();
    worst = std::max(worst, cv::norm(motion.shift() - cv::Point2d(-3.0 * k, -2.0 * k)));
  }
  std::printf("pan: worst error %.2f px, the last move measured (%.1f, %.1f)\n", worst, motion.shift().x,
              motion.shift().y);
  EXPECT_LT(worst, 1.0);
  motion.reset();
  EXPECT_FALSE(motion.started());
  cv::RNG noise(7);
  double drift = 0;
  for (int k = 0; k < 60; ++k) {
    cv::Mat frame = scene.render({100, 100}, {-100, -100});
    cv::Mat grain(frame.size(), CV_16SC3);
    noise.fill(grain, cv::RNG::NORMAL, 0, 4);
    frame.convertTo(frame, CV_16SC3);
    frame += grain;
    frame.convertTo(frame, CV_8UC3);
    motion.measure(frame);
    drift = std::max(drift, cv::norm(motion.shift()));
  }
  std::printf("still: largest move measured %.2f px\n", drift);
  EXPECT_LT(drift, 0.5);
}

// The tracker measures the view only on the frames that ask (a find
// elsewhere weighed) and at least every kMaxGap frames: a pan of 6 px a
// frame across and 4 down (over a cell of the 320x240 view's 5 px a frame),
// 28 frames, measured on every kMaxGap-th frame only, is followed within a
// pixel and a half (every frame measured: within one).
TEST(ViewMotion, FollowsAPanMeasuredOnlyEveryFewFrames) {
  const Scene scene;
  const auto worst_error = [&](int every) {
    ViewMotion motion;
    double worst = 0;
    for (int k = 0; k <= 28; k += every) {
      motion.measure(scene.render({20.0 + 6 * k, 20.0 + 4 * k}, {-100, -100}));
      EXPECT_TRUE(motion.measuring()) << "frame " << k << ", peak " << motion.peak();
      worst = std::max(worst, cv::norm(motion.shift() - cv::Point2d(-6.0 * k, -4.0 * k)));
    }
    return worst;
  };
  const double every_frame = worst_error(1), every_few = worst_error(ViewMotion::kMaxGap);
  std::printf("pan of 168 x 112 px: worst error %.2f px measured every frame, %.2f every %d frames\n", every_frame,
              every_few, ViewMotion::kMaxGap);
  EXPECT_LT(every_frame, 1.0);
  EXPECT_LT(every_few, 1.5);
}

// A view that no longer correlates with the last (a cut to another part of
// the scene) ends the measurement: nothing can be said of where things went
// until a reset; a frame of another size too.
TEST(ViewMotion, ACutOrAnotherSizeEndsTheMeasurementUntilAReset) {
  const Scene scene;
  ViewMotion motion;
  motion.measure(scene.render({20, 20}, {-100, -100}));
  motion.measure(scene.render({26, 20}, {-100, -100}));
  ASSERT_TRUE(motion.measuring());
  EXPECT_NEAR(motion.shift().x, -6, 1);
  motion.measure(scene.render({180, 230}, {-100, -100}));
  std::printf("peak after the cut %.2f\n", motion.peak());
  EXPECT_TRUE(motion.lost());
  EXPECT_FALSE(motion.measuring());
  EXPECT_EQ(motion.shift(), cv::Point2d());
  motion.measure(scene.render({180, 230}, {-100, -100}));
  EXPECT_TRUE(motion.lost()) << "until a reset";
  motion.reset();
  motion.measure(scene.render({180, 230}, {-100, -100}));
  motion.measure(scene.render({180, 225}, {-100, -100}));
  EXPECT_TRUE(motion.measuring());
  EXPECT_NEAR(motion.shift().y, 5, 1);
  cv::Mat small;
  cv::resize(scene.render({180, 225}, {-100, -100}), small, {160, 120});
  motion.measure(small);
  EXPECT_TRUE(motion.lost());
}

TEST(BoxTracker, RefusesBoxesItCannotFollowAndSaysWhy) {
  const Scene scene;
  const cv::Mat frame = scene.render({60, 60}, {160, 120});
  BoxTracker t;
  EXPECT_THAT(t.init(frame, {400, 100, 40, 40}).message(), ::testing::HasSubstr("outside the 320x240 frame"));
  EXPECT_THAT(t.init(frame, {100, 100, 0, 40}).message(), ::testing::HasSubstr("smaller than the smallest target"));
  EXPECT_THAT(t.init(frame, {100, 100, 5, 5}).message(), ::testing::HasSubstr("box 100,100,5,5"));
  const cv::Mat flat(240, 320, CV_8UC3, cv::Scalar(90, 90, 90));
  EXPECT_THAT(t.init(flat, {100, 100, 40, 40}).message(), ::testing::HasSubstr("flat"));
  EXPECT_FALSE(t.initialized());
  EXPECT_FALSE(t.init(cv::Mat(), {100, 100, 40, 40}).ok());
  // A refused box leaves a tracker that follows a target as it was.
  const cv::Point2d c(160, 120);
  ASSERT_TRUE(t.init(frame, scene.box(c)).ok());
  EXPECT_FALSE(t.init(flat, {100, 100, 40, 40}).ok());
  const TrackEstimate e = t.update(scene.render({60, 60}, c + cv::Point2d(3, 2)));
  EXPECT_EQ(e.state, TrackState::kTracking);
  EXPECT_LT(cv::norm(center(e.box) - (c + cv::Point2d(3, 2))), 2.0);
  // Frames with nothing to look at (under 2x2, not 8-bit, none) change nothing.
  for (const cv::Mat& nothing : {cv::Mat(1, 1, CV_8UC3, cv::Scalar::all(7)), cv::Mat(1, 320, CV_8UC3),
                                 cv::Mat(240, 1, CV_8UC1), cv::Mat(240, 320, CV_16UC3), cv::Mat()}) {
    const TrackEstimate same = t.update(nothing);
    EXPECT_EQ(same.state, e.state);
    EXPECT_EQ(same.box, e.box);
  }
  EXPECT_EQ(t.update(scene.render({60, 60}, c + cv::Point2d(4, 2))).state, TrackState::kTracking);
}

}  // namespace
}  // namespace saccade
