// The box tracker on the tracking benchmark's generated sequences
// (apps/bench/tracking_data: real opencv-doc images moved by a hand-held
// camera, exact truth), from the first boxes `make bench-track --runs 6`
// starts it from: what the benchmark measures, held as a test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "box_tracker.hpp"
#include "support.hpp"
#include "tracking_data.hpp"

namespace saccade {
namespace {

using namespace saccade::bench;
using namespace saccade::fovea;

Sequence generated(const std::string& name) {
  const std::vector<SyntheticScript> scripts = standard_scripts();
  const auto script = std::find_if(scripts.begin(), scripts.end(), [&](const auto& s) { return s.name == name; });
  if (script == scripts.end()) throw std::runtime_error("no generated sequence " + name);
  Result<Sequence> sequence = generate_sequence(*script, test::sample_dir());
  if (!sequence.ok()) throw std::runtime_error(sequence.error());
  return std::move(sequence).value();
}

TrackScore track(const Sequence& s, int run) {
  std::vector<TrackedFrame> frames(static_cast<std::size_t>(s.size()));
  BoxTracker tracker;
  const Result<cv::Mat> first = s.frame(0);
  EXPECT_TRUE(first.ok());
  EXPECT_TRUE(tracker.init(*first, perturbed_first_box(s.truth.front(), run)).ok());
  for (int i = 1; i < s.size(); ++i) {
    const Result<cv::Mat> frame = s.frame(i);
    EXPECT_TRUE(frame.ok());
    const TrackEstimate e = tracker.update(*frame);
    frames[static_cast<std::size_t>(i)] = {e.box, e.state == TrackState::kTracking};
  }
  Result<TrackScore> score = score_track(s.truth, s.visible, frames);
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

}  // namespace
}  // namespace saccade
