// The box tracker on the tracking benchmark's generated sequences
// (apps/bench/tracking_data: real opencv-doc images moved by a hand-held
// camera, exact truth), from the first boxes `make bench-track --runs 6`
// starts it from: what the benchmark measures, held as a test. And on real
// video: the faces of opencv-doc's Megamind.avi, against OpenCV's face
// detector.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>

#include "box_tracker.hpp"
#include "view_motion.hpp"
#include "support.hpp"
#include "tracking_data.hpp"

namespace saccade {
namespace {

using namespace saccade::bench;
using namespace saccade::fovea;

// Sequence `name` of `scripts`, rendered.
Sequence rendered(const std::vector<SyntheticScript>& scripts, const std::string& name) {
  const auto script = std::find_if(scripts.begin(), scripts.end(), [&](const auto& s) { return s.name == name; });
  if (script == scripts.end()) throw std::runtime_error("no generated sequence " + name);
  Result<Sequence> sequence = generate_sequence(*script, test::sample_dir());
  if (!sequence.ok()) throw std::runtime_error(sequence.error());
  return std::move(sequence).value();
}

// The benchmark's standard and held-out scripts.
std::vector<SyntheticScript> standard_and_held_out() {
  std::vector<SyntheticScript> scripts = standard_scripts();
  for (SyntheticScript& held_out : holdout_scripts()) scripts.push_back(std::move(held_out));
  return scripts;
}

Sequence generated(const std::string& name) { return rendered(standard_and_held_out(), name); }

// Sequence `name` of fresh set `set` (the benchmark's --fresh).
Sequence fresh(int set, const std::string& name) { return rendered(fresh_scripts(set), name); }

// With its target cut round (the benchmark's --round).
Sequence generated_round(const std::string& name) {
  return rendered(with_round_targets(standard_and_held_out()), name);
}

// With its target turning back and forth by up to `degrees` (the benchmark's --turn).
Sequence generated_turning(const std::string& name, double degrees) {
  return rendered(with_turning_targets(standard_and_held_out(), degrees), name);
}

// As a monochrome camera sees it (the benchmark's --gray).
Sequence generated_gray(const std::string& name) {
  Sequence gray = generated(name);
  make_gray(gray);
  return gray;
}

// A sequence's target followed from `box` moved as `run`'s first box
// (perturbed_first_box): one entry per frame, the first box first.
std::vector<TrackedFrame> follow_from(const Sequence& s, cv::Rect2d box, int run, const BoxTrackerConfig& config) {
  BoxTracker tracker(config);
  const cv::Rect2d first = perturbed_first_box(box, run);
  const Result<cv::Mat> frame0 = s.frame(0);
  EXPECT_TRUE(frame0.ok() && tracker.init(*frame0, first).ok());
  std::vector<TrackedFrame> track{{first}};
  for (int i = 1; i < s.size(); ++i) {
    const Result<cv::Mat> frame = s.frame(i);
    EXPECT_TRUE(frame.ok());
    const TrackEstimate e = tracker.update(*frame);
    track.push_back({e.box, e.state == TrackState::kTracking});
  }
  return track;
}

TrackScore track(const Sequence& s, int run, const BoxTrackerConfig& config = {}) {
  Result<TrackScore> score = score_track(s.truth, s.visible, follow_from(s, s.truth.front(), run, config));
  EXPECT_TRUE(score.ok());
  return score.ok() ? *score : TrackScore{};
}

// `mixed`: an orange over fruits, hidden by an occluder and back 1.3-1.45x
// larger near where it went. The whole-frame search proposes it at a larger
// size, where the filter, which knows it smaller, peaks on a part of it; the
// colour measured around that peak was not the orange's, and from three of
// the six first boxes it was re-acquired 20-25 frames after it reappeared.
// Measured where the search centred it, 13-14 frames from every one.
TEST(BoxTrackerOnGeneratedSequences, AChangedTargetBackLargerIsReacquiredWithin15FramesFromEveryFirstBox) {
  const Sequence mixed = generated("mixed");
  for (int run = 0; run < 6; ++run) {
    const TrackScore score = track(mixed, run);
    std::printf("run %d: re-acquired after %d frames, %d of %d reappearances missed, precision %.3f\n", run,
                score.max_reacquire_delay, score.reacquire_misses, score.reappearances, score.precision20);
    EXPECT_GE(score.reappearances, 1);
    EXPECT_EQ(score.reacquire_misses, 0) << "run " << run;
    EXPECT_LE(score.max_reacquire_delay, 15) << "run " << run;
  }
}

// `fresh6_occlusion` from the third and fifth of `--runs 6`'s first boxes:
// while an occluder passes over the target the unsure tracker drifts onto
// the background beside it, whose peaks (7.4-7.6) stay under the target's
// usual ones but sure otherwise. Ten such frames made them the new usual
// peak, and the background was claimed to the end (precision 0.26 and
// 0.27); peaks under the re-detection bar no longer do, and the target is
// found again when it comes out.
TEST(BoxTrackerOnGeneratedSequences, PeaksTooLowToReDetectTheTargetDoNotBecomeItsUsualOnes) {
  const Sequence occlusion = fresh(6, "fresh6_occlusion");
  for (const int run : {2, 4}) {
    const TrackScore score = track(occlusion, run);
    std::printf("run %d: precision %.3f, success@0.5 %.3f, honest lost %.2f\n", run, score.precision20, score.success50,
                score.honest_lost);
    EXPECT_GE(score.precision20, 0.8) << "run " << run;
    EXPECT_EQ(score.reacquire_misses, 0) << "run " << run;
  }
}

// `fresh5_mixed` from the true first box: the orange comes back from behind
// its occluder 1.3 times the size it went in at and grows to 1.8 times;
// the unsure tracker sits on it at the old size, peaking at 5-9 there and at
// 12-13 at 1.56 and 1.95 times, too low for a tracked frame's bar (22). Its
// box stayed at the old size until the orange was tracked again (success@0.5
// 0.854). The look at the larger size, a quarter higher and more, now gives
// the box its size while the tracker is still unsure (box_resize_ratio).
TEST(BoxTrackerOnGeneratedSequences, AnUnsureTrackerTakesTheSizeTheTargetShowsAtWhereItSits) {
  const Sequence mixed = fresh(5, "fresh5_mixed");
  BoxTrackerConfig without;
  without.resize_ratio = 0;
  const TrackScore with_it = track(mixed, 0), kept = track(mixed, 0, without);
  std::printf("success@0.5 %.3f, AUC %.3f (its size kept: %.3f, %.3f)\n", with_it.success50, with_it.success_auc,
              kept.success50, kept.success_auc);
  EXPECT_GE(with_it.success50, 0.9);
  EXPECT_LT(kept.success50, 0.9);
  EXPECT_GE(with_it.precision20, kept.precision20);
}

// `fresh6_mixed` from the first and fourth of `--runs 6`'s first boxes, and
// `holdout_mixed` from the sixth: the target comes back from behind its
// occluder larger than it went in and is found again at the nearest of the
// search's few sizes, about 0.75 of its own (fresh6_mixed, run 0: frame
// 190, a 35x40 box on a 46x53 target, tracked again from 203). The scale
// filter, which learnt it at the size it had before, fits none of its
// scales better than the others and answers its middle one: the box stayed
// 0.65-0.75 of the target while it was tracked (success@0.5 0.752, 0.797
// and 0.707). For box_look_size_frames after the find, such a flat answer
// has the position's filter look at 1.1 times the size and 1 / 1.1: the box
// has the target's size 10 frames after it is tracked again (0.945, 0.941,
// 0.966).
TEST(BoxTrackerOnGeneratedSequences, ATargetFoundAgainSmallerThanItIsTakesItsSizeWhereTheScaleFilterCannotTell) {
  const Sequence fresh_mixed = fresh(6, "fresh6_mixed"), held_out = generated("holdout_mixed");
  BoxTrackerConfig without;
  without.look_size_frames = 0;
  for (const auto& [sequence, run] : {std::pair{&fresh_mixed, 0}, {&fresh_mixed, 3}, {&held_out, 5}}) {
    const TrackScore looked = track(*sequence, run), kept = track(*sequence, run, without);
    std::printf("%s, run %d: success@0.5 %.3f, AUC %.3f (without the look: %.3f, %.3f)\n", sequence->name.c_str(), run,
                looked.success50, looked.success_auc, kept.success50, kept.success_auc);
    EXPECT_GE(looked.success50, 0.9) << sequence->name << ", run " << run;
    EXPECT_LT(kept.success50, 0.85) << sequence->name << ", run " << run;
    EXPECT_GE(looked.precision20, kept.precision20) << sequence->name << ", run " << run;
  }
}

// The same never shrinks a target: a smaller look peaks higher on the part
// of a face an occluder still half hides. `fresh4_fast_640` through a JPEG
// of quality 50, from the true first box: allowed to shrink, the box took
// 0.8 of the face as it came out, was tracked at that size and the scale
// filter learnt it (AUC 0.888 -> 0.740).
TEST(BoxTrackerOnGeneratedSequences, AFaceComingOutFromBehindAnOccluderIsNotShrunkToThePartThatShows) {
  Sequence fast = fresh(4, "fresh4_fast_640");
  ASSERT_TRUE(make_jpeg(fast, 50).ok());
  const TrackScore score = track(fast, 0);
  std::printf("AUC %.3f, success@0.5 %.3f\n", score.success_auc, score.success50);
  EXPECT_GE(score.success_auc, 0.85);
}

// `rotation` as a camera whose white balance drifts sees it (the benchmark's
// --white-balance 0.2: red and blue swung 20% either way over 150 frames).
// Read as they come, the fish's colours left the tolerance of what was learnt
// by frame 11, the frames after were doubted for their colour, and it was
// lost in plain view for most of the sequence (precision 0.334). With the white balance followed and
// undone (box_balance_colors), the colours stay the learnt ones. Over the
// six first boxes of `--runs 6`: since the angle follows a fast turn
// (2026-12-02), the true first box's run is doubted from frame 11 at peaks
// of 5.4-6, lost in view and doubted again once found (0.278; 0.950 before),
// the five others followed throughout (1.000; three of them 0.950 before).
TEST(BoxTrackerOnGeneratedSequences, ATargetIsFollowedThroughAWhiteBalanceDrift) {
  Sequence rotation = generated("rotation");
  ASSERT_TRUE(make_white_balance(rotation, 0.2).ok());
  BoxTrackerConfig as_they_come;
  as_they_come.balance_colors = false;
  int followed = 0;
  for (int run = 0; run < 6; ++run) {
    const TrackScore balanced = track(rotation, run);
    std::printf("run %d: precision@20 %.3f, success@0.5 %.3f\n", run, balanced.precision20, balanced.success50);
    if (balanced.precision20 >= 0.9 && balanced.success50 >= 0.9) ++followed;
  }
  const TrackScore raw = track(rotation, 0, as_they_come);
  std::printf("colours as they come: %.3f, %.3f\n", raw.precision20, raw.success50);
  EXPECT_GE(followed, 5);
  EXPECT_LT(raw.precision20, 0.5);
}

// `holdout_mixed` as a camera whose white balance drifts: the target is lost
// behind an occluder while red and blue swing on. Lost, nothing learns its
// colours, so the balance forgets nothing then and the colours learnt before
// are read through the whole change since; forgetting 3% a frame, as it does
// on every other frame, it was re-acquired after 35 frames (9 holding).
TEST(BoxTrackerOnGeneratedSequences, ALostTargetsColoursAreReadThroughTheWholeWhiteBalanceChangeSince) {
  Sequence mixed = generated("holdout_mixed");
  ASSERT_TRUE(make_white_balance(mixed, 0.2).ok());
  const TrackScore score = track(mixed, 0);
  std::printf("re-acquired after %d frames at most, %d of %d reappearances missed, precision@20 %.3f\n",
              score.max_reacquire_delay, score.reacquire_misses, score.reappearances, score.precision20);
  EXPECT_GE(score.reappearances, 1);
  EXPECT_EQ(score.reacquire_misses, 0);
  EXPECT_LE(score.max_reacquire_delay, 15);
  EXPECT_GE(score.precision20, 0.93);
}

// `fresh4_fast_640` from the second of `--runs 6`'s first boxes: the camera
// looks away and the target leaves the view across the left edge; the camera
// turns back fast (up to 50 px a frame) and brings it 200 px and more into the
// view before it is found. A target that left the view is looked for only
// as far in as the camera has turned back towards it (box_reentry_speed); the
// camera's turn, measured while the target is not tracked (view_motion.hpp),
// lets it be found as soon as without that limit. (Unmeasured, 25 frames instead of 9.)
TEST(BoxTrackerOnGeneratedSequences, ATargetTheCameraTurnsBackToIsFoundWhereTheTurnBroughtIt) {
  const Sequence s = fresh(4, "fresh4_fast_640");
  BoxTrackerConfig anywhere;
  anywhere.reentry_speed = 0;
  const TrackScore score = track(s, 1), unlimited = track(s, 1, anywhere);
  std::printf("re-acquired after %d frames at most (looked for anywhere: %d), %d of %d reappearances missed\n",
              score.max_reacquire_delay, unlimited.max_reacquire_delay, score.reacquire_misses, score.reappearances);
  EXPECT_EQ(score.reappearances, 2);
  EXPECT_EQ(score.reacquire_misses, 0);
  EXPECT_LE(score.max_reacquire_delay, 15);
  EXPECT_EQ(score.max_reacquire_delay, unlimited.max_reacquire_delay);
  EXPECT_NEAR(score.success_auc, unlimited.success_auc, 0.01);
}

// `holdout_mixed` (the benchmark's held-out set: `mixed`'s script with a dog's
// face over sweets): an occluder passes over the face, which comes back about
// 40 px from where it went, 1.2-1.6x larger, turned and in other light. Lost,
// the tracker's look stayed where the face went and peaked on it at 3.5-3.8
// (off the look's centre, at the wrong size), under every bar, until the
// face was 1.7x the size it was lost at: re-acquired 60 frames after the
// first sliver of it showed again. Following the face's colours near where
// it went, and looking there at other sizes, 24 frames; the whole-frame
// search proposed the round sweets, which share the face's round shape more
// than the turned face does, and never the face at its size. Proposed while
// lost by its look and colour together, 9-11 frames from four of the six
// first boxes, 26 and 32 from the other two (the turned scale filter alone:
// 22, 38, 24, 24, never, 38).
TEST(BoxTrackerOnGeneratedSequences, ALostTargetBackTurnedAmongLookAlikesOfOtherColoursIsFoundByItsColours) {
  const Sequence held_out = generated("holdout_mixed");
  int within_15 = 0;
  for (int run = 0; run < 6; ++run) {
    const TrackScore score = track(held_out, run);
    std::printf("run %d: re-acquired after %d frames, %d of %d reappearances missed, precision %.3f\n", run,
                score.max_reacquire_delay, score.reacquire_misses, score.reappearances, score.precision20);
    EXPECT_EQ(score.reappearances, 1) << "run " << run;
    EXPECT_EQ(score.reacquire_misses, 0) << "run " << run;
    EXPECT_LE(score.max_reacquire_delay, 35) << "run " << run;
    EXPECT_GE(score.precision20, 0.75) << "run " << run;
    within_15 += score.max_reacquire_delay <= 15;
  }
  EXPECT_GE(within_15, 4);
  BoxTrackerConfig by_look;
  by_look.color_proposals = 0;
  const TrackScore look_alone = track(held_out, 0, by_look);
  by_look.follow_lost_colors = 0;
  const TrackScore stays = track(held_out, 0, by_look);
  std::printf("proposed by look alone: re-acquired after %d frames; and the look kept where the face went: %d\n",
              look_alone.max_reacquire_delay, stays.max_reacquire_delay);
  EXPECT_GT(look_alone.max_reacquire_delay, 20);
  EXPECT_GT(stays.max_reacquire_delay, 40);
}

// `holdout_mixed` again, from the two first boxes whose runs found the face
// again at the wrong size: at half its size (the search's sizes are 1.25x
// apart), so that the box's central half took in other colours than the
// face's and every frame was doubted; the scale filter, which measures the
// size on tracked frames only, kept the box at that size for 100 frames
// (success@0.5 0.617 and 0.583). Measured, not learnt, on unsure frames too
// for rescale_frames after a re-detection: 0.910 and 0.872. (Since a
// re-detection is asked for the target's tones too, box_min_shared_tones,
// the wrong finds that came first on these two runs are refused, and the
// face is found at frame 189 and kept at its size either way: 0.890 and
// 0.876. Without the tones the runs take the path above, where the resizing
// is shown. Since a usual peak is made anew only from peaks that reach the
// re-detection bar, run 2 with the size measured on tracked frames only
// reaches 0.834 too, and only run 4's 0.583 still shows what the resizing
// is for. Since an unsure target takes the size it shows where it sits,
// box_resize_ratio, run 4 reached 0.790 in the counterfactual, which then
// turned that off too; since an unsure tracker on a sure peak of another
// colour has the frame proposed by colour as well, 2026-12-01, it stays at
// 0.583 with only rescale_frames off. The runs are those of the frames' own
// colours, box_balance_colors off: read through the camera's white balance
// as followed from frame to frame (the default), run 4 takes another way and
// reaches 0.690 (run 2 0.969), the same whatever the resizing and the tones
// do: held below as it is.)
TEST(BoxTrackerOnGeneratedSequences, ATargetFoundAgainAtTheWrongSizeIsResizedWhileStillDoubted) {
  const Sequence held_out = generated("holdout_mixed");
  BoxTrackerConfig as_they_come;
  as_they_come.balance_colors = false;
  // (The reach and re-entry limits stay on: with both off as well, run 2
  // without the tones took a place of the face's colour 63 px off it while
  // the face was partly hidden, 0.552, since an unsure tracker on a sure peak
  // of another colour has the whole frame proposed by colour too. And only
  // rescale_frames is off in the counterfactual: box_resize_ratio, which
  // also resizes a find and an unsure target, changes neither run here.)
  BoxTrackerConfig without_tones = as_they_come;
  without_tones.min_shared_tones = 0;
  BoxTrackerConfig tracked_only = without_tones;
  tracked_only.rescale_frames = 0;
  for (const int run : {2, 4}) {
    const TrackScore defaults = track(held_out, run, as_they_come), resized = track(held_out, run, without_tones),
                     kept = track(held_out, run, tracked_only);
    std::printf("run %d: success@0.5 %.3f; without the tones %.3f, and the size measured on tracked frames only %.3f\n",
                run, defaults.success50, resized.success50, kept.success50);
    EXPECT_GE(defaults.success50, 0.85) << "run " << run;
    EXPECT_GE(resized.success50, 0.85) << "run " << run;
    if (run == 4) { EXPECT_LT(kept.success50, 0.7); }
  }
  const TrackScore balanced_2 = track(held_out, 2), balanced_4 = track(held_out, 4);
  std::printf("the white balance followed: run 2 %.3f, run 4 %.3f\n", balanced_2.success50, balanced_4.success50);
  EXPECT_GE(balanced_2.success50, 0.85);
  EXPECT_GE(balanced_4.success50, 0.65);
}

// `rotation` and `holdout_rotation`: a fish turning up to 80 degrees either
// way, a whale up to 80 (0.8-1.25x their size). The scale filter read the
// target's scales upright while the patch followed its turn: turned, the box
// sampled other parts of it at every scale and the estimate wandered (AUC
// 0.764 and 0.745). Read turned as the patch is, once the turn passes
// scale_turn_min: 0.900 and 0.876. (Since the angle keeps up with a fast
// turn, 2026-12-02: 0.926 and 0.901, upright 0.784 and 0.797.)
TEST(BoxTrackerOnGeneratedSequences, ATurningTargetsSizeIsMeasuredTurnedWithIt) {
  BoxTrackerConfig upright;
  upright.scale_turn_min = 360;
  for (const char* name : {"rotation", "holdout_rotation"}) {
    const Sequence turning = generated(name);
    const TrackScore turned = track(turning, 0), kept_upright = track(turning, 0, upright);
    std::printf("%s: AUC %.3f, the scale filter upright %.3f\n", name, turned.success_auc, kept_upright.success_auc);
    EXPECT_GE(turned.success_auc, 0.85) << name;
    EXPECT_GE(turned.success50, 0.99) << name;
    EXPECT_GT(turned.success_auc, kept_upright.success_auc + 0.05) << name;
  }
}

// `fresh3_rotation`: a butterfly turning back and forth by up to 80 degrees,
// faster than a turn search every fourth frame follows (5 degrees each). Its
// angle fell behind, the scale filter read the butterfly at that angle, its
// answer became the window's shape across scales, and the box kept its size
// while the butterfly shrank to 0.74 of it and was left for the background. A turn
// found the same way as the last one is now searched for again on the next frame.
TEST(BoxTrackerOnGeneratedSequences, AFastTurningTargetsAngleKeepsUpWithIt) {
  const Sequence turning = fresh(3, "fresh3_rotation");
  BoxTrackerConfig every_fourth_frame;
  every_fourth_frame.follow_turns = false;
  const TrackScore behind = track(turning, 0, every_fourth_frame);
  std::printf("searched every fourth frame: precision %.3f, success@0.5 %.3f\n", behind.precision20, behind.success50);
  EXPECT_LT(behind.success50, 0.8);
  for (int run = 0; run < 6; ++run) {
    const TrackScore score = track(turning, run);
    std::printf("run %d: precision %.3f, success@0.5 %.3f, AUC %.3f\n", run, score.precision20, score.success50,
                score.success_auc);
    EXPECT_GE(score.precision20, 0.95) << "run " << run;
    EXPECT_GE(score.success50, 0.95) << "run " << run;
  }
}

// Small targets: `holdout_mixed` and `rotation` at half the size (`make
// bench-track TRACK_ARGS="--scale 0.5"`: a 30 px face, a 32 px fish). The
// scale filter's scales 2% apart differ by half a pixel there: it answered 1
// while the face grew from 21 to 41 px after it was found again (success@0.5
// 0.683), and while the fish shrank from 37 to 26 (0.957). Steps that move the
// box's larger side by a pixel (scale_step_pixels): 0.824 and 1.000. (Since
// colours are read through the camera's white balance as followed from frame
// to frame, 2026-12-01, the fish is doubted for its colour from frame 11 and
// lost for frames 27-46, where its colour had stood at the tolerance's edge:
// 0.950 with either step; the face shows the steps' worth, 0.969 against
// 0.686.) Since the size is looked for after a re-detection (box_look_size_frames,
// 2026-12-03), that look also found the face's size with steps of 2% (0.969
// in its first form): the steps are weighed with it off.
TEST(BoxTrackerOnGeneratedSequences, ASmallTargetsSizeIsFollowedByStepsOfAPixel) {
  BoxTrackerConfig unlooked;
  unlooked.look_size_frames = 0;
  BoxTrackerConfig two_percent = unlooked;
  two_percent.scale_step_pixels = 0;
  for (const char* name : {"holdout_mixed", "rotation"}) {
    Sequence small = generated(name);
    ASSERT_TRUE(resample(small, 1, 0.5).ok());
    const TrackScore looked = track(small, 0), stepped = track(small, 0, unlooked),
                     fixed = track(small, 0, two_percent);
    std::printf("%s at half the size: success@0.5 %.3f; without the look at other sizes %.3f, and steps of 2%% %.3f\n",
                name, looked.success50, stepped.success50, fixed.success50);
    EXPECT_GE(looked.success50, 0.8) << name;
    EXPECT_GE(stepped.success50, 0.8) << name;
    if (std::string(name) == "holdout_mixed") { EXPECT_LE(fixed.success50, stepped.success50 - 0.1) << name; }
  }
}

// A sequence followed with precision@20 and success@0.5 of at least
// `floor`, hardly ever claimed with the box off the target in view (a false
// lock: none in the benchmark on these sequences), and, where the target is
// hidden, the floors' honesty and re-acquisition within 15 frames.
void expect_followed(const char* name, const TrackScore& score, double floor) {
  std::printf(
      "%s: precision@20 %.3f, success@0.5 %.3f, claimed off the target %d, honest lost %.2f, re-acquired "
      "within %d frames\n",
      name, score.precision20, score.success50, score.claimed_off_target, score.honest_lost, score.max_reacquire_delay);
  EXPECT_GE(score.precision20, floor) << name;
  EXPECT_GE(score.success50, floor) << name;
  EXPECT_LE(score.claimed_off_target, 3) << name;
  if (score.reappearances > 0) {
    EXPECT_GE(score.honest_lost, 0.9) << name;
    EXPECT_EQ(score.reacquire_misses, 0) << name;
    EXPECT_LE(score.max_reacquire_delay, 15) << name;
  }
}

// Round targets (`--round` in the benchmark): a ball or a face fills its box
// only so far, and the box's corners show the scene behind it, which moves
// as the target does. Growing, turning, hidden by an occluder and out of
// view, it is followed and found again as a rectangle is (the benchmark:
// precision 1.000, 1.000, 0.918, 0.972; re-acquired in 12 and 3 frames).
TEST(BoxTrackerOnGeneratedSequences, ARoundTargetIsFollowedWithTheSceneMovingInItsBoxsCorners) {
  for (const char* name : {"scale@round", "rotation@round", "occlusion@round", "holdout_out_of_view@round"}) {
    expect_followed(name, track(generated_round(name), 0), 0.88);
  }
}

// Turning targets (`--turn 30` in the benchmark): the picture goes round
// the side as another comes into view, inside the same box. Shaken and
// blurred, circled by a look-alike, also turning in the image's plane, and
// out of view and back, each is followed as it turns (the benchmark:
// precision 1.000, 1.000, 1.000, 0.976; re-acquired in 3 frames).
TEST(BoxTrackerOnGeneratedSequences, ATurningTargetIsFollowedAsItsLookChanges) {
  for (const char* name : {"shake_blur@turn30", "distractor@turn30", "holdout_rotation@turn30", "out_of_view@turn30"}) {
    expect_followed(name, track(generated_turning(name, 30), 0), 0.9);
  }
}

// A monochrome camera (`--gray` in the benchmark): `holdout_fast_640`'s
// whale in gray, hidden by an occluder and later out of view. Every place is
// of its gray "colour", and while its colour was checked regardless, finds
// of background under the full bar were let in as near where it was lost and
// of its colour: it was claimed on a wall while hidden and never re-acquired
// (precision 0.439, both reappearances missed). Without colours to check it
// is taken back only over the full bar: precision 0.934, re-acquired in 10
// and 4 frames.
TEST(BoxTrackerOnGeneratedSequences, AMonochromeCamerasTargetIsFoundAgainOnlyOverTheFullBar) {
  const Sequence gray = generated_gray("holdout_fast_640");
  const Result<cv::Mat> first = gray.frame(0);
  ASSERT_TRUE(first.ok());
  std::vector<cv::Mat> channels;
  cv::split(*first, channels);
  ASSERT_EQ(cv::norm(channels[0], channels[2], cv::NORM_INF), 0.0) << "not gray";
  const TrackScore score = track(gray, 0);
  std::printf(
      "holdout_fast_640 in gray: precision %.3f, honest lost %.2f, %d of %d reappearances missed, the "
      "longest re-acquisition %d frames\n",
      score.precision20, score.honest_lost, score.reacquire_misses, score.reappearances, score.max_reacquire_delay);
  EXPECT_GE(score.precision20, 0.85);
  EXPECT_GE(score.honest_lost, 0.9);
  EXPECT_EQ(score.reacquire_misses, 0);
  EXPECT_LE(score.max_reacquire_delay, 15);
}

// `fast_640` in gray: while the target is away, the whole-frame search finds
// background that the filter half matches, over the re-detection's bar
// (PSR 10-12) and of the target's size; a monochrome camera has no colour to
// refuse it by. Its tones (gray relative to the mean: box_min_shared_tones)
// are a flat patch's or another contrast's, and refused, the tracker waits
// for the target. Without them (the tracker until the eighth session of
// 2026-11-29), precision 0.629 and honest lost 0.82.
TEST(BoxTrackerOnGeneratedSequences, AMonochromeCamerasFindOfOtherTonesIsNotTakenForTheTarget) {
  const Sequence gray = generated_gray("fast_640");
  BoxTrackerConfig without_tones;
  without_tones.min_shared_tones = 0;
  const TrackScore with = track(gray, 0), without = track(gray, 0, without_tones);
  std::printf(
      "fast_640 in gray: precision %.3f, honest lost %.2f, %d of %d reappearances missed (without tones: %.3f, "
      "%.2f, %d)\n",
      with.precision20, with.honest_lost, with.reacquire_misses, with.reappearances, without.precision20,
      without.honest_lost, without.reacquire_misses);
  EXPECT_GE(with.precision20, 0.85);
  EXPECT_GE(with.honest_lost, 0.95);
  EXPECT_EQ(with.reacquire_misses, 0);
  EXPECT_LT(without.precision20, 0.75) << "the tones are what refuse the background here";
}

// `mixed_640` as a monochrome camera sees it: the peak falls under half its
// usual height for ten frames on something else (what the tracker slid onto
// as the butterfly went behind the occluder), and nothing in gray told that
// from the target's new look: it was learnt, and followed while the target was
// away (precision 0.425, honest lost 0.78). A frame under the usual peak now
// counts towards a new one only if it shares the target's tones. (Weighed
// with the look at other sizes after a re-detection off: with it, 2026-12-03,
// the box takes the butterfly's size when it is found again and then follows
// its growth too slowly, precision 0.634 against CSRT's 0.422;
// docs/tracking.md, Not met. Measured then too: with box_min_shared_tones 0
// the precision is also 0.813, so this sequence no longer shows the rule's
// worth, only that the target is kept.)
TEST(BoxTrackerOnGeneratedSequences, AMonochromeCamerasTargetsNewLookMustShareItsTones) {
  const Sequence s = generated_gray("mixed_640");
  BoxTrackerConfig unlooked;
  unlooked.look_size_frames = 0;
  const TrackScore score = track(s, 0, unlooked);
  std::printf("precision %.3f, success AUC %.3f, honest lost %.2f\n", score.precision20, score.success_auc,
              score.honest_lost);
  EXPECT_GE(score.precision20, 0.8);
  EXPECT_GE(score.honest_lost, 0.9);
}

// `mixed` in gray: the orange comes back from behind the occluder near where
// it went, changed, its filter peaking under the full bar (in colour, 7-8
// for 15 frames). A find of its colour is let in there at the lower bar; a
// monochrome camera's orange has no colour, and waited for the full bar, 20
// frames. Sharing nine tenths of its tones (box_near_shared_tones) lets it in.
TEST(BoxTrackerOnGeneratedSequences, AMonochromeCamerasTargetBackNearWhereItWentIsLetInByItsTones) {
  const Sequence gray = generated_gray("mixed");
  BoxTrackerConfig full_bar;
  full_bar.near_shared_tones = 0;
  const TrackScore toned = track(gray, 0), waited = track(gray, 0, full_bar);
  std::printf("mixed in gray: re-acquired after %d frames, precision %.3f, honest lost %.2f (the full bar: %d, %.3f)\n",
              toned.max_reacquire_delay, toned.precision20, toned.honest_lost, waited.max_reacquire_delay,
              waited.precision20);
  EXPECT_EQ(toned.reacquire_misses, 0);
  EXPECT_LE(toned.max_reacquire_delay, 15);
  EXPECT_GE(toned.honest_lost, 0.95);
  EXPECT_GE(toned.precision20, 0.94);
  EXPECT_GT(waited.max_reacquire_delay, 15) << "the tones are what let it in early here";
}

// `fresh4_occlusion` in gray: as the occluder slides over the face, the
// tracker, unsure, slides with it, and the occluder peaks lower than the face
// did but steadily, for long enough to become the usual peak. (In colour it
// is not taken, though the face, colourless, has no colour to check: the
// tracker's path there differs.) A monochrome camera's face has only its
// tones, and the occluder shared the six tenths every frame under the usual
// peak must: it was claimed as the face for 23 frames while
// the face was hidden and then beside it. Settling there now also asks most
// of its tones (box_near_shared_tones), as a find near where it went does;
// only in a monochrome camera's frames: in colour the face, as colourless,
// was re-acquired in 17 frames with it instead of 13.
TEST(BoxTrackerOnGeneratedSequences, AMonochromeCamerasOccluderIsNotTakenForTheTargetsNewLook) {
  const Sequence colour = fresh(4, "fresh4_occlusion");
  Sequence gray = colour;
  make_gray(gray);
  BoxTrackerConfig six_tenths;
  six_tenths.near_shared_tones = 0;
  const TrackScore toned = track(gray, 0), slid = track(gray, 0, six_tenths);
  std::printf(
      "fresh4_occlusion in gray: honest lost %.2f, %d frames claimed off the face, precision %.3f "
      "(without most of its tones: %.2f, %d, %.3f)\n",
      toned.honest_lost, toned.claimed_off_target, toned.precision20, slid.honest_lost, slid.claimed_off_target,
      slid.precision20);
  EXPECT_GE(toned.honest_lost, 0.95);
  EXPECT_EQ(toned.claimed_off_target, 0);
  EXPECT_EQ(toned.reacquire_misses, 0);
  EXPECT_LT(slid.honest_lost, 0.9) << "the tones are what keep the occluder out here";
  EXPECT_GT(slid.claimed_off_target, 0);
  const TrackScore in_colour = track(colour, 0);
  EXPECT_LE(in_colour.max_reacquire_delay, 15) << "a colour camera's face settles without them";
}

// `holdout_mixed` in gray: the dog's face comes back from behind an occluder
// near where it went, larger and turned, peaking under the re-detection's
// bar. In colour the lost look follows the face's colours there
// (box_follow_lost_colors); a monochrome camera's face, without colours, is
// followed by its tones (as much of them as a re-detection must share) and
// re-acquired in 12 frames; with the look kept where it went, in 41.
TEST(BoxTrackerOnGeneratedSequences, AMonochromeCamerasLostTargetIsFollowedByItsTones) {
  const Sequence gray = generated_gray("holdout_mixed");
  const TrackScore followed = track(gray, 0);
  EXPECT_EQ(followed.reacquire_misses, 0);
  EXPECT_LE(followed.max_reacquire_delay, 15);
  EXPECT_GE(followed.precision20, 0.9);
  // Kept where the face went, the look finds it late.
  BoxTrackerConfig look_stays;
  look_stays.follow_lost_colors = 0;
  const TrackScore stays = track(gray, 0, look_stays);
  std::printf(
      "holdout_mixed in gray: re-acquired after %d frames, precision %.3f (the look kept where it went: %d, %.3f)\n",
      followed.max_reacquire_delay, followed.precision20, stays.max_reacquire_delay, stays.precision20);
  EXPECT_GT(stays.max_reacquire_delay, 30) << "following the tones is what finds it here";
}

// Real video: the four shots of opencv-doc's Megamind.avi (720x528, an
// animated film: a woman's face, a man's, hers, his closer; cuts at frames
// 98, 154 and 200), each followed from the box OpenCV's Haar face detector
// (opencv-doc's haarcascade_frontalface_default) gives on its first frame,
// as `make bench-track-faces` does. The same detector on every later frame is
// the reference: the face it finds nearest the reference of the frame before
// (its middle within 80 px, the face at least 120 px: the small faces in the
// background are others'). Frames where it finds none are not scored.
struct FaceShot {
  int first_frame, frames;
  cv::Rect2d box;
};

std::string face_cascade_path() {
  const std::filesystem::path path = std::filesystem::path(test::sample_dir()) / ".." / ".." / "opencv4" / "html" /
                                     "haarcascade_frontalface_default.xml.gz";
  if (!std::filesystem::exists(path))
    throw std::runtime_error(path.string() + " is missing: install Debian's opencv-doc (bash scripts/install-deps.sh)");
  return path.string();
}

std::optional<cv::Rect2d> detected_face(cv::CascadeClassifier& detector, const cv::Mat& frame, cv::Rect2d near) {
  cv::Mat gray;
  cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::Rect> faces;
  detector.detectMultiScale(gray, faces, 1.1, 4, 0, cv::Size(60, 60));
  std::optional<cv::Rect2d> best;
  double nearest = 80;
  for (const cv::Rect& f : faces) {
    const double distance = center_error(cv::Rect2d(f), near);
    if (f.width >= 120 && distance < nearest) nearest = distance, best = cv::Rect2d(f);
  }
  return best;
}

TEST(BoxTrackerOnRealVideo, FollowsEachShotsFaceWhereOpenCvsFaceDetectorFindsIt) {
  // The detector on the calling thread: the same boxes whatever the machine's
  // cores (OpenCV's parallel loop collects them in the order its threads end).
  struct SingleThreaded {
    int threads = cv::getNumThreads();
    SingleThreaded() { cv::setNumThreads(1); }
    ~SingleThreaded() { cv::setNumThreads(threads); }
  } const single_threaded;
  cv::CascadeClassifier detector;
  ASSERT_TRUE(detector.load(face_cascade_path()));
  const std::string video = test::sample_path("Megamind.avi");
  for (const FaceShot& shot : {FaceShot{2, 96, {210, 165, 155, 155}}, FaceShot{98, 56, {389, 112, 170, 170}},
                               FaceShot{156, 44, {203, 149, 186, 186}}, FaceShot{200, 70, {215, 62, 349, 349}}}) {
    Result<Sequence> read = read_video({video, shot.first_frame, shot.box, shot.frames});
    ASSERT_TRUE(read.ok()) << read.error();
    const Sequence& s = *read;
    ASSERT_EQ(s.size(), shot.frames);
    BoxTracker tracker;
    const Result<cv::Mat> first = s.frame(0);
    ASSERT_TRUE(first.ok());
    ASSERT_TRUE(tracker.init(*first, shot.box).ok());
    cv::Rect2d reference = shot.box;
    int scored = 0, within = 0, claimed = 0, still_within = 0;
    double error_sum = 0, still_sum = 0;
    for (int i = 1; i < s.size(); ++i) {
      const Result<cv::Mat> frame = s.frame(i);
      ASSERT_TRUE(frame.ok());
      const TrackEstimate e = tracker.update(*frame);
      claimed += e.state == TrackState::kTracking;
      const std::optional<cv::Rect2d> face = detected_face(detector, *frame, reference);
      if (!face) continue;
      reference = *face;
      const double error = center_error(e.box, *face);
      ++scored, error_sum += error, within += error <= 20;
      const double still = center_error(shot.box, *face);
      still_sum += still, still_within += still <= 20;
    }
    const double precision = static_cast<double>(within) / std::max(scored, 1);
    std::printf(
        "frames %d-%d: %d scored, mean centre error %.1f px, precision@20 %.2f, claimed %d of %d; "
        "the first box kept: %.1f px, %.2f\n",
        shot.first_frame, shot.first_frame + shot.frames - 1, scored, error_sum / std::max(scored, 1), precision,
        claimed, s.size() - 1, still_sum / std::max(scored, 1),
        static_cast<double>(still_within) / std::max(scored, 1));
    EXPECT_GE(scored, 10) << "the detector finds the face on too few frames to score";
    EXPECT_GE(precision, 0.9) << "frames " << shot.first_frame << "-" << shot.first_frame + shot.frames - 1;
    EXPECT_GE(claimed, 0.9 * (s.size() - 1)) << "the face stays in view: it is claimed";
    EXPECT_LT(error_sum, 0.4 * still_sum) << "the face moves: followed, it is nearer than the first box kept still";
  }
}

// Real video: two of vtest.avi's pedestrians (make bench-track-people's boxes)
// while they are in view. Each was once left for another man in dark clothes
// ("a jump": the box's centre moving more than 0.75 of its larger side in one
// frame, which a walking person cannot): the first at frame 355 while doubted
// by his colour (another man's mean colour nearer the learnt one, but fewer of
// his colours); the second at frame 486 for a man 100 px away. The second, a
// man in black, is crossed twice by men in darker jackets and jeans (frames
// 483-487 and 503-508): where he is was read off the frames by eye at three of
// them. Taken at 1.25 times his size while the first crossed him (a find that
// covered both, then followed the man in front: no jump, but the wrong man
// from frame 486 to 508), he is now kept, since no target grows by a quarter in
// three frames (box_max_size_change), though doubted on more frames. A third,
// at 292,189 in frame 420, walks into a crowd: his peak falls from 25-36 to
// 10-15 and his colour flickers about its tolerance, so he is unsure from
// frame 469 on; at frame 484, after 15 unsure frames, another man 110 px away
// was taken for him. He is kept while his peak where the tracker sits still
// reaches the re-detection bar (box_redetect_margin_frames); where he is was
// read off the frames by eye at three of them.
TEST(BoxTrackerOnRealVideo, KeepsAPedestrianWhoStaysInViewOverOthersInDarkClothes) {
  const std::string video = test::sample_path("vtest.avi");
  struct Seen {
    int frame;  // of the video
    cv::Point2d center;
  };
  struct Walker {
    int first_frame, frames;
    cv::Rect2d box;
    double min_claimed;
    std::vector<Seen> seen;
  };
  const std::vector<Walker> walkers{
      // (He walks left, turns at frame 321 and walks right, men in dark
      // clothes within 50 px of him: where he is, by eye, at three frames.)
      {300, 100, {309, 168, 42, 136}, 0.7, {{320, {269, 222}}, {340, {349, 239}}, {350, {396, 257}}}},
      // (Claimed on 21 of his 39 frames, 0.54: doubted while he is crossed.)
      {480, 40, {577, 241, 35, 111}, 0.5, {{492, {634, 312}}, {498, {627, 322}}, {510, {630, 321}}}},
      // (Claimed on 0.62 of his 88 frames: doubted in the crowd.)
      {420, 89, {292, 189, 34, 111}, 0.5, {{484, {500, 290}}, {496, {566, 323}}, {508, {639, 360}}}}};
  for (const Walker& w : walkers) {
    Result<Sequence> read = read_video({video, w.first_frame, w.box, w.frames});
    ASSERT_TRUE(read.ok()) << read.error();
    const Sequence& s = *read;
    // Scored as make bench-track-people scores it (witness_score: its jumps and claimed share).
    const std::vector<TrackedFrame> track = follow_from(s, w.box, 0, {});
    for (const Seen& seen : w.seen) {
      const cv::Rect2d& b = track.at(static_cast<std::size_t>(seen.frame - w.first_frame)).box;
      const double off = cv::norm(cv::Point2d(b.x + b.width / 2, b.y + b.height / 2) - seen.center);
      std::printf("frame %d: the box's centre %.1f px from where he is\n", seen.frame, off);
      EXPECT_LT(off, 15) << "frame " << seen.frame << ": not on the pedestrian";
    }
    const WitnessScore score = witness_score(track);
    std::printf("pedestrian at %.0f,%.0f from frame %d: %d jumps, claimed %.2f of %d frames\n", w.box.x, w.box.y,
                w.first_frame, score.jumps, score.claimed, score.frames);
    EXPECT_EQ(score.jumps, 0) << "frame " << w.first_frame;
    EXPECT_GE(score.claimed, w.min_claimed) << "frame " << w.first_frame;
  }
}

// vtest.avi's pedestrian at 671,197 in frame 600 (make bench-track-people's
// boxes) walks out of the view's right edge within 20 frames; the
// whole-frame search then finds others in dark clothes. While re-detections
// were asked only for his colours, the box went from one to another two or
// three times from each of the six first boxes `--runs 6` starts him from
// (13 jumps in all; from the true box at frames 20, 30 and 34); asked for his
// tones too (box_min_shared_tones), once from each (frame 32). (Over the 132
// runs the jumps went 122 -> 95; single people's counts move either way
// with a pixel of the first box: this one's did not.)
TEST(BoxTrackerOnRealVideo, APedestrianIsLeftForOthersOfOtherTonesLessOftenFromEveryFirstBox) {
  const cv::Rect2d box(671, 197, 34, 111);
  Result<Sequence> read = read_video({test::sample_path("vtest.avi"), 600, box, 150});
  ASSERT_TRUE(read.ok()) << read.error();
  const Sequence& s = *read;
  auto jumps = [&](int run, const BoxTrackerConfig& config) {
    return witness_score(follow_from(s, box, run, config)).jumps;
  };
  // (Both without box_reentry_speed, which keeps him from being taken for
  // others once he has left the view: the test below, nor box_reach_speed.)
  BoxTrackerConfig with_tones;
  with_tones.reentry_speed = 0;
  with_tones.reach_speed = 0;
  BoxTrackerConfig without_tones = with_tones;
  without_tones.min_shared_tones = 0;
  int all_with = 0, all_without = 0;
  for (int run = 0; run < 6; ++run) {
    const int with = jumps(run, with_tones), without = jumps(run, without_tones);
    std::printf("first box %d: %d jumps (without tones %d)\n", run, with, without);
    EXPECT_LE(with, 1) << "first box " << run;
    all_with += with, all_without += without;
  }
  EXPECT_GE(all_without, 10) << "without the tones he is left for others from every first box (13 jumps)";
  EXPECT_GE(all_without, 2 * all_with) << "the tones are what keep him here";
}

// The same pedestrian, at 671,197 in frame 600: his centre leaves the view's
// right edge at frame 617 from each of the six first boxes, and others in
// dark clothes walk 100-440 px from that edge. The box went to one of them
// from each box (at frame 632 from the true one); a target that left the view
// comes back across the edge it left by, at no more than a walking pace here,
// the camera still (box_reentry_speed).
TEST(BoxTrackerOnRealVideo, APedestrianWhoWalksOutOfViewIsNotTakenForAnotherStillInIt) {
  const cv::Rect2d box(671, 197, 34, 111);
  constexpr int kFrames = 90;
  Result<Sequence> read = read_video({test::sample_path("vtest.avi"), 600, box, kFrames});
  ASSERT_TRUE(read.ok()) << read.error();
  const Sequence& s = *read;
  const int width = s.frame(0)->cols;
  struct Outcome {
    int left_at = -1;  // the first frame his centre is beyond the right edge
    int jumps = 0;     // after that
  };
  auto follow = [&](int run, const BoxTrackerConfig& config) {
    const std::vector<TrackedFrame> track = follow_from(s, box, run, config);
    Outcome o;
    for (std::size_t i = 1; i < track.size() && o.left_at < 0; ++i)
      if (track[i].box.x + track[i].box.width / 2 > width) o.left_at = static_cast<int>(i);
    if (o.left_at >= 0)
      o.jumps = witness_score(std::vector<TrackedFrame>(track.begin() + o.left_at - 1, track.end())).jumps;
    return o;
  };
  BoxTrackerConfig anywhere;
  anywhere.reentry_speed = 0;
  anywhere.reach_speed = 0;
  int all_without = 0;
  for (int run = 0; run < 6; ++run) {
    const Outcome with = follow(run, {}), without = follow(run, anywhere);
    std::printf("first box %d: left the view at frame %d; %d jumps after (anywhere: %d)\n", run, 600 + with.left_at,
                with.jumps, without.jumps);
    EXPECT_GE(with.left_at, 10) << "first box " << run << ": he walks out of the view";
    EXPECT_EQ(with.jumps, 0) << "first box " << run;
    all_without += without.jumps;
  }
  EXPECT_GE(all_without, 4) << "others are there to be taken for him";
}

// vtest.avi's man in black at 607,170 in frame 540 (make bench-track-people's
// boxes) is crossed by a passer-by at frames 589-591 and is unsure there;
// from four of the six first boxes `--runs 6` starts him from, the box went at
// frame 592 to a man standing 130 px below him, whose peak (14-15) was half
// as high again as the crossed man's. A target not tracked for a few frames
// can only be as far from where it was last tracked as the image's move and
// its own could take it (box_reach_speed): one that far is somebody else,
// unless it peaks as high as the target usually does (from one first box
// here, whose usual peak had fallen under it).
TEST(BoxTrackerOnRealVideo, APedestrianCrossedByAPasserByIsNotLeftForAnotherFartherThanHeCouldWalk) {
  const cv::Rect2d box(607, 170, 33, 106);
  Result<Sequence> read = read_video({test::sample_path("vtest.avi"), 540, box, 70});
  ASSERT_TRUE(read.ok()) << read.error();
  const Sequence& s = *read;
  BoxTrackerConfig anywhere;
  anywhere.reach_speed = 0;
  int all_with = 0, all_without = 0;
  for (int run = 0; run < 6; ++run) {
    const int with = witness_score(follow_from(s, box, run, {})).jumps;
    const int without = witness_score(follow_from(s, box, run, anywhere)).jumps;
    std::printf("first box %d: %d jumps (anywhere: %d)\n", run, with, without);
    all_with += with, all_without += without;
  }
  EXPECT_LE(all_with, 1);
  EXPECT_GE(all_without, 3) << "others are there to be taken for him";
}

// The bar under which the image's move is no measurement (ViewMotion's
// kMinPeak, 0.15; view_motion.hpp), on real pictures moved as a hand-held
// camera moves them: fresh set 1's ten sequences, each frame measured
// against its keyframe in episodes of 30 frames (as while a target is not
// tracked), peak at least at the bar on 99% of the frames and more (0.65%
// under it); a cut (frame 100 of one sequence against frame 100 of the next
// of its size) under it every time (0.07-0.12). vtest.avi's still camera,
// people walking across it: every frame over the bar, and no move measured
// of more than two thirds of a cell (8 px; 6 at most: the walkers pull the
// peak by up to half a cell, against a pedestrian's 34 px).
TEST(ViewMotionOnRealPictures, ACutPeaksUnderTheBarAndAMovingCamerasFramesOverIt) {
  int frames = 0, under = 0, cuts = 0, cuts_over = 0;
  std::optional<Sequence> before;
  for (const SyntheticScript& script : fresh_scripts(1)) {
    Result<Sequence> read = generate_sequence(script, test::sample_dir());
    ASSERT_TRUE(read.ok()) << read.error();
    const Sequence& s = *read;
    ViewMotion motion;
    for (int i = 0; i < s.size(); ++i) {
      if (i % 30 == 0) motion.reset();
      motion.measure(*s.frame(i));
      if (i % 30 == 0) continue;
      ++frames;
      if (motion.lost()) ++under, motion.reset(), motion.measure(*s.frame(i));
    }
    if (before && before->frame_size == s.frame_size) {
      ViewMotion cut;
      cut.measure(*before->frame(100));
      cut.measure(*s.frame(100));
      ++cuts;
      cuts_over += !cut.lost();
    }
    before = std::move(read).value();
  }
  Result<Sequence> still = read_video({test::sample_path("vtest.avi"), 0, {249, 202, 36, 116}, 300});
  ASSERT_TRUE(still.ok()) << still.error();
  ViewMotion motion;
  int still_under = 0;
  double largest = 0;
  for (int i = 0; i < still->size(); ++i) {
    if (i % 30 == 0) motion.reset();
    motion.measure(*still->frame(i));
    still_under += motion.lost();
    largest = std::max(largest, cv::norm(motion.shift()));
  }
  std::printf(
      "hand-held: %d of %d frames under the bar; cuts over it: %d of %d; still camera: %d under, largest move %.2f "
      "px\n",
      under, frames, cuts_over, cuts, still_under, largest);
  EXPECT_LE(under, frames / 100);
  EXPECT_GE(cuts, 5);
  EXPECT_EQ(cuts_over, 0);
  EXPECT_EQ(still_under, 0);
  EXPECT_LT(largest, 8.0);
}

}  // namespace
}  // namespace saccade
