#pragma once
// What the fault suite's scenarios share: how many rounds to run (make faults
// runs 10, ctest 1 or 2), a summary of the recovery times, JSON lines.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

namespace saccade::faults {

// SACCADE_FAULT_ROUNDS, else `fallback`: each scenario runs this many rounds in a row.
inline int rounds(int fallback) {
  const char* env = std::getenv("SACCADE_FAULT_ROUNDS");
  const int n = env != nullptr ? std::atoi(env) : 0;
  return n > 0 ? n : fallback;
}

// SACCADE_FAULT_SEED (default 1) + round: each round's seed, printed to reproduce it.
inline unsigned seed_of(int round) {
  const char* env = std::getenv("SACCADE_FAULT_SEED");
  return static_cast<unsigned>((env != nullptr ? std::atoi(env) : 1) + round);
}

// Figures over the rounds, printed as "[ fault ] <what>: n N, min / median / max".
struct Figures {
  Figures(std::string what_, std::string unit_) : what(std::move(what_)), unit(std::move(unit_)) {}
  std::string what, unit;
  std::vector<double> values;
  void add(double v) { values.push_back(v); }
  void print() const {
    if (values.empty()) return;
    std::vector<double> v = values;
    std::sort(v.begin(), v.end());
    const double median = v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
    std::printf("[ fault ] %s: n %zu, min %.3f / median %.3f / max %.3f %s\n", what.c_str(), v.size(), v.front(),
                median, v.back(), unit.c_str());
    std::fflush(stdout);
  }
};

}  // namespace saccade::faults
