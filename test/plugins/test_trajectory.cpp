// The head's joint trajectories: minimum-jerk moves within velocity,
// acceleration and position limits, re-planned smoothly mid-move.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "trajectory.hpp"

namespace saccade::head {
namespace {

std::vector<JointLimit> head_limits() {
  // neck, vergence left, tilt left, vergence right, tilt right
  return {{-1.6, 1.6, 2.0, 20.0},
          {-0.6, 0.6, 4.0, 40.0},
          {-0.8, 0.8, 3.0, 30.0},
          {-0.6, 0.6, 4.0, 40.0},
          {-0.8, 0.8, 3.0, 30.0}};
}

TEST(Quintic, RestToRestIsTheMinimumJerkProfile) {
  const Quintic q({0.0, 0.0, 0.0}, 1.0, 2.0);
  EXPECT_NEAR(q.at(0).position, 0.0, 1e-12);
  EXPECT_NEAR(q.at(2).position, 1.0, 1e-12);
  EXPECT_NEAR(q.at(2).velocity, 0.0, 1e-12);
  EXPECT_NEAR(q.at(2).acceleration, 0.0, 1e-12);
  // Peak velocity 1.875 h / T at the middle.
  EXPECT_NEAR(q.at(1).velocity, 1.875 / 2.0, 1e-12);
  // From a moving state: starts there, ends at rest.
  const Quintic m({0.2, 1.5, -3.0}, -0.4, 0.7);
  EXPECT_NEAR(m.at(0).velocity, 1.5, 1e-12);
  EXPECT_NEAR(m.at(0).acceleration, -3.0, 1e-12);
  EXPECT_NEAR(m.at(0.7).position, -0.4, 1e-12);
  EXPECT_NEAR(m.at(0.7).velocity, 0.0, 1e-9);
}

TEST(Trajectory, AllJointsArriveTogetherWithinTheirLimits) {
  const auto limits = head_limits();
  Trajectory traj(limits);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<JointState> now(5);
  for (int move = 0; move < 50; ++move) {
    std::vector<double> target(5);
    for (std::size_t j = 0; j < 5; ++j) target[j] = u(rng) * limits[j].max * 0.95;
    const double T = traj.plan(now, target);
    ASSERT_GT(T, 0);
    for (int i = 0; i <= 400; ++i) {
      const auto s = traj.at(T * i / 400);
      for (std::size_t j = 0; j < 5; ++j) {
        EXPECT_LE(std::abs(s[j].velocity), limits[j].velocity * 1.001) << "joint " << j;
        EXPECT_LE(std::abs(s[j].acceleration), limits[j].acceleration * 1.001) << "joint " << j;
      }
    }
    const auto end = traj.at(T);
    for (std::size_t j = 0; j < 5; ++j) {
      EXPECT_NEAR(end[j].position, target[j], 1e-9);
      EXPECT_NEAR(end[j].velocity, 0.0, 1e-9);
    }
    now = end;
  }
}

TEST(Trajectory, ReplanningMidMoveIsSmoothAndEndsAtTheClampedTarget) {
  const auto limits = head_limits();
  Trajectory traj(limits);
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> u(-2.0, 2.0);  // beyond the limits on purpose
  std::vector<JointState> now(5);
  std::vector<double> target(5);
  for (std::size_t j = 0; j < 5; ++j) target[j] = u(rng);
  double T = traj.plan(now, target);
  EXPECT_NE(traj.clamped(), "") << "a target beyond a limit is clamped, and said so";
  // A new target every 40 ms (the vision's rate), as a pursuit does.
  for (int k = 0; k < 100; ++k) {
    const double dt = std::min(0.04, T);
    const auto before = traj.at(dt);
    for (std::size_t j = 0; j < 5; ++j) target[j] = u(rng);
    T = traj.plan(before, target);
    const auto after = traj.at(0);
    for (std::size_t j = 0; j < 5; ++j) {
      EXPECT_NEAR(after[j].position, before[j].position, 1e-12) << "position continuous";
      EXPECT_NEAR(after[j].velocity, before[j].velocity, 1e-9) << "velocity continuous";
      EXPECT_NEAR(after[j].acceleration, before[j].acceleration, 1e-9) << "acceleration continuous";
    }
  }
  // The last target, beyond the limits on some joints, is reached at the limits, at rest.
  const auto end = traj.at(T);
  for (std::size_t j = 0; j < 5; ++j) {
    EXPECT_NEAR(end[j].position, std::clamp(target[j], limits[j].min, limits[j].max), 1e-9) << "joint " << j;
    EXPECT_NEAR(end[j].velocity, 0.0, 1e-9);
  }
}

TEST(Trajectory, AlreadyThereTakesNoTime) {
  Trajectory traj(head_limits());
  std::vector<JointState> now(5);
  EXPECT_EQ(traj.plan(now, {0, 0, 0, 0, 0}), 0.0);
  EXPECT_EQ(traj.clamped(), "");
}

}  // namespace
}  // namespace saccade::head
