// The head's control path closed on one machine: gaze controller -> CANopen
// master -> bus -> simulated CiA 402 drives -> TPDOs -> master -> controller,
// on a simulated clock. A 20 degree saccade must end within 0.5 degrees of
// the target inside 1 s of simulated time, over the virtual bus and over the
// cannelloni UDP tunnel on 127.0.0.1 with packets lost; a drive fault and a
// silent drive must each hold the head.
#include <gtest/gtest.h>

#include <cmath>

#include "cannelloni.hpp"
#include "drive_sim.hpp"
#include "gaze_controller.hpp"
#include "master.hpp"
#include "support.hpp"
#include "virtual_bus.hpp"

namespace saccade {
namespace {

using Eigen::Vector3d;

constexpr double kPeriod = 0.004;  // 250 Hz control

can::MasterConfig master_config() {
  can::MasterConfig c;
  for (int j = 0; j < head::kJoints; ++j) c.joints.push_back({head::joint_name(j), j + 1, 20000.0, 1000 * j});
  return c;
}

// The encoders' zero sits 1000 * j counts away from the joint's zero.
std::vector<can::DriveConfig> drive_configs() {
  std::vector<can::DriveConfig> d;
  for (int j = 0; j < head::kJoints; ++j) {
    can::DriveConfig c;
    c.node = j + 1;
    c.counts_per_rad = 20000.0;
    c.initial_position = 1000.0 * j / 20000.0;
    d.push_back(c);
  }
  return d;
}

head::JointReading::Health health(can::DriveHealth h) {
  switch (h) {
    case can::DriveHealth::kReady: return head::JointReading::Health::kReady;
    case can::DriveHealth::kFault: return head::JointReading::Health::kFault;
    case can::DriveHealth::kSilent: return head::JointReading::Health::kSilent;
    case can::DriveHealth::kStarting: break;
  }
  return head::JointReading::Health::kStarting;
}

struct Loop {
  head::HeadConfig config;
  head::GazeController controller{config};
  std::unique_ptr<can::Bus> master_bus;
  std::unique_ptr<can::Master> master;
  std::unique_ptr<can::DriveRack> rack;
  std::shared_ptr<can::VirtualBus> virtual_bus;
  std::vector<can::JointFeedback> feedback;
  std::vector<head::JointReading> readings = std::vector<head::JointReading>(head::kJoints);
  int64_t now = 0, wait_ns = 0;

  void start(std::unique_ptr<can::Bus> to_drives, std::unique_ptr<can::Bus> from_master) {
    master_bus = std::move(to_drives);
    master = std::make_unique<can::Master>(*master_bus, master_config());
    rack = std::make_unique<can::DriveRack>(std::move(from_master), drive_configs());
  }
  void cycle() {
    for (std::size_t j = 0; j < feedback.size(); ++j)
      readings[j] = {feedback[j].position, feedback[j].velocity, health(feedback[j].health), feedback[j].updated_ns};
    const head::HeadCommand& c = controller.cycle(now, readings);
    master->cycle(now, c.position.data(), c.reset, feedback, wait_ns);
    rack->step(now, kPeriod, wait_ns);
    now += static_cast<int64_t>(kPeriod * 1e9);
    if (virtual_bus) virtual_bus->set_time(now);
  }
  bool ready() const {
    return !feedback.empty() && std::all_of(feedback.begin(), feedback.end(),
                                            [](const auto& f) { return f.health == can::DriveHealth::kReady; });
  }
  // Degrees between each camera's optical axis (from the drives' true shaft
  // positions) and the direction to `p`: the larger of the two.
  double gaze_error_deg(const Vector3d& p) {
    kinematics::HeadJoints q;
    double* joints[] = {&q.neck, &q.vergence_left, &q.tilt_left, &q.vergence_right, &q.tilt_right};
    for (std::size_t j = 0; j < 5; ++j)
      *joints[j] = rack->drive(j).position() - 1000.0 * static_cast<double>(j) / 20000.0;
    double worst = 0;
    for (const auto& pose :
         {kinematics::left_camera(config.geometry, q), kinematics::right_camera(config.geometry, q)}) {
      const Vector3d to = (p - pose.translation()).normalized();
      worst = std::max(worst, std::acos(std::clamp(to.dot(kinematics::optical_axis(pose)), -1.0, 1.0)) * 180 / M_PI);
    }
    return worst;
  }
  // Starts the drives, fixates straight ahead, then asks for a saccade of
  // `degrees` to the right; the simulated seconds until the gaze is within
  // 0.5 degrees and stays there (a huge value if never).
  double saccade(double degrees) {
    for (int i = 0; i < 200 && !ready(); ++i) cycle();
    EXPECT_TRUE(ready()) << master->problem();
    const Vector3d ahead(0, 1.5, 0.12);
    EXPECT_EQ(controller.look_at(ahead).message(), "");
    for (int i = 0; i < 250; ++i) cycle();
    EXPECT_LT(gaze_error_deg(ahead), 0.5);
    const double a = degrees * M_PI / 180;
    const Vector3d target(1.5 * std::sin(a), 1.5 * std::cos(a), 0.12);
    EXPECT_EQ(controller.look_at(target).message(), "");
    EXPECT_GT(gaze_error_deg(target), degrees - 1);
    double settled = -1;
    for (int i = 1; i <= 500; ++i) {  // 2 s
      cycle();
      const double e = gaze_error_deg(target);
      if (e < 0.5 && settled < 0) settled = i * kPeriod;
      if (e >= 0.5) settled = -1;
    }
    EXPECT_FALSE(controller.holding()) << controller.fault();
    return settled < 0 ? 1e9 : settled;
  }
};

TEST(HeadLoop, A20DegreeSaccadeSettlesWithinOneSecondOverTheVirtualBus) {
  Loop loop;
  loop.virtual_bus = can::VirtualBus::create();
  loop.virtual_bus->set_time(0);
  loop.virtual_bus->set_faults({0.0, 1'000'000, 1});  // 1 ms bus latency
  loop.start(loop.virtual_bus->attach(), loop.virtual_bus->attach());
  const double settled = loop.saccade(20);
  EXPECT_LT(settled, 1.0);
  std::printf("[ figure ] virtual bus: 20 deg saccade within 0.5 deg after %.3f s simulated\n", settled);
}

TEST(HeadLoop, A20DegreeSaccadeSettlesOverTheUdpTunnelWithLoss) {
  const auto [local, peer] = test::free_udp_ports();
  auto master_end = can::UdpTunnel::open({local, "127.0.0.1", peer, 0.05, 11});
  ASSERT_TRUE(master_end.ok()) << master_end.error();
  auto drive_end = can::UdpTunnel::open({peer, "127.0.0.1", local, 0.05, 12});
  ASSERT_TRUE(drive_end.ok()) << drive_end.error();
  can::UdpTunnel* m = master_end->get();
  can::UdpTunnel* d = drive_end->get();
  Loop loop;
  loop.wait_ns = 3'000'000;  // a lost packet costs this much real time, nothing simulated
  loop.start(std::move(master_end).value(), std::move(drive_end).value());
  const double settled = loop.saccade(20);
  EXPECT_LT(settled, 1.0);
  EXPECT_GT(m->counters().dropped + d->counters().dropped, 20u) << "packets were lost";
  std::printf("[ figure ] udp tunnel, 5%% packet loss: settled after %.3f s simulated; %llu + %llu frames lost\n",
              settled, static_cast<unsigned long long>(m->counters().dropped),
              static_cast<unsigned long long>(d->counters().dropped));
}

TEST(HeadLoop, ADriveFaultAndASilentDriveEachHoldTheHead) {
  for (int trouble = 0; trouble < 2; ++trouble) {
    Loop loop;
    loop.virtual_bus = can::VirtualBus::create();
    loop.virtual_bus->set_time(0);
    loop.start(loop.virtual_bus->attach(), loop.virtual_bus->attach());
    for (int i = 0; i < 200 && !loop.ready(); ++i) loop.cycle();
    ASSERT_TRUE(loop.ready());
    ASSERT_EQ(loop.controller.look_at({0.8, 1.5, 0.3}).message(), "");
    for (int i = 0; i < 20; ++i) loop.cycle();  // mid-saccade
    if (trouble == 0)
      loop.rack->drive(1).inject_fault(can::emcy::kGeneric);
    else
      loop.rack->drive(3).set_silent(true);
    for (int i = 0; i < 30; ++i) loop.cycle();
    ASSERT_TRUE(loop.controller.holding());
    // A silent drive: the head's own feedback timeout and the master's
    // supervision race; either names the joint.
    EXPECT_EQ(loop.controller.fault().rfind(trouble == 0 ? "vergence_left: drive fault" : "vergence_right: ", 0), 0u)
        << loop.controller.fault();
    // The other joints stop where they are.
    const double neck = loop.rack->drive(0).position();
    for (int i = 0; i < 50; ++i) loop.cycle();
    EXPECT_NEAR(loop.rack->drive(0).position(), neck, 0.02);
    // Reset: back to ready, and motion again.
    if (trouble == 1) loop.rack->drive(3).set_silent(false);
    loop.controller.reset();
    for (int i = 0; i < 100; ++i) loop.cycle();
    EXPECT_TRUE(loop.ready()) << loop.master->problem();
    EXPECT_EQ(loop.controller.look_at({0.0, 1.5, 0.12}).message(), "");
    for (int i = 0; i < 250; ++i) loop.cycle();
    EXPECT_LT(loop.gaze_error_deg({0.0, 1.5, 0.12}), 0.5);
  }
}

}  // namespace
}  // namespace saccade
