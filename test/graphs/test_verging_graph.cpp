// graphs/verging.xml in simulated time: the head loop follows the target
// while both cameras' retinas are sampled along the pair's rectified geometry
// for the joints each frame was rendered at; the stereo's fixated point is the
// target's wherever the fovea is on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "support.hpp"

namespace saccade {
namespace {

TEST(VergingGraph, TheFixatedPointIsTheTargetsWhereTheFoveaIsOnIt) {
  test::run_recording(SACCADE_SOURCE_DIR "/graphs/verging.xml",
                      {"driver.realtime=false", "drives.realtime=false", "driver.duration=16", "drives.duration=16"},
                      {"fixation", "truth"});
  const auto fixations = test::recorded<StereoFixation>("fixation");
  std::map<int64_t, std::shared_ptr<const Region>> truth;
  for (const auto& t : test::recorded<Region>("truth")) truth[t->frame_id] = t;
  ASSERT_GT(fixations.size(), 300u);
  // The sim's cameras: 60 degrees across 320 pixels, principal point at the middle.
  const double focal = 160.0 / std::tan(30.0 * M_PI / 180.0);
  std::vector<double> errors;
  int rectified = 0, located = 0, in_head_frame = 0;
  for (const auto& f : fixations) {
    rectified += f->rectified;
    located += f->depth > 0;
    in_head_frame += f->point_head_valid;
    const auto t = truth.find(f->frame_id);
    if (t == truth.end() || f->depth <= 0 || t->second->label != "visible") continue;
    // Where the fixated point lies in the left image, against the target's disc.
    const cv::Vec3d& p = f->point;
    const double u = focal * p[0] / p[2] + 160, v = focal * p[1] / p[2] + 120;
    if (std::hypot(u - t->second->center.x, v - t->second->center.y) > t->second->size.width / 2 - 1) continue;
    errors.push_back(std::abs(p[2] - t->second->depth) / t->second->depth);
  }
  EXPECT_EQ(rectified, static_cast<int>(fixations.size()));
  // The kinematics' pose is a side input: the first frame may come before it.
  EXPECT_GE(in_head_frame, located - 1) << "of " << located << " located points";
  ASSERT_GE(errors.size(), 150u) << "frames with the fovea on the target";
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const auto within = std::count_if(errors.begin(), errors.end(), [](double e) { return e <= 0.03; });
  std::printf("[ figure ] verging graph: %zu frames on the target, depth error median %.2f%%, max %.2f%%\n",
              errors.size(), 100 * median, 100 * errors.back());
  EXPECT_LT(median, 0.015);
  EXPECT_GE(within, static_cast<long>(errors.size() * 95 / 100));
}

}  // namespace
}  // namespace saccade
