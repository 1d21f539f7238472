#include "trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

Trajectory::Trajectory(std::vector<JointLimit> limits)
    : limits_(std::move(limits)),
      joints_(limits_.size()),
      second_(limits_.size()),
      goal_(limits_.size()),
      stop_(limits_.size()),
      rest_(limits_.size()) {}

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

double Trajectory::plan(const std::vector<JointState>& now, const std::vector<double>& target, double min_duration) {
  clamped_.clear();
  split_ = -1;
  const std::size_t n = limits_.size();
  std::vector<double>& goal = goal_;
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
  // The shortest duration (not below min_duration) that keeps every joint,
  // from its actual state, within its limits: durations around the guess,
  // ascending. From rest the guess itself fits; a joint already moving may
  // need a shorter move (a long one overshoots the target, and near a limit
  // the limit) or a longer one (to come to rest).
  const double floor = std::max(min_duration, 1e-3);
  const auto fits = [&](const std::vector<double>& to, double t) {
    for (std::size_t j = 0; j < n; ++j) {
      const Extremes e = extremes(Quintic(now[j], to[j], t));
      if (e.velocity > limits_[j].velocity * 1.0001 || e.acceleration > limits_[j].acceleration * 1.0001 ||
          e.low < limits_[j].min - 1e-9 || e.high > limits_[j].max + 1e-9)
        return false;
    }
    return true;
  };
  const double guess = std::max(duration, floor);
  for (int k = -25; k <= 40; ++k) {
    const double candidate = guess * std::pow(1.15, k);
    if (candidate < floor || !fits(goal, candidate)) continue;
    for (std::size_t j = 0; j < n; ++j) joints_[j] = Quintic(now[j], goal[j], candidate);
    duration_ = candidate;
    return candidate;
  }
  // No single quintic fits (a fast joint asked to turn back): first come to
  // rest where the motion naturally stops, then move from rest, which fits.
  std::vector<double>& stop = stop_;
  double brake = 0;
  for (int k = -10; k <= 40 && brake == 0; ++k) {
    const double candidate = std::max(floor, 0.05) * std::pow(1.15, k);
    for (std::size_t j = 0; j < n; ++j)
      stop[j] = std::clamp(now[j].position + now[j].velocity * candidate / 2, limits_[j].min, limits_[j].max);
    if (fits(stop, candidate)) brake = candidate;
  }
  if (brake == 0) brake = std::max(floor, 0.05) * std::pow(1.15, 40);  // at() keeps the positions inside
  std::vector<JointState>& rest = rest_;
  double second = 0;
  for (std::size_t j = 0; j < n; ++j) {
    joints_[j] = Quintic(now[j], stop[j], brake);
    rest[j] = {stop[j], 0.0, 0.0};
    const double h = std::abs(goal[j] - stop[j]);
    second = std::max({second, 1.875 * h / limits_[j].velocity, std::sqrt(5.7735 * h / limits_[j].acceleration)});
  }
  second = std::max(second, 1e-3);
  for (std::size_t j = 0; j < n; ++j) second_[j] = Quintic(rest[j], goal[j], second);
  split_ = brake;
  duration = brake + second;
  duration_ = duration;
  return duration;
}

std::vector<JointState> Trajectory::at(double t) const {
  std::vector<JointState> out;
  at(t, out);
  return out;
}

void Trajectory::at(double t, std::vector<JointState>& out) const {
  out.resize(joints_.size());
  for (std::size_t j = 0; j < joints_.size(); ++j) {
    out[j] = split_ >= 0 && t > split_ ? second_[j].at(t - split_) : joints_[j].at(t);
    // Positions never leave the limits, even where a re-plan from a fast
    // state could not be timed to stay inside.
    if (out[j].position < limits_[j].min || out[j].position > limits_[j].max) {
      out[j] = {std::clamp(out[j].position, limits_[j].min, limits_[j].max), 0.0, 0.0};
    }
  }
}

}  // namespace saccade::head
