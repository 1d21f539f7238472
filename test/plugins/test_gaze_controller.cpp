// The gaze controller on an ideal plant (the joints are where they were
// commanded one cycle earlier): every kind of request ends with the optical
// axes on the target, limits hold under random requests, and each kind of
// trouble (drive fault, silent drive, stale feedback, following error) holds
// the head until reset.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "gaze_controller.hpp"

namespace saccade::head {
namespace {

using Eigen::Vector3d;

constexpr int64_t kPeriodNs = 4'000'000;

struct IdealHead {
  HeadConfig config;
  GazeController controller{config};
  std::vector<JointReading> readings = std::vector<JointReading>(kJoints);
  int64_t now = 0;
  IdealHead() {
    for (auto& r : readings) r.health = JointReading::Health::kReady;
  }
  const HeadCommand& step() {
    for (auto& r : readings) r.updated_ns = now;
    const HeadCommand& c = controller.cycle(now, readings);
    for (int j = 0; j < kJoints; ++j)
      readings[static_cast<std::size_t>(j)].position = c.position[static_cast<std::size_t>(j)];
    now += kPeriodNs;
    return c;
  }
  void run(double seconds) {
    for (int i = 0; i < static_cast<int>(seconds / (kPeriodNs * 1e-9)); ++i) step();
  }
  // Angle between camera `c`'s optical axis and the direction to `p`, degrees.
  double error_deg(int camera, const Vector3d& p) const {
    const auto q = controller.measured();
    const auto pose =
        camera == 0 ? kinematics::left_camera(config.geometry, q) : kinematics::right_camera(config.geometry, q);
    const Vector3d to = (p - pose.translation()).normalized();
    return std::acos(std::clamp(to.dot(kinematics::optical_axis(pose)), -1.0, 1.0)) * 180 / M_PI;
  }
};

TEST(GazeController, LooksAtAPointWithBothCameras) {
  IdealHead h;
  h.step();
  const Vector3d target(0.4, 1.2, 0.3);
  EXPECT_TRUE(h.controller.look_at(target).ok()) << h.controller.last_rejection();
  h.run(1.0);
  EXPECT_LT(h.error_deg(0, target), 1e-6);
  EXPECT_LT(h.error_deg(1, target), 1e-6);
  const auto f = h.controller.fixation();
  ASSERT_TRUE(f.valid);
  EXPECT_LT((f.point - target).norm(), 1e-6);
  EXPECT_EQ(h.controller.stats().saccades, 1);
}

TEST(GazeController, EveryKindOfRequestEndsOnItsTarget) {
  IdealHead h;
  h.step();
  ASSERT_TRUE(h.controller.look_at({0.0, 1.5, 0.12}).ok()) << h.controller.last_rejection();
  h.run(1.0);
  // A direction from the left camera at a known depth.
  const auto pose = kinematics::optical_frame(kinematics::left_camera(h.config.geometry, h.controller.measured()));
  const Vector3d seen = pose * Vector3d(0.2, -0.1, 1.0);  // in front of the left camera, 1 m deep
  ASSERT_TRUE(h.controller.look_along(0, Vector3d(0.2, -0.1, 1.0), 1.0).ok()) << h.controller.last_rejection();
  h.run(1.0);
  EXPECT_LT(h.error_deg(0, seen), 1e-6);
  EXPECT_LT(h.error_deg(1, seen), 1e-6);
  // Without depth the vergence distance stays.
  const double before = (h.controller.fixation().point - pose.translation()).norm();
  ASSERT_TRUE(h.controller.look_along(1, Vector3d(-0.1, 0.0, 1.0), 0).ok()) << h.controller.last_rejection();
  h.run(1.0);
  const double after = (h.controller.fixation().point - pose.translation()).norm();
  EXPECT_NEAR(after, before, 0.15 * before);
  // A stereo pixel pair: project a point into both cameras and ask for it.
  const Vector3d point(-0.3, 2.0, 0.4);
  const double focal = 500, cx = 320, cy = 240;
  const auto q = h.controller.measured();
  const auto l = kinematics::optical_frame(kinematics::left_camera(h.config.geometry, q));
  const auto r = kinematics::optical_frame(kinematics::right_camera(h.config.geometry, q));
  const Vector3d pl = l.inverse() * point, pr = r.inverse() * point;
  const double ul = cx + focal * pl.x() / pl.z(), vl = cy + focal * pl.y() / pl.z();
  const double ur = cx + focal * pr.x() / pr.z(), vr = cy + focal * pr.y() / pr.z();
  ASSERT_NEAR(vl, vr, 25.0) << "verged cameras: nearly the same row";
  ASSERT_TRUE(h.controller.look_at_stereo(ul, vl, ul - ur, focal, cx, cy).ok()) << h.controller.last_rejection();
  h.run(1.0);
  EXPECT_LT(h.error_deg(0, point), 0.6) << "rows differ a little: the pair is triangulated as the closest point";
  // A relative turn: 10 degrees right of the current fixation, seen from between the cameras.
  const auto fix = h.controller.fixation();
  ASSERT_TRUE(fix.valid);
  ASSERT_TRUE(h.controller.turn(10 * M_PI / 180, 0).ok()) << h.controller.last_rejection();
  h.run(1.0);
  const auto fix2 = h.controller.fixation();
  const double az1 = std::atan2(fix.point.x(), fix.point.y()), az2 = std::atan2(fix2.point.x(), fix2.point.y());
  EXPECT_NEAR((az2 - az1) * 180 / M_PI, 10.0, 0.5);
}

TEST(GazeController, RefusesWhatGeometryForbidsAndSaysWhy) {
  IdealHead h;
  EXPECT_EQ(h.controller.look_at({0, 1, 0}).message(), "no joint state yet");
  h.step();
  EXPECT_FALSE(h.controller.look_at({0.05, 0.0, 0.12}).ok()) << "inside the circle the cameras sweep";
  EXPECT_FALSE(h.controller.look_along(0, Vector3d(0, 0, -1), 1.0).ok());
  EXPECT_EQ(h.controller.stats().rejected, 3) << "the first had no joint state";
}

TEST(GazeController, JointLimitsHoldUnderRandomRequests) {
  IdealHead h;
  h.step();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-4, 4), y(-1, 4), z(-3, 3), angle(-2, 2);
  const auto limits = h.config.joint_limits();
  double worst_velocity = 0;
  for (int request = 0; request < 300; ++request) {
    if (request % 3 == 0) {
      h.controller.turn(angle(rng), angle(rng));
    } else {
      h.controller.look_at({x(rng), y(rng), z(rng)});
    }
    for (int i = 0; i < 1 + static_cast<int>(rng() % 60); ++i) {
      const HeadCommand& c = h.step();
      for (std::size_t j = 0; j < limits.size(); ++j) {
        ASSERT_GE(c.position[j], limits[j].min - 1e-12) << joint_name(static_cast<int>(j));
        ASSERT_LE(c.position[j], limits[j].max + 1e-12) << joint_name(static_cast<int>(j));
        worst_velocity = std::max(worst_velocity, std::abs(c.velocity[j]) / limits[j].velocity);
      }
    }
  }
  EXPECT_GT(h.controller.stats().clamped, 10) << "many requests were beyond the limits";
  EXPECT_LE(worst_velocity, 1.001) << "re-plans from any state keep the velocity limit";
  EXPECT_FALSE(h.controller.holding()) << h.controller.fault();
}

TEST(GazeController, SmallCorrectionsArePursuitLargeOnesSaccades) {
  IdealHead h;
  h.step();
  h.controller.look_at({0.0, 1.5, 0.12});
  h.run(0.5);
  for (int i = 1; i <= 10; ++i) {
    h.controller.look_at({0.01 * i, 1.5, 0.12});  // about 0.4 degrees each
    h.run(0.04);
  }
  EXPECT_EQ(h.controller.stats().saccades, 1);
  EXPECT_EQ(h.controller.stats().pursuits, 10);
}

TEST(GazeController, TroubleHoldsTheHeadUntilReset) {
  struct Trouble {
    const char* name;
    std::function<void(IdealHead&)> cause;
    const char* fault;
  };
  const std::vector<Trouble> troubles = {
      {"drive fault", [](IdealHead& h) { h.readings[2].health = JointReading::Health::kFault; },
       "tilt_left: drive fault"},
      {"silent drive", [](IdealHead& h) { h.readings[4].health = JointReading::Health::kSilent; },
       "tilt_right: drive silent"},
      {"stale feedback", [](IdealHead& h) { h.readings[0].updated_ns = h.now - 80'000'000; },
       "neck: no feedback for 80 ms"},
      {"following error", [](IdealHead& h) { h.readings[1].position += 0.3; }, "vergence_left: following error"},
  };
  for (const Trouble& t : troubles) {
    SCOPED_TRACE(t.name);
    IdealHead h;
    h.step();
    h.controller.look_at({0.5, 1.5, 0.3});
    h.run(0.1);  // mid-saccade
    t.cause(h);
    const HeadCommand& c = h.controller.cycle(h.now, h.readings);
    ASSERT_TRUE(c.hold);
    EXPECT_THAT(c.fault, ::testing::HasSubstr(t.fault));
    const std::vector<double> held = c.position;
    for (std::size_t j = 0; j < held.size(); ++j)
      EXPECT_NEAR(held[j], h.readings[j].position, 1e-9) << "holds where the joints are";
    EXPECT_FALSE(h.controller.look_at({0.0, 1.5, 0.12}).ok()) << "no motion while holding";
    // Whatever the readings do next, the hold stays.
    for (auto& r : h.readings) r = {r.position, 0, JointReading::Health::kReady, h.now};
    for (int i = 0; i < 10; ++i) EXPECT_EQ(h.step().position, held);
    // Reset: drives come back through starting, then motion resumes from where they are.
    h.controller.reset();
    EXPECT_EQ(h.controller.cycle(h.now, h.readings).reset, 1);
    EXPECT_FALSE(h.controller.holding());
    EXPECT_TRUE(h.controller.look_at({0.0, 1.5, 0.12}).ok()) << h.controller.last_rejection();
    h.run(1.0);
    EXPECT_LT(h.error_deg(0, {0.0, 1.5, 0.12}), 1e-6);
  }
}

}  // namespace
}  // namespace saccade::head
