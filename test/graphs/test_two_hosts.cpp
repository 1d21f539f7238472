// Two hosts on one machine: two network namespaces joined by a veth pair, each
// with its own /dev/shm (so nothing can pass but the link), a saccade process
// in each. Discovery by multicast, and by initial peers only with multicast
// off; a link cut mid-run and restored. Skips, saying why, where namespaces
// cannot be made (they need root or CAP_NET_ADMIN).
#include <gtest/gtest.h>

#include <signal.h>
#include <spawn.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "support.hpp"

extern char** environ;

namespace saccade {
namespace {

namespace fs = std::filesystem;

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

class TwoHosts : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string id = std::to_string(getpid());
    head_ = "saccade_" + id + "_head";
    robot_ = "saccade_" + id + "_robot";
    dir_ = fs::temp_directory_path() / ("saccade_two_hosts_" + id);
    fs::create_directories(dir_);
    const std::string veth_head = "sv" + id + "h", veth_robot = "sv" + id + "r";
    const std::string setup = test::two_hosts_command(head_, robot_, veth_head, veth_robot, "10.77.0");
    link_down_ = "ip -n " + head_ + " link set " + veth_head + " down";
    link_up_ = "ip -n " + head_ + " link set " + veth_head + " up";
    made_ = std::system((setup + " > " + (dir_ / "setup.log").string() + " 2>&1").c_str()) == 0;
    if (!made_)
      GTEST_SKIP() << "cannot make network namespaces and a veth pair here (ip netns and veth need root or "
                      "CAP_NET_ADMIN; iproute2 and util-linux's unshare): "
                   << test::read_text(dir_ / "setup.log");
  }
  void TearDown() override {
    for (pid_t pid : children_) {
      kill(pid, SIGKILL);
      test::wait_child(pid, 5);
    }
    // Deleting a namespace deletes the veth end inside it, and with it the pair.
    (void)std::system(("ip netns del " + head_ + " 2>/dev/null; ip netns del " + robot_ + " 2>/dev/null").c_str());
    fs::remove_all(dir_);
  }

  // saccade with `args` inside namespace `ns`, with its own /dev/shm; output to `log`.
  pid_t run_in(const std::string& ns, const std::string& env, const std::string& args, const std::string& log) {
    const std::string inner = "mount -t tmpfs tmpfs /dev/shm && exec env " + env +
                              " " SACCADE_BINARY_DIR "/bin/saccade " + args + " > " + (dir_ / log).string() + " 2>&1";
    std::vector<std::string> argv_s = {"ip", "netns", "exec", ns, "unshare", "-m", "sh", "-c", inner};
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    if (posix_spawnp(&pid, "ip", nullptr, nullptr, argv.data(), environ) != 0) return -1;
    children_.push_back(pid);
    return pid;
  }
  int finish(pid_t pid, double timeout_s) {
    int code = test::wait_child(pid, timeout_s);
    children_.erase(std::remove(children_.begin(), children_.end(), pid), children_.end());
    return code;
  }
  std::string log_of(const std::string& log) { return test::read_text(dir_ / log); }

  // A profile with discovery by unicast only (no multicast locator at all) and these initial peers.
  std::string unicast_profile(const std::string& name, const std::string& self, const std::string& peer) {
    const fs::path file = dir_ / name;
    std::ofstream(file) << R"(<?xml version="1.0" encoding="UTF-8"?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <participant profile_name="saccade" is_default_profile="true">
    <rtps>
      <builtin>
        <metatrafficUnicastLocatorList>
          <locator><udpv4><address>)"
                        << self << R"(</address><port>7412</port></udpv4></locator>
        </metatrafficUnicastLocatorList>
        <initialPeersList>
          <locator><udpv4><address>)"
                        << peer << R"(</address><port>7412</port></udpv4></locator>
        </initialPeersList>
      </builtin>
    </rtps>
  </participant>
</profiles>
)";
    return "FASTRTPS_DEFAULT_PROFILES_FILE=" + file.string();
  }

  static std::string publisher(const std::string& extra = "", const std::string& level = "warn") {
    return "--log-level " + level +
           " run " SACCADE_SOURCE_DIR "/test/graphs/peer_counter.xml --set publish.topic=hosts/images " + extra;
  }
  std::string subscriber(const std::string& extra) {
    const fs::path graph = dir_ / "robot.xml";
    std::ofstream(graph) << R"(<graph name="robot">
  <node name="sub" plugin="dds.subscribe"><param name="topic" value="hosts/images"/><param name="type" value="Image"/></node>
  <node name="sink" plugin="util.null"/>
  <edge from="sub.out" to="sink.in"/>
</graph>)";
    return "--log-level info run " + graph.string() + " --stats-json " + (dir_ / "robot.json").string() + " " + extra;
  }
  long received() { return test::stats_emitted(dir_ / "robot.json", "sub"); }

  std::string head_, robot_, link_down_, link_up_;
  fs::path dir_;
  bool made_ = false;
  std::vector<pid_t> children_;
};

TEST_F(TwoHosts, MulticastDiscoveryAcrossTheLinkSurvivesALinkCut) {
  pid_t robot = run_in(robot_, "", subscriber("--duration 60"), "robot.log");
  pid_t head = run_in(head_, "", publisher("", "info"), "head.log");
  ASSERT_GT(robot, 0);
  ASSERT_GT(head, 0);
  const std::string joined = "the writer of hosts/images joined", left = "the writer of hosts/images left";
  const std::string reader_joined = "a reader of hosts/images joined", reader_left = "a reader of hosts/images left";
  ASSERT_TRUE(test::wait_for([&] { return count_of(log_of("robot.log"), joined) == 1; }, 30)) << log_of("robot.log");
  ASSERT_TRUE(test::wait_for([&] { return count_of(log_of("head.log"), reader_joined) == 1; }, 30))
      << log_of("head.log");
  std::this_thread::sleep_for(std::chrono::seconds(1));  // frames flow

  ASSERT_EQ(std::system(link_down_.c_str()), 0);
  // Within the participants' lease (3 s) each side reports the silent peer, and keeps running.
  EXPECT_TRUE(test::wait_for([&] { return count_of(log_of("robot.log"), left) == 1; }, 15)) << log_of("robot.log");
  EXPECT_TRUE(test::wait_for([&] { return count_of(log_of("head.log"), reader_left) == 1; }, 15)) << log_of("head.log");
  ASSERT_EQ(std::system(link_up_.c_str()), 0);
  EXPECT_TRUE(test::wait_for([&] { return count_of(log_of("robot.log"), joined) == 2; }, 30)) << log_of("robot.log");
  // Both ends have matched again (DDS matches each side on its own).
  EXPECT_TRUE(test::wait_for([&] { return count_of(log_of("head.log"), reader_joined) == 2; }, 30))
      << log_of("head.log");

  // Frames flow again: the head's end of stream, sent over the restored
  // link, ends the robot's graph long before its 60 s.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(head, SIGTERM);  // a clean stop: the command exits 128 + the signal
  EXPECT_EQ(finish(head, 30), 128 + SIGTERM) << log_of("head.log");
  EXPECT_EQ(finish(robot, 30), 0) << log_of("robot.log") << "\nhead:\n" << log_of("head.log");
  EXPECT_GT(received(), 50);
}

TEST_F(TwoHosts, InitialPeersAloneFindThePeerWhereMulticastIsOff) {
  // Wrong peers first: with no multicast, nothing else can find the head.
  pid_t robot = run_in(robot_, unicast_profile("robot_wrong.xml", "10.77.0.2", "10.77.0.98"),
                       subscriber("--duration 4"), "robot.log");
  pid_t head = run_in(head_, unicast_profile("head_wrong.xml", "10.77.0.1", "10.77.0.99"), publisher("--duration 4"),
                      "head.log");
  EXPECT_EQ(finish(head, 30), 0) << log_of("head.log");
  EXPECT_EQ(finish(robot, 30), 0) << log_of("robot.log");
  EXPECT_EQ(count_of(log_of("robot.log"), "joined"), 0) << log_of("robot.log");
  EXPECT_EQ(received(), 0);

  // The right peers.
  robot = run_in(robot_, unicast_profile("robot.xml.profile", "10.77.0.2", "10.77.0.1"), subscriber("--duration 60"),
                 "robot2.log");
  head =
      run_in(head_, unicast_profile("head.xml.profile", "10.77.0.1", "10.77.0.2"), publisher("", "info"), "head2.log");
  EXPECT_TRUE(
      test::wait_for([&] { return count_of(log_of("robot2.log"), "the writer of hosts/images joined") == 1; }, 30))
      << log_of("robot2.log");
  EXPECT_TRUE(test::wait_for([&] { return count_of(log_of("head2.log"), "a reader of hosts/images joined") == 1; }, 30))
      << log_of("head2.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(head, SIGTERM);  // a clean stop: the command exits 128 + the signal
  EXPECT_EQ(finish(head, 30), 128 + SIGTERM) << log_of("head2.log");
  EXPECT_EQ(finish(robot, 30), 0) << log_of("robot2.log") << "\nhead:\n" << log_of("head2.log");
  EXPECT_GT(received(), 20);
}

}  // namespace
}  // namespace saccade
