#pragma once
// Helpers shared by the benchmark files.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <vector>

#include <opencv2/core.hpp>

namespace saccade::bench {

// Per-call timing, for the p50/p99 counters each micro-benchmark reports next to
// Google Benchmark's mean.
class PerCall {
 public:
  PerCall() { ns_.reserve(1 << 20); }
  void start() { t0_ = std::chrono::steady_clock::now(); }
  void stop() {
    if (ns_.size() < ns_.capacity())
      ns_.push_back(std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0_).count());
  }
  void report(benchmark::State& state) {
    if (ns_.empty()) return;
    std::sort(ns_.begin(), ns_.end());
    state.counters["p50_us"] = ns_[ns_.size() / 2] / 1e3;
    state.counters["p99_us"] = ns_[std::min(ns_.size() - 1, ns_.size() * 99 / 100)] / 1e3;
  }

 private:
  std::vector<double> ns_;
  std::chrono::steady_clock::time_point t0_;
};

inline cv::Size size_arg(const benchmark::State& state) {
  return {static_cast<int>(state.range(0)), static_cast<int>(state.range(1))};
}

}  // namespace saccade::bench
