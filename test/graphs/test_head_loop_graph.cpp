// graphs/head_loop.xml, the whole active vision loop on one machine, in
// simulated time: the target swings beyond the cameras' field of view, the
// fovea asks for gaze shifts, the head turns through the CAN driver and the
// simulated drives, and the target stays in view.
#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <cmath>
#include <thread>
#include <cstdio>

#include "support.hpp"

namespace saccade {
namespace {

const std::vector<std::string> kSimulated = {"driver.realtime=false", "drives.realtime=false", "driver.duration=16",
                                             "drives.duration=16"};

struct LoopFigures {
  int frames = 0, visible = 0;
  double neck_min = 0, neck_max = 0;
  int64_t gaze_requests = 0;
  double max_target_azimuth_deg = 0;
};

LoopFigures run(const std::vector<std::string>& extra) {
  std::vector<std::string> overrides = kSimulated;
  overrides.insert(overrides.end(), extra.begin(), extra.end());
  test::run_recording(SACCADE_SOURCE_DIR "/graphs/head_loop.xml", overrides, {"truth", "drive_truth", "snapshot"});
  LoopFigures f;
  const auto truth = test::recorded<Region>("truth");
  const auto joints = test::recorded<JointState>("drive_truth");
  const auto states = test::recorded<FoveaState>("snapshot");
  // From the second second on: the loop has started and the drives are enabled.
  for (const auto& t : truth) {
    if (t->timestamp_ns < 1'000'000'000) continue;
    ++f.frames;
    f.visible += t->label == "visible";
  }
  for (const auto& j : joints) {
    f.neck_min = std::min(f.neck_min, j->position[0] * 180 / M_PI);
    f.neck_max = std::max(f.neck_max, j->position[0] * 180 / M_PI);
  }
  if (!states.empty()) f.gaze_requests = states.back()->gaze_requests;
  return f;
}

TEST(HeadLoopGraph, TheHeadTurnsAndTheTargetStaysInView) {
  const LoopFigures f = run({});
  std::printf(
      "[ figure ] head loop: target in view %d of %d frames (%.1f%%), neck %.1f..%.1f deg, %lld gaze requests\n",
      f.visible, f.frames, 100.0 * f.visible / std::max(1, f.frames), f.neck_min, f.neck_max,
      static_cast<long long>(f.gaze_requests));
  ASSERT_GT(f.frames, 300);
  EXPECT_GE(f.visible, f.frames * 95 / 100);
  EXPECT_LT(f.neck_min, -25.0) << "the head turned left";
  EXPECT_GT(f.neck_max, 25.0) << "and right";
  EXPECT_GE(f.gaze_requests, 4);
}

TEST(HeadLoopGraph, WithoutTheHeadTheTargetLeavesTheView) {
  // The same scene with the head's joints held (no gaze requests reach it).
  const LoopFigures f = run({"head.velocity=1", "head.acceleration=1", "head.saccade_threshold=180"});
  EXPECT_LT(f.visible, f.frames * 70 / 100) << f.visible << " of " << f.frames;
}

TEST(DrivesProgram, TheSimulatedDrivesRunAsTheirOwnProcessBehindAUdpTunnel) {
  // graphs/drives_sim.xml in a child process stands in for the robot's motors; a
  // CAN driver here configures and enables them over the cannelloni tunnel.
  const auto [master_port, drives_port] = test::free_udp_ports();
  int child = test::spawn_saccade(
      {"--log-level", "warn", "run", SACCADE_SOURCE_DIR "/graphs/drives_sim.xml", "--set",
       "drives.bus=udp:" + std::to_string(drives_port) + ":127.0.0.1:" + std::to_string(master_port), "--duration",
       "10"});
  ASSERT_GT(child, 0);
  // The master gives a drive three SDO attempts; start it once the drives listen.
  for (int i = 0; i < 1000 && !test::udp_port_in_use(drives_port); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  testing::Recorder::instance().clear();
  auto run = test::open_graph(R"(<graph name="master">
    <node name="driver" plugin="can.driver">
      <param name="bus" value="udp:)" +
                              std::to_string(master_port) + ":127.0.0.1:" + std::to_string(drives_port) + R"("/>
      <param name="duration" value="5"/>
      <param name="wait_ms" value="2"/>
    </node>
    <node name="state" plugin="util.record"/>
    <edge from="driver.state" to="state.in"/>
  </graph>)");
  Status status = run->run();
  ::kill(child, SIGTERM);  // a clean stop, as Ctrl-C: the command then exits 128 + the signal
  EXPECT_EQ(test::wait_child(child, 20), 128 + SIGTERM);
  ASSERT_TRUE(status.ok()) << status.message();
  const auto states = test::recorded<JointState>("state");
  ASSERT_GT(states.size(), 500u);
  int ready_cycles = 0;
  for (const auto& s : states) ready_cycles += s->all_ready();
  EXPECT_TRUE(states.back()->all_ready()) << states.back()->detail;
  EXPECT_GE(ready_cycles, 250) << "at least a second of the run with every drive enabled";
  ASSERT_EQ(states.back()->position.size(), 5u) << "the head's five joints";
  for (double p : states.back()->position) EXPECT_NEAR(p, 0.0, 1e-3);
}

}  // namespace
}  // namespace saccade
