// The head's control cycle: joint targets -> CANopen frames -> virtual bus ->
// five simulated CiA 402 drives (each advancing its 4 kHz position loop for
// one 4 ms cycle) -> TPDOs -> joint state; with and without the gaze
// controller in front. Median and p99 per cycle are reported as counters.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "drive_sim.hpp"
#include "gaze_controller.hpp"
#include "master.hpp"
#include "virtual_bus.hpp"

namespace {

using namespace saccade;

void report(benchmark::State& state, std::vector<double>& ns) {
  if (ns.empty()) return;
  std::sort(ns.begin(), ns.end());
  state.counters["p50_us"] = ns[ns.size() / 2] / 1e3;
  state.counters["p99_us"] = ns[ns.size() * 99 / 100] / 1e3;
}

void BM_Head_ControlCycle(benchmark::State& state) {
  const bool with_controller = state.range(0) != 0;
  auto bus = can::VirtualBus::create();
  bus->set_time(0);
  auto port = bus->attach();
  can::MasterConfig config;
  std::vector<can::DriveConfig> drives;
  for (int j = 0; j < head::kJoints; ++j) {
    config.joints.push_back({head::joint_name(j), j + 1, 20000.0, 0});
    can::DriveConfig d;
    d.node = j + 1;
    d.counts_per_rad = 20000.0;
    drives.push_back(d);
  }
  can::Master master(*port, config);
  can::DriveRack rack(bus->attach(), drives);
  head::GazeController controller{head::HeadConfig{}};
  std::vector<can::JointFeedback> feedback;
  std::vector<head::JointReading> readings(head::kJoints);
  std::vector<double> targets(head::kJoints, 0.0);
  int64_t now = 0;
  const int64_t period = 4'000'000;
  int64_t cycle = 0;
  const auto step = [&] {
    const double* t = targets.data();
    int64_t reset = 0;
    if (with_controller) {
      for (std::size_t j = 0; j < feedback.size(); ++j)
        readings[j] = {feedback[j].position, feedback[j].velocity,
                       feedback[j].health == can::DriveHealth::kReady ? head::JointReading::Health::kReady
                                                                      : head::JointReading::Health::kStarting,
                       feedback[j].updated_ns};
      const head::HeadCommand& c = controller.cycle(now, readings);
      t = c.position.data();
      reset = c.reset;
      if (cycle % 100 == 50) controller.look_at({std::sin(cycle * 0.01), 1.5, 0.12});  // a saccade every 0.4 s
    } else {
      for (int j = 0; j < head::kJoints; ++j) targets[static_cast<std::size_t>(j)] = 0.3 * std::sin(cycle * 0.004 + j);
    }
    master.cycle(now, t, reset, feedback);
    rack.step(now, period * 1e-9);
    now += period;
    bus->set_time(now);
    ++cycle;
  };
  for (int i = 0; i < 100; ++i) step();  // configured and enabled
  if (!master.all_ready()) state.SkipWithError("drives not ready");
  std::vector<double> ns;
  ns.reserve(1 << 20);
  double bits = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    step();
    ns.push_back(static_cast<double>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count()));
    bits += master.stats().bits_last_cycle;
  }
  // Set-point cycles (RPDO2 + RPDO1) and acknowledge cycles (RPDO1) alternate: the mean.
  state.counters["bits_per_cycle"] = ns.empty() ? 0 : bits / static_cast<double>(ns.size());
  report(state, ns);
}
BENCHMARK(BM_Head_ControlCycle)->Arg(0)->Arg(1)->ArgNames({"controller"});

}  // namespace
