#include "trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace saccade::head {

Quintic::Quintic(const JointState& from, double target, double duration) : duration_(duration) {
  const double p0 = from.position, v0 = from.velocity, a0 = from.acceleration;
  c_[0] = p0;
  c_[1] = v0;
  c_[2] = a0 / 2;
  if (duration <= 0) {
    c_[0] = target;
    c_[1] = c_[2] = 0;
    return;
  }
  // Rest at `target` at T: p(T) = target, v(T) = 0, a(T) = 0.
  const double T = duration, T2 = T * T, T3 = T2 * T, T4 = T3 * T, T5 = T4 * T;
  const double h = target - p0;
  c_[3] = (20 * h - 12 * v0 * T - 3 * a0 * T2) / (2 * T3);
  c_[4] = (-30 * h + 16 * v0 * T + 3 * a0 * T2) / (2 * T4);
  c_[5] = (12 * h - 6 * v0 * T - a0 * T2) / (2 * T5);
}

JointState Quintic::at(double t) const {
  t = std::clamp(t, 0.0, duration_);
  JointState s;
  s.position = c_[0] + t * (c_[1] + t * (c_[2] + t * (c_[3] + t * (c_[4] + t * c_[5]))));
  s.velocity = c_[1] + t * (2 * c_[2] + t * (3 * c_[3] + t * (4 * c_[4] + t * 5 * c_[5])));
  s.acceleration = 2 * c_[2] + t * (6 * c_[3] + t * (12 * c_[4] + t * 20 * c_[5]));
  return s;
}

Trajectory::Trajectory(std::vector<JointLimit> limits) : limits_(std::move(limits)), joints_(limits_.size()) {}

namespace {

// Largest |velocity|, |acceleration| and the position range of a quintic, sampled finely.
struct Extremes {
  double velocity = 0, acceleration = 0, low = 0, high = 0;
};
Extremes extremes(const Quintic& q) {
  Extremes e;
  e.low = e.high = q.at(0).position;
  constexpr int kSamples = 200;
  for (int i = 0; i <= kSamples; ++i) {
    const JointState s = q.at(q.duration() * i / kSamples);
    e.velocity = std::max(e.velocity, std::abs(s.velocity));
    e.acceleration = std::max(e.acceleration, std::abs(s.acceleration));
    e.low = std::min(e.low, s.position);
    e.high = std::max(e.high, s.position);
  }
  return e;
}

}  // namespace

double Trajectory::plan(const std::vector<JointState>& now, const std::vector<double>& target) {
  clamped_.clear();
  const std::size_t n = limits_.size();
  std::vector<double> goal(n);
  for (std::size_t j = 0; j < n; ++j) {
    goal[j] = std::clamp(target.at(j), limits_[j].min, limits_[j].max);
    if (goal[j] != target[j] && clamped_.empty())
      clamped_ = "joint " + std::to_string(j) + ": " + std::to_string(target[j]) + " rad is beyond [" +
                 std::to_string(limits_[j].min) + ", " + std::to_string(limits_[j].max) + "]";
  }
  // From rest the minimum-jerk peaks are 1.875 h / T (velocity) and
  // 5.7735 h / T^2 (acceleration): the first guess of the common duration;
  // then lengthened until every joint, from its actual state, keeps its
  // limits (a joint already moving may need longer to come to rest).
  double duration = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const double h = std::abs(goal[j] - now.at(j).position);
    duration = std::max({duration, 1.875 * h / limits_[j].velocity, std::sqrt(5.7735 * h / limits_[j].acceleration)});
  }
  const bool moving = std::any_of(now.begin(), now.end(), [](const JointState& s) {
    return std::abs(s.velocity) > 1e-12 || std::abs(s.acceleration) > 1e-12;
  });
  if (duration <= 1e-9 && !moving) {
    for (std::size_t j = 0; j < n; ++j) joints_[j] = Quintic(now[j], goal[j], 0);
    duration_ = 0;
    return 0;
  }
  duration = std::max(duration, 1e-3);
  // A joint already racing toward its limit may overshoot whatever the
  // duration: after a bounded search the last plan stands, and at() keeps
  // its positions inside the limits.
  for (int attempt = 0; attempt < 40; ++attempt) {
    bool within = true;
    for (std::size_t j = 0; j < n; ++j) {
      joints_[j] = Quintic(now[j], goal[j], duration);
      const Extremes e = extremes(joints_[j]);
      within = within && e.velocity <= limits_[j].velocity * 1.0001 &&
               e.acceleration <= limits_[j].acceleration * 1.0001 && e.low >= limits_[j].min - 1e-9 &&
               e.high <= limits_[j].max + 1e-9;
    }
    if (within) break;
    duration *= 1.15;
  }
  duration_ = duration;
  return duration;
}

std::vector<JointState> Trajectory::at(double t) const {
  std::vector<JointState> out(joints_.size());
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    out[j] = joints_[j].at(t);
    // Positions never leave the limits, even where a re-plan from a fast
    // state could not be timed to stay inside.
    out[j].position = std::clamp(out[j].position, limits_[j].min, limits_[j].max);
  }
  return out;
}

}  // namespace saccade::head
