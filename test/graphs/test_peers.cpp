// Peers that die: a publisher killed with SIGKILL and started again is
// rejoined while the reading graph keeps running and reports the gap; a
// process stopped by SIGTERM leaves no shared memory behind; what a SIGKILL
// leaves is found stale and removed.
#include <gtest/gtest.h>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <chrono>
#include <fstream>
#include <regex>
#include <set>
#include <thread>

#include <spdlog/sinks/ringbuffer_sink.h>

#include "saccade/log.hpp"
#include "shared_memory.hpp"
#include "support.hpp"

namespace saccade {
namespace {

using test::private_domain;

// The node `xml` describes, opened; nullptr, and a test failure saying why,
// when it cannot be.
std::unique_ptr<testing::NodeHarness> open_node(const std::string& xml) {
  Result<std::unique_ptr<testing::NodeHarness>> node = testing::NodeHarness::create(xml);
  EXPECT_TRUE(node.ok()) << node.error();
  return std::move(node).value_or(nullptr);
}

pid_t start_peer(const std::string& topic, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> args = {"--log-level", "warn",
                                   "run",         SACCADE_SOURCE_DIR "/test/graphs/peer_counter.xml",
                                   "--set",       "publish.topic=" + topic,
                                   "--set",       "publish.domain=" + std::to_string(private_domain())};
  args.insert(args.end(), extra.begin(), extra.end());
  return test::spawn_saccade(args);
}

// This process's graph: a subscriber of `topic` whose images util.record keeps under "rx".
std::unique_ptr<test::GraphRun> open_recording_reader(const std::string& topic, bool zero_copy) {
  return test::open_graph(R"(<graph name="reader">
  <node name="sub" plugin="dds.subscribe">
    <param name="topic" value=")" +
                          topic + R"("/><param name="type" value="Image"/>
    <param name="domain" value=")" +
                          std::to_string(private_domain()) + R"("/>
    <param name="zero_copy" value=")" +
                          (zero_copy ? "true" : "false") + R"("/>
  </node>
  <node name="rx" plugin="util.record"/>
  <edge from="sub.out" to="rx.in" queue="block:16"/>
</graph>)");
}

uint64_t node_counter(const test::GraphRun& run, const std::string& node, const std::string& name) {
  for (const auto& c : run.stats(node).counters)
    if (c->name == name) return c->value.load();
  ADD_FAILURE() << node << " has no counter " << name;
  return 0;
}

void rejoin_a_writer_killed_and_started_again(bool zero_copy) {
  const std::string topic = "test_peers/" + std::to_string(getpid()) + "/images" + (zero_copy ? "_ring" : "");
  auto ring = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256);
  saccade::log().sinks().push_back(ring);
  testing::Recorder::instance().clear();
  auto run = open_recording_reader(topic, zero_copy);
  Status status;
  std::thread reader([&] { status = run->run(); });
  auto received = [] { return testing::Recorder::instance().get("rx").size(); };

  const std::string zero_copy_set = std::string("publish.zero_copy=") + (zero_copy ? "true" : "false");
  pid_t first = start_peer(topic, {"--set", "camera.camera_id=1", "--set", zero_copy_set});
  ASSERT_GT(first, 0);
  EXPECT_TRUE(test::wait_for([&] { return received() >= 20; }, 60)) << "the first writer's frames";
  kill(first, SIGKILL);
  EXPECT_EQ(test::wait_child(first, 10), -1) << "killed";
  const std::size_t before_restart = received();
  // The reader notices within the participants' lease (3 s) and says so.
  auto reported = [&](const std::string& what) {
    int n = 0;
    for (const std::string& line : ring->last_formatted())
      if (line.find("the writer of " + topic + " " + what) != std::string::npos) ++n;
    return n;
  };
  EXPECT_TRUE(test::wait_for([&] { return reported("left; waiting for it to come back") == 1; }, 20));

  pid_t second = start_peer(topic, {"--set", "camera.camera_id=2", "--set", zero_copy_set});
  ASSERT_GT(second, 0);
  EXPECT_TRUE(test::wait_for([&] { return received() >= before_restart + 20; }, 60)) << "the second writer's frames";
  kill(second, SIGTERM);  // a clean stop (exit 128 + the signal): its end of stream ends the reader's graph too
  EXPECT_EQ(test::wait_child(second, 30), 128 + SIGTERM);
  reader.join();
  saccade::log().sinks().pop_back();
  ASSERT_TRUE(status.ok()) << status.message();

  // Frames of the first writer, then of the second (the camera id tells
  // them apart), each intact: every pixel holds its frame number.
  auto images = test::recorded<Image>("rx");
  ASSERT_GE(images.size(), 40u);
  std::size_t switches = 0, from_second = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const Image& im = *images[i];
    double lo = 0, hi = 0;
    cv::minMaxLoc(im.mat, &lo, &hi);
    EXPECT_EQ(lo, static_cast<double>(im.frame_id % 256));
    EXPECT_EQ(hi, lo);
    EXPECT_TRUE(im.camera_id == 1 || im.camera_id == 2);
    if (i > 0 && im.camera_id != images[i - 1]->camera_id) ++switches;
    if (im.camera_id == 2) ++from_second;
  }
  EXPECT_EQ(images.front()->camera_id, 1);
  EXPECT_EQ(switches, 1u);
  EXPECT_GE(from_second, 20u);
  EXPECT_EQ(reported("joined"), 2);
  // Through the frame ring, the killed writer's ring (never closed) is left
  // for the new one's, whose frames then come from its mailbox too.
  if (zero_copy) { EXPECT_GE(node_counter(*run, "sub", "mailbox_frames"), 30u); }
}

TEST(DdsPeers, AWriterKilledAndStartedAgainIsRejoinedWhileTheReaderKeepsRunning) {
  rejoin_a_writer_killed_and_started_again(false);
}

TEST(DdsPeers, AFrameRingWriterKilledAndStartedAgainIsRejoinedWhileTheReaderKeepsRunning) {
  rejoin_a_writer_killed_and_started_again(true);
}

// The address ranges of this process's mappings of saccade frame rings.
std::vector<std::pair<uintptr_t, uintptr_t>> frame_ring_mappings() {
  std::vector<std::pair<uintptr_t, uintptr_t>> out;
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line)) {
    if (line.find("/dev/shm/saccade_ring_") == std::string::npos) continue;
    out.emplace_back(std::stoull(line.substr(0, line.find('-')), nullptr, 16),
                     std::stoull(line.substr(line.find('-') + 1), nullptr, 16));
  }
  return out;
}

TEST(DdsPeers, FramesThroughTheFrameRingArriveIntactAndAreReadInPlace) {
  const std::string topic = "test_peers/" + std::to_string(getpid()) + "/ring";
  testing::Recorder::instance().clear();
  auto run = open_recording_reader(topic, true);
  Status status;
  std::thread reader([&] { status = run->run(); });
  auto received = [] { return testing::Recorder::instance().get("rx").size(); };
  const std::string stats = "/tmp/saccade_test_ring_" + std::to_string(getpid()) + ".json";
  pid_t writer =
      start_peer(topic, {"--set", "publish.zero_copy=true", "--set", "camera.size=640x480", "--stats-json", stats});
  ASSERT_GT(writer, 0);
  EXPECT_TRUE(test::wait_for([&] { return received() >= 40; }, 60));
  const auto rings = frame_ring_mappings();
  kill(writer, SIGTERM);  // a clean stop: the command exits 128 + the signal
  EXPECT_EQ(test::wait_child(writer, 30), 128 + SIGTERM);
  reader.join();
  ASSERT_TRUE(status.ok()) << status.message();

  // The counter made its images in the edge's frame ring: the writer copied none.
  EXPECT_GE(test::stats_counter(stats, "publish", "written"), 40);
  EXPECT_EQ(test::stats_counter(stats, "publish", "copied_frames"), 0);
  std::remove(stats.c_str());

  // The recorder keeps every frame: the first ones stay pinned in the
  // writer's ring (read in place), the rest are copied out so the writer
  // never runs out of buffers. Every frame is whole: each pixel is its number.
  auto images = test::recorded<Image>("rx");
  ASSERT_GE(images.size(), 40u);
  ASSERT_FALSE(rings.empty()) << "the reader mapped the writer's ring";
  std::size_t in_place = 0;
  for (const auto& im : images) {
    ASSERT_EQ(im->mat.size(), cv::Size(640, 480));
    double lo = 0, hi = 0;
    cv::minMaxLoc(im->mat, &lo, &hi);
    EXPECT_EQ(lo, static_cast<double>(im->frame_id % 256));
    EXPECT_EQ(hi, lo);
    const auto at = reinterpret_cast<uintptr_t>(im->mat.data);
    for (const auto& [begin, end] : rings) in_place += at >= begin && at < end ? 1 : 0;
  }
  EXPECT_EQ(in_place, 4u) << "a reader pins a quarter of the writer's 16 buffers";
  // After the first frame (which names the ring, through DDS) the writer's
  // mailbox woke the reader; DDS' copies of those frames were dropped: each
  // frame arrived once, in order.
  for (std::size_t i = 1; i < images.size(); ++i) EXPECT_GT(images[i]->frame_id, images[i - 1]->frame_id) << i;
  EXPECT_GE(node_counter(*run, "sub", "mailbox_frames"), images.size() / 2);
}

// This process's view of /dev/shm files process `pid` maps, DDS' own only
// (participant segments and data-sharing pools; port files are shared by design).
std::set<std::string> dds_files_mapped_by(pid_t pid) {
  static const std::regex own("fastrtps_[0-9a-f]{16}|fast_datasharing_.*|saccade_ring_.*|saccade_mail_.*");
  std::set<std::string> out;
  std::ifstream maps("/proc/" + std::to_string(pid) + "/maps");
  std::string line;
  while (std::getline(maps, line)) {
    auto at = line.find("/dev/shm/");
    if (at == std::string::npos) continue;
    std::string name = line.substr(at + 9);
    if (std::regex_match(name, own)) out.insert(name);
  }
  return out;
}

bool exists_in_shm(const std::string& name) { return access(("/dev/shm/" + name).c_str(), F_OK) == 0; }

// A lone publisher with a zero-copy edge: its participant segment, the
// data-sharing pool of its samples and the frame ring of its pixels.
std::set<std::string> start_lone_peer(pid_t& pid) {
  pid = start_peer("test_peers/" + std::to_string(getpid()) + "/lone",
                   {"--set", "publish.zero_copy=true", "--set", "publish.capacity=65536"});
  std::set<std::string> files;
  test::wait_for(
      [&] {
        files = dds_files_mapped_by(pid);
        auto has = [&](const char* prefix) {
          return std::any_of(files.begin(), files.end(), [&](auto& f) { return f.rfind(prefix, 0) == 0; });
        };
        return has("fastrtps_") && has("fast_datasharing_") && has("saccade_ring_");
      },
      30);
  return files;
}

TEST(DdsSharedMemory, ACleanStopBySigtermLeavesNothingBehind) {
  pid_t pid = -1;
  std::set<std::string> files = start_lone_peer(pid);
  ASSERT_GE(files.size(), 3u) << "a participant segment, a data-sharing pool and a frame ring";
  kill(pid, SIGTERM);
  ASSERT_EQ(test::wait_child(pid, 30), 128 + SIGTERM) << "a clean stop: 128 + the signal";
  for (const auto& f : files) EXPECT_FALSE(exists_in_shm(f)) << f;
}

TEST(DdsSharedMemory, WhatAKilledProcessLeftIsRemovedAsStale) {
  pid_t pid = -1;
  std::set<std::string> files = start_lone_peer(pid);
  ASSERT_GE(files.size(), 2u);
  kill(pid, SIGKILL);
  test::wait_child(pid, 10);
  for (const auto& f : files) EXPECT_TRUE(exists_in_shm(f)) << f << ": a SIGKILL leaves it";

  // A live participant's files are never stale, however old.
  pid_t live = -1;
  std::set<std::string> live_files = start_lone_peer(live);
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  dds::StaleSharedMemory stale = dds::remove_stale_shared_memory(1.0);
  for (const auto& f : files) {
    EXPECT_FALSE(exists_in_shm(f)) << f;
    EXPECT_NE(std::find(stale.removed.begin(), stale.removed.end(), f), stale.removed.end()) << f;
  }
  for (const auto& f : live_files) EXPECT_TRUE(exists_in_shm(f)) << f << " belongs to a live process";
  EXPECT_GT(stale.bytes, 0u);
  kill(live, SIGTERM);
  EXPECT_EQ(test::wait_child(live, 30), 128 + SIGTERM);
}

// Steady clocks are per host: a reader on another host (same_clock=false, as
// the partitioner sets it) counts latency from arrival, not from an origin on
// a clock it does not share.
TEST(DdsPeers, AReaderOnAnotherClockCountsLatencyFromArrival) {
  for (bool same_clock : {true, false}) {
    const std::string topic = "test_peers/" + std::to_string(getpid()) + "/clock" + (same_clock ? "1" : "0");
    auto sub = open_node("<node plugin=\"dds.subscribe\"><param name=\"topic\" value=\"" + topic +
                         "\"/><param name=\"type\" value=\"Image\"/><param name=\"reliable\" value=\"true\"/>"
                         "<param name=\"same_clock\" value=\"" +
                         (same_clock ? "true" : "false") + "\"/></node>");
    ASSERT_NE(sub, nullptr);
    auto pub = open_node("<node plugin=\"dds.publish\"><param name=\"topic\" value=\"" + topic +
                         "\"/><param name=\"type\" value=\"Image\"/><param name=\"reliable\" value=\"true\"/>"
                         "<param name=\"wait_ms\" value=\"20000\"/></node>");
    ASSERT_NE(pub, nullptr);
    auto image = std::make_shared<Image>();
    image->mat = cv::Mat(4, 4, CV_8UC1, cv::Scalar(7));
    image->origin_ns = 12345;  // another host's steady clock
    pub->set("in", image);
    const int64_t before = steady_now_ns();
    ASSERT_TRUE(pub->process().ok());
    ASSERT_TRUE(sub->process().ok());
    auto got = sub->last<Image>("out");
    ASSERT_NE(got, nullptr);
    if (same_clock) {
      EXPECT_EQ(got->origin_ns, 12345);
    } else {
      EXPECT_GE(got->origin_ns, before);
    }
  }
}

// What goes wrong between peers is said in the log, naming the topic: a
// writer that never comes, a reader that never comes, QoS the two ends
// cannot agree on, a writer silent past its deadline.
TEST(DdsPeers, AMissingPeerAnIncompatibleQosAndAMissedDeadlineAreReported) {
  const std::string base = "test_peers/" + std::to_string(getpid()) + "/";
  auto ring = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(256);
  saccade::log().sinks().push_back(ring);
  auto logged = [&](const std::string& text) {
    for (const std::string& line : ring->last_formatted())
      if (line.find(text) != std::string::npos) return true;
    return false;
  };
  auto lonely = open_node("<node plugin=\"dds.publish\"><param name=\"topic\" value=\"" + base +
                          "nobody\"/><param name=\"wait_ms\" value=\"100\"/></node>");
  ASSERT_NE(lonely, nullptr);
  auto best_effort =
      open_node("<node plugin=\"dds.publish\"><param name=\"topic\" value=\"" + base + "mismatch\"/></node>");
  ASSERT_NE(best_effort, nullptr);
  auto sub = [&](const std::string& name, const std::string& params) {
    return "<node name=\"" + name + "\" plugin=\"dds.subscribe\"><param name=\"topic\" value=\"" + base + name +
           "\"/>" + params + "</node><node name=\"" + name + "_sink\" plugin=\"util.null\"/><edge from=\"" + name +
           ".out\" to=\"" + name + "_sink.in\"/>";
  };
  ExecutorOptions options;
  options.duration_s = 1.5;
  auto run = test::open_graph(
      "<graph name=\"peers\">" + sub("absent", "<param name=\"missing_peer_ms\" value=\"200\"/>") +
          sub("mismatch", "<param name=\"reliable\" value=\"true\"/>") +
          sub("deadline", "<param name=\"reliable\" value=\"true\"/><param name=\"deadline_ms\" value=\"50\"/>") +
          "</graph>",
      options);
  std::thread writer([&] {
    // Waits for the deadline's reader, writes once, then stays silent. The
    // writer offers the deadline too (a writer offering none is incompatible).
    auto once = testing::NodeHarness::create(
                    "<node plugin=\"dds.publish\"><param name=\"topic\" value=\"" + base +
                    "deadline\"/><param name=\"reliable\" value=\"true\"/><param name=\"deadline_ms\" value=\"50\"/>"
                    "<param name=\"wait_ms\" value=\"20000\"/></node>")
                    .value_or(nullptr);
    if (once == nullptr) return;
    auto image = std::make_shared<Image>();
    image->mat = cv::Mat(2, 2, CV_8UC1, cv::Scalar(1));
    once->set("in", image);
    (void)once->process();
  });
  ASSERT_TRUE(run->run().ok());
  writer.join();
  saccade::log().sinks().pop_back();

  EXPECT_TRUE(logged("no reader of " + base + "nobody after 100 ms"));
  EXPECT_TRUE(logged("no writer of " + base + "absent has joined yet"));
  EXPECT_TRUE(logged("this end reads saccade_idl::Image, which both ends' zero_copy"))
      << "the type a writer must match";
  EXPECT_TRUE(
      logged("the writer of " + base + "mismatch offers an incompatible QoS (reliability); nothing will arrive"));
  EXPECT_TRUE(logged("a reader of " + base + "mismatch asks for an incompatible QoS (reliability)"));
  EXPECT_TRUE(logged("nothing on " + base + "deadline within its deadline"));
  EXPECT_FALSE(logged("no writer of " + base + "deadline has joined yet"));
}

}  // namespace
}  // namespace saccade
