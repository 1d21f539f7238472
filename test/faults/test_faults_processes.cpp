// The fault suite on graphs/two_pc.xml run as real processes: either process
// killed with SIGKILL and started again, round after round, and the DDS link
// between them cut for 5 s (two network namespaces). Each round prints how
// long the other side took to resume and what was lost, and asserts it:
// resumed soon after the restart (kResume), the head held meanwhile, and nothing a
// killed process left in /dev/shm stays once the next process has started.
// SACCADE_FAULT_ROUNDS rounds in a row (kills: default 2; make faults: 10).
//
// What the test watches: the vision process's left-camera truth (one JSON line
// per frame it renders, flushed) and the drives' true shaft positions (one line
// per 4 ms step), both stamped on the host's steady clock, and each process's
// log. For the kills the drives run as a third process (the motors behind the
// CAN tunnel), so that they outlive the robot process as real motors do.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "fault_support.hpp"
#include "support.hpp"

extern char** environ;

namespace saccade {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = M_PI / 180.0;

double since(int64_t from_ns, int64_t to_ns) { return static_cast<double>(to_ns - from_ns) * 1e-9; }
void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

// The complete lines a child has appended to a JSON-lines file so far.
class Tail {
 public:
  struct Line {
    int64_t origin_ns = 0;
    std::vector<double> position;
  };
  explicit Tail(fs::path path) : path_(std::move(path)) {}
  const std::vector<Line>& poll() {
    std::ifstream in(path_, std::ios::binary);
    if (!in) return lines_;
    in.seekg(static_cast<std::streamoff>(offset_));
    std::string chunk((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    offset_ += chunk.size();
    partial_ += chunk;
    for (std::size_t nl; (nl = partial_.find('\n')) != std::string::npos; partial_.erase(0, nl + 1)) {
      const auto j = nlohmann::json::parse(partial_.substr(0, nl), nullptr, false);
      if (j.is_discarded()) continue;
      Line l;
      l.origin_ns = j.value("origin_ns", int64_t{0});
      if (j.contains("position")) l.position = j["position"].get<std::vector<double>>();
      lines_.push_back(std::move(l));
    }
    return lines_;
  }
  // The first line stamped at or after `t_ns`; -1 when none yet.
  int64_t first_after(int64_t t_ns) {
    for (const Line& l : poll())
      if (l.origin_ns >= t_ns) return l.origin_ns;
    return -1;
  }
  // The last line stamped before `t_ns`; -1 when none.
  int64_t last_before(int64_t t_ns) {
    int64_t last = -1;
    for (const Line& l : poll())
      if (l.origin_ns < t_ns) last = l.origin_ns;
    return last;
  }
  int count_between(int64_t from_ns, int64_t to_ns) {
    int n = 0;
    for (const Line& l : poll()) n += l.origin_ns >= from_ns && l.origin_ns < to_ns;
    return n;
  }
  // How far any joint moved between the two times, degrees.
  double drift_deg(int64_t from_ns, int64_t to_ns) {
    std::vector<double> lo, hi;
    for (const Line& l : poll()) {
      if (l.origin_ns < from_ns || l.origin_ns >= to_ns) continue;
      lo.resize(l.position.size(), 1e9);
      hi.resize(l.position.size(), -1e9);
      for (std::size_t k = 0; k < l.position.size(); ++k) {
        lo[k] = std::min(lo[k], l.position[k]);
        hi[k] = std::max(hi[k], l.position[k]);
      }
    }
    double most = 0;
    for (std::size_t k = 0; k < lo.size(); ++k) most = std::max(most, (hi[k] - lo[k]) / kDeg);
    return most;
  }

 private:
  fs::path path_;
  std::size_t offset_ = 0;
  std::string partial_;
  std::vector<Line> lines_;
};

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// `argv` as a child, its stdout and stderr appended to `log`.
pid_t spawn_logged(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> copy = args;
  std::vector<char*> argv;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

bool alive(pid_t pid) { return waitpid(pid, nullptr, WNOHANG) == 0; }

// DDS' own /dev/shm files process `pid` maps (participant segments, data-sharing
// pools, frame rings, mailboxes; Fast DDS' port files are shared by design).
std::set<std::string> shm_files_of(pid_t pid) {
  static const std::regex own("fastrtps_[0-9a-f]{16}|fast_datasharing_.*|saccade_ring_.*|saccade_mail_.*");
  std::set<std::string> out;
  std::ifstream maps("/proc/" + std::to_string(pid) + "/maps");
  std::string line;
  while (std::getline(maps, line)) {
    const auto at = line.find("/dev/shm/");
    if (at == std::string::npos) continue;
    std::string name = line.substr(at + 9);
    if (auto deleted = name.find(" (deleted)"); deleted != std::string::npos) name.resize(deleted);
    if (std::regex_match(name, own)) out.insert(name);
  }
  return out;
}
std::vector<std::string> still_there(const std::set<std::string>& files) {
  std::vector<std::string> out;
  for (const auto& f : files)
    if (fs::exists("/dev/shm/" + f)) out.push_back(f);
  return out;
}

// graphs/two_pc.xml with what the suite watches: the left camera's truth and the
// drives' shafts as flushed JSON lines; `edit` then changes it further.
bool replace_once(std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) {
    ADD_FAILURE() << "graphs/two_pc.xml no longer holds '" << from << "'";
    return false;
  }
  text.replace(at, from.size(), to);
  return true;
}
std::string jsonl(const std::string& name, const std::string& process, const fs::path& path) {
  return "<node name=\"" + name + "\" process=\"" + process + "\" plugin=\"util.jsonl\"><param name=\"path\" value=\"" +
         path.string() + "\"/><param name=\"flush\" value=\"true\"/></node>";
}

class FaultsTwoPc : public ::testing::Test {
 protected:
  void SetUp() override {
    id_ = std::to_string(getpid());
    dir_ = fs::temp_directory_path() / ("saccade_faults_" + id_);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    prefix_ = "test/faults/" + id_;
  }
  void TearDown() override {
    for (pid_t pid : children_)
      if (alive(pid)) {
        kill(pid, SIGKILL);
        test::wait_child(pid, 5);
      }
    if (!HasFailure()) fs::remove_all(dir_);
  }
  // The graph, with `motors`: the drives as a process of their own.
  std::string write_graph(bool motors, const std::string& head_host, const std::string& robot_host) {
    std::string g = test::read_text(SACCADE_SOURCE_DIR "/graphs/two_pc.xml");
    replace_once(g, "<process name=\"head_pc\" host=\"localhost\"/>",
                 "<process name=\"head_pc\" host=\"" + head_host + "\"/>");
    replace_once(g, "<process name=\"robot_pc\" host=\"localhost\"/>",
                 "<process name=\"robot_pc\" host=\"" + robot_host + "\"/>" +
                     (motors ? "<process name=\"motors\" host=\"" + robot_host + "\"/>" : std::string()));
    replace_once(g, "<node name=\"truth\" process=\"head_pc\" plugin=\"util.null\"/>",
                 jsonl("truth", "head_pc", dir_ / "frames_0.jsonl"));
    replace_once(g, "<node name=\"drive_truth\" process=\"robot_pc\" plugin=\"util.null\"/>",
                 jsonl("drive_truth", motors ? "motors" : "robot_pc", dir_ / "shafts.jsonl"));
    if (motors)
      replace_once(g, "<node name=\"drives\" process=\"robot_pc\"", "<node name=\"drives\" process=\"motors\"");
    const fs::path file = dir_ / "two_pc_faults.xml";
    std::ofstream(file) << g;
    return file.string();
  }
  std::vector<std::string> args(const std::string& process, const std::vector<std::string>& extra = {}) {
    std::vector<std::string> a = {SACCADE_BINARY_DIR "/bin/saccade",
                                  "--log-level",
                                  "info",
                                  "run",
                                  graph_,
                                  "--stats",  // at exit: what each node took in and sent
                                  "0",
                                  "--process",
                                  process,
                                  "--domain",
                                  std::to_string(test::private_domain()),
                                  "--topic-prefix",
                                  prefix_,
                                  "--set",
                                  "driver.duration=0",
                                  "--set",
                                  "drives.duration=0",
                                  "--set",
                                  "snapshot.dir=" + (dir_ / "snapshots").string()};
    a.insert(a.end(), bus_.begin(), bus_.end());
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  }
  pid_t start(const std::vector<std::string>& argv, const std::string& log) {
    const pid_t pid = spawn_logged(argv, dir_ / log);
    if (pid > 0) children_.push_back(pid);
    return pid;
  }
  std::string log_of(const std::string& log) { return test::read_text((dir_ / log).string()); }
  // Times a log line `what` appears the `n`th time (polled every 20 ms); -1 after `timeout_s`.
  int64_t when_logged(const std::string& log, const std::string& what, int n, double timeout_s) {
    int64_t at = -1;
    test::wait_for(
        [&] {
          if (count_of(log_of(log), what) < n) return false;
          at = steady_now_ns();
          return true;
        },
        timeout_s);
    return at;
  }
  std::string gaze_joined() const { return "the writer of " + prefix_ + "/fovea/gaze joined"; }

  void kill_and_restart(bool vision);

  std::string id_, prefix_, graph_;
  fs::path dir_;
  std::vector<std::string> bus_;
  std::vector<pid_t> children_;
};

constexpr double kLifetime = 6.0;  // s each incarnation runs before it is killed (stale files are 5 s old at least)
constexpr double kOutage = 1.0;    // s between the kill and the restart
// s: the bound asserted for the other side to resume, the reliability issue's
// floor. (It was missed while a killed listener cost each new participant Fast
// DDS' 1 s shared-memory health check per port: see TransportSettings.) A
// sanitizer build starts its processes several times slower: there the bound
// is twice as long, and the rounds over 2 s are still counted and printed.
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
constexpr double kResume = 4.0;
#else
constexpr double kResume = 2.0;
#endif
constexpr double kFloor = 2.0;

void FaultsTwoPc::kill_and_restart(bool vision) {
  const std::string victim = vision ? "head_pc" : "robot_pc";
  graph_ = write_graph(true, "localhost", "localhost");
  const auto [master_port, drives_port] = test::free_udp_ports();
  bus_ = {"--set", "driver.bus=udp:" + std::to_string(master_port) + ":127.0.0.1:" + std::to_string(drives_port),
          "--set", "drives.bus=udp:" + std::to_string(drives_port) + ":127.0.0.1:" + std::to_string(master_port)};
  const pid_t motors = start(args("motors"), "motors.log");
  pid_t robot = start(args("robot_pc"), "robot_0.log");
  pid_t head = start(args("head_pc"), "head_0.log");
  ASSERT_GT(motors, 0);
  ASSERT_GT(robot, 0);
  ASSERT_GT(head, 0);
  int64_t born = steady_now_ns();
  Tail frames(dir_ / "frames_0.jsonl"), shafts(dir_ / "shafts.jsonl");
  ASSERT_TRUE(test::wait_for([&] { return frames.first_after(0) > 0; }, 60)) << "the loop never ran\nrobot:\n"
                                                                             << log_of("robot_0.log") << "\nhead:\n"
                                                                             << log_of("head_0.log");

  faults::Figures resume{victim + " killed: the loop resumed after the restart in", "s"};
  faults::Figures lost{victim + " killed: no frames for", "s"};
  std::vector<std::set<std::string>> killed_files;
  const int n = faults::rounds(2);
  int over_floor = 0;
  for (int round = 0; round < n; ++round) {
    pid_t& pid = vision ? head : robot;
    const std::string log = (vision ? "head_" : "robot_") + std::to_string(round + 1) + ".log";
    sleep_s(std::max(0.0, kLifetime - since(born, steady_now_ns())));
    killed_files.push_back(shm_files_of(pid));
    ASSERT_FALSE(killed_files.back().empty()) << "it mapped no shared memory of its own: the cleanup is not tested";
    const int64_t t_kill = steady_now_ns();
    ASSERT_EQ(kill(pid, SIGKILL), 0);
    EXPECT_EQ(test::wait_child(pid, 10), -1) << "killed";
    EXPECT_FALSE(still_there(killed_files.back()).empty())
        << "a killed process's files stay until they are found stale";
    sleep_s(kOutage);
    const int64_t last_frame = frames.last_before(t_kill + 50'000'000);
    const int64_t t_spawn = steady_now_ns();
    std::vector<std::string> extra;
    if (vision) extra = {"--set", "truth.path=" + (dir_ / ("frames_" + std::to_string(round + 1) + ".jsonl")).string()};
    pid = start(args(victim, extra), log);
    born = t_spawn;
    ASSERT_GT(pid, 0);
    if (vision) frames = Tail(dir_ / ("frames_" + std::to_string(round + 1) + ".jsonl"));
    // Resumed: the vision side renders from the robot's joints again, and the
    // robot side has matched the (new) vision process's gaze requests.
    int64_t t_frame = -1;
    test::wait_for([&] { return (t_frame = frames.first_after(t_spawn)) > 0; }, 30);
    const int64_t t_joined = when_logged(vision ? "robot_0.log" : log, gaze_joined(), vision ? round + 2 : 1, 30);
    if (t_frame <= 0) {  // stopped, each process logs what its nodes took in and sent (--stats)
      for (pid_t p : {head, robot, motors}) kill(p, SIGTERM);
      for (pid_t p : {head, robot, motors}) test::wait_child(p, 10);
    }
    const std::string survivor = vision ? "robot_0.log" : "head_0.log";
    ASSERT_GT(t_frame, 0) << "no frame after the restart\n"
                          << log << ":\n"
                          << log_of(log) << "\n"
                          << survivor << ":\n"
                          << log_of(survivor) << "\nmotors.log:\n"
                          << log_of("motors.log");
    ASSERT_GT(t_joined, 0) << "the robot side never matched the vision side's requests";
    const double resumed = since(t_spawn, std::max(t_frame, t_joined));
    // Held: the joints stay where they were while the other side is gone
    // (after 0.3 s for a set-point in flight), until the loop runs again.
    const double drift = shafts.drift_deg(t_kill + 300'000'000, t_frame);
    const int steps = shafts.count_between(t_kill, t_spawn);
    std::printf(
        "[ fault ] %s killed, round %d: restarted after %.1f s; frames again %.3f s and requests matched %.3f s "
        "after the restart; no frames for %.3f s (~%d frames lost); the joints moved %.3f deg meanwhile; the "
        "drives stepped %d times while it was down\n",
        victim.c_str(), round, kOutage, since(t_spawn, t_frame), since(t_spawn, t_joined), since(last_frame, t_frame),
        static_cast<int>(since(last_frame, t_frame) * 25), drift, steps);
    std::fflush(stdout);
    EXPECT_LT(resumed, kResume) << "round " << round;
    EXPECT_LT(drift, 0.5) << "the head holds while the " << victim << " is down";
    EXPECT_GT(steps, static_cast<int>(kOutage * 200)) << "the drives ran on";
    EXPECT_TRUE(alive(motors));
    EXPECT_TRUE(alive(vision ? robot : head)) << "the other side kept running";
    // What the process killed the round before left is gone: its restart (this
    // round's) removed it, its owner dead and its peer's lease over.
    if (round > 0) {
      // (Less what a live process maps: a killed reader mapped its peers' files too.)
      std::set<std::string> dead = killed_files[static_cast<std::size_t>(round - 1)];
      for (pid_t p : {head, robot, motors})
        for (const auto& f : shm_files_of(p)) dead.erase(f);
      EXPECT_EQ(still_there(dead), std::vector<std::string>{})
          << "left by the " << victim << " killed in round " << round - 1;
    }
    resume.add(resumed);
    lost.add(since(last_frame, t_frame));
    over_floor += resumed >= kFloor;
  }
  std::printf("[ fault ] %s killed: %d of %d rounds resumed within the %.0f s floor\n", victim.c_str(), n - over_floor,
              n, kFloor);
  // Once everything has stopped (cleanly), the next process to start removes
  // what the killed ones left (files of a dead owner, 5 s old at least).
  std::set<std::string> live = shm_files_of(head), robot_files = shm_files_of(robot);
  live.insert(robot_files.begin(), robot_files.end());
  for (pid_t pid : {head, robot, motors}) {
    kill(pid, SIGTERM);
    EXPECT_EQ(test::wait_child(pid, 30), 128 + SIGTERM);
  }
  const pid_t next =
      start(args("head_pc", {"--duration", "1", "--set", "truth.path=" + (dir_ / "last.jsonl").string()}), "last.log");
  EXPECT_EQ(test::wait_child(next, 60), 0) << log_of("last.log");
  EXPECT_EQ(still_there(live), std::vector<std::string>{}) << "left by the processes stopped cleanly";
  for (std::size_t r = 0; r < killed_files.size(); ++r)
    EXPECT_EQ(still_there(killed_files[r]), std::vector<std::string>{})
        << "left by the " << victim << " killed in round " << r;
  resume.print();
  lost.print();
}

// The two processes in two network namespaces joined by a veth pair, each with
// its own /dev/shm (two hosts: their DDS edges go over UDP), the link cut for
// 5 s and restored, round after round.
TEST_F(FaultsTwoPc, TheDdsLinkCutForFiveSeconds) {
  const std::string head_ns = "saccade_" + id_ + "_fh", robot_ns = "saccade_" + id_ + "_fr";
  const std::string veth_head = "sf" + id_ + "h", veth_robot = "sf" + id_ + "r";
  const std::string setup = test::two_hosts_command(head_ns, robot_ns, veth_head, veth_robot, "10.78.0");
  const bool made = std::system((setup + " > " + (dir_ / "setup.log").string() + " 2>&1").c_str()) == 0;
  struct Cleanup {
    std::string cmd;
    ~Cleanup() { (void)std::system(cmd.c_str()); }
  } cleanup{"ip netns del " + head_ns + " 2>/dev/null; ip netns del " + robot_ns + " 2>/dev/null"};
  if (!made)
    GTEST_SKIP() << "cannot make network namespaces and a veth pair here (ip netns and veth need root or "
                    "CAP_NET_ADMIN; iproute2 and util-linux's unshare): "
                 << log_of("setup.log");
  graph_ = write_graph(false, "head", "robot");
  // saccade inside a namespace, with a /dev/shm of its own.
  auto in_ns = [&](const std::string& ns, const std::vector<std::string>& argv) {
    std::string inner = "mount -t tmpfs tmpfs /dev/shm && exec";
    for (const auto& a : argv) inner += " '" + a + "'";
    return std::vector<std::string>{"ip", "netns", "exec", ns, "unshare", "-m", "sh", "-c", inner};
  };
  const pid_t robot = start(in_ns(robot_ns, args("robot_pc")), "robot_0.log");
  const pid_t head = start(in_ns(head_ns, args("head_pc")), "head_0.log");
  ASSERT_GT(robot, 0);
  ASSERT_GT(head, 0);
  Tail frames(dir_ / "frames_0.jsonl"), shafts(dir_ / "shafts.jsonl");
  ASSERT_TRUE(test::wait_for([&] { return frames.first_after(0) > 0; }, 60)) << "the loop never ran\nrobot:\n"
                                                                             << log_of("robot_0.log") << "\nhead:\n"
                                                                             << log_of("head_0.log");
  ASSERT_GE(when_logged("robot_0.log", gaze_joined(), 1, 30), 0) << log_of("robot_0.log");

  constexpr double kCut = 5.0;
  faults::Figures resume{"DDS link cut 5 s: the loop resumed after the link came back in", "s"};
  for (int round = 0; round < faults::rounds(1); ++round) {
    sleep_s(2.0);  // the loop runs
    const int64_t t_cut = steady_now_ns();
    ASSERT_EQ(std::system(("ip -n " + head_ns + " link set " + veth_head + " down").c_str()), 0);
    sleep_s(kCut);
    const int64_t t_up = steady_now_ns();
    ASSERT_EQ(std::system(("ip -n " + head_ns + " link set " + veth_head + " up").c_str()), 0);
    int64_t t_frame = -1;
    test::wait_for([&] { return (t_frame = frames.first_after(t_up)) > 0; }, 30);
    const int64_t t_joined = when_logged("robot_0.log", gaze_joined(), round + 2, 30);
    ASSERT_GT(t_frame, 0) << "no frame after the link came back\n" << log_of("head_0.log");
    ASSERT_GT(t_joined, 0) << "the robot side never matched the vision side again\n" << log_of("robot_0.log");
    const int64_t last_frame = frames.last_before(t_cut + 100'000'000);
    const int during = frames.count_between(t_cut + 200'000'000, t_up);
    const double drift = shafts.drift_deg(t_cut + 300'000'000, t_frame);
    const int steps = shafts.count_between(t_cut, t_up);
    const double resumed = since(t_up, std::max(t_frame, t_joined));
    std::printf(
        "[ fault ] DDS link cut %.0f s, round %d: frames again %.3f s and requests matched %.3f s after it came "
        "back; no frames for %.3f s (~%d frames lost), the joints moved %.3f deg meanwhile; the robot side "
        "cycled %d times while cut\n",
        kCut, round, since(t_up, t_frame), since(t_up, t_joined), since(last_frame, t_frame),
        static_cast<int>(since(last_frame, t_frame) * 25), drift, steps);
    std::fflush(stdout);
    EXPECT_EQ(during, 0) << "no joint state crosses a cut link";
    EXPECT_LT(drift, 0.5) << "the head holds while cut off";
    EXPECT_GT(steps, static_cast<int>(kCut * 200)) << "the robot side ran on";
    EXPECT_LT(resumed, 3.0) << "the participants' lease is 3 s, their announcements 1 s apart";
    EXPECT_TRUE(alive(robot));
    EXPECT_TRUE(alive(head));
    resume.add(resumed);
  }
  for (pid_t pid : {head, robot}) {
    kill(pid, SIGTERM);
    EXPECT_EQ(test::wait_child(pid, 30), 128 + SIGTERM);
  }
  resume.print();
}

TEST_F(FaultsTwoPc, TheVisionProcessKilledAndRestarted) { kill_and_restart(true); }

TEST_F(FaultsTwoPc, TheRobotProcessKilledAndRestarted) { kill_and_restart(false); }

}  // namespace
}  // namespace saccade
