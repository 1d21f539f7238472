// The executor: queue policies with their drop counts, sync groups, feedback
// edges, end of stream, determinism, thread counts, fan-out without copies,
// failures.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>

#include "support.hpp"

namespace saccade {
namespace {

using test::open_graph;
using test::recorded;

class Executor : public ::testing::Test {
 protected:
  void SetUp() override { testing::Recorder::instance().clear(); }
};

ExecutorOptions threads(int n) {
  ExecutorOptions o;
  o.threads = n;
  return o;
}

std::string counter(const std::string& name, int count, const std::string& extra = "") {
  return "<node name=\"" + name + "\" plugin=\"util.counter\"><param name=\"count\" value=\"" + std::to_string(count) +
         "\"/>" + extra + "</node>";
}

std::string slow_sink(const std::string& name, int busy_us) {
  return "<node name=\"" + name + "\" plugin=\"util.record\"><param name=\"busy_us\" value=\"" +
         std::to_string(busy_us) + "\"/></node>";
}

TEST_F(Executor, LatestKeepsTheNewestAndCountsEveryDrop) {
  auto g = open_graph("<graph>" + counter("src", 200) + slow_sink("sink", 300) +
                          "<edge from=\"src.image\" to=\"sink.in\" queue=\"latest\"/></graph>",
                      threads(2));
  ASSERT_TRUE(g->run().ok());
  const auto& s = g->stats("sink");
  uint64_t dropped = s.inputs[0]->dropped.load();
  EXPECT_GT(dropped, 0u);
  EXPECT_EQ(s.processed.load() + dropped, 200u);
  EXPECT_EQ(s.inputs[0]->received.load(), 200u);
  auto got = recorded<Image>("sink");
  EXPECT_EQ(got.back()->frame_id, 199) << "the newest frame is never dropped";
  for (std::size_t i = 1; i < got.size(); ++i) EXPECT_GT(got[i]->frame_id, got[i - 1]->frame_id);
}

TEST_F(Executor, FifoIsBoundedAndCountsDrops) {
  auto g = open_graph("<graph>" + counter("src", 200) + slow_sink("sink", 300) +
                          "<edge from=\"src.image\" to=\"sink.in\" queue=\"fifo:4\"/></graph>",
                      threads(2));
  ASSERT_TRUE(g->run().ok());
  const auto& s = g->stats("sink");
  EXPECT_GT(s.inputs[0]->dropped.load(), 0u);
  EXPECT_EQ(s.processed.load() + s.inputs[0]->dropped.load(), 200u);
  auto got = recorded<Image>("sink");
  for (std::size_t i = 1; i < got.size(); ++i) EXPECT_GT(got[i]->frame_id, got[i - 1]->frame_id);
}

TEST_F(Executor, BlockLosesNothingAndKeepsOrder) {
  auto g = open_graph("<graph>" + counter("src", 200) + slow_sink("sink", 100) +
                          "<edge from=\"src.image\" to=\"sink.in\" queue=\"block:2\"/></graph>",
                      threads(2));
  ASSERT_TRUE(g->run().ok());
  EXPECT_EQ(g->stats("sink").inputs[0]->dropped.load(), 0u);
  auto got = recorded<Image>("sink");
  ASSERT_EQ(got.size(), 200u);
  for (int i = 0; i < 200; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)]->frame_id, i);
}

TEST_F(Executor, SyncGroupPairsExactTimestampsAndCountsTheUnpaired) {
  // b leaves out every third frame; only frames both have may pair.
  auto g = open_graph("<graph>" + counter("a", 60) + counter("b", 60, "<param name=\"skip_every\" value=\"3\"/>") +
                          "<node name=\"p\" plugin=\"util.pair\"><sync inputs=\"a,b\"/></node>"
                          "<node name=\"sink\" plugin=\"util.record\"/>"
                          "<edge from=\"a.image\" to=\"p.a\" queue=\"block:4\"/>"
                          "<edge from=\"b.image\" to=\"p.b\" queue=\"block:4\"/>"
                          "<edge from=\"p.pair\" to=\"sink.in\" queue=\"block:4\"/></graph>",
                      threads(2));
  ASSERT_TRUE(g->run().ok());
  auto pairs = recorded<Region>("sink");
  ASSERT_EQ(pairs.size(), 40u);
  for (const auto& p : pairs) {
    EXPECT_EQ(p->center.x, p->center.y);
    EXPECT_NE(static_cast<int>(p->center.x) % 3, 2);
  }
  EXPECT_EQ(g->stats("p").inputs[0]->sync_dropped.load(), 20u);
}

TEST_F(Executor, SyncGroupWithinATolerance) {
  auto g = open_graph("<graph>" + counter("a", 30) + counter("b", 30, "<param name=\"offset_ms\" value=\"3\"/>") +
                          "<node name=\"p\" plugin=\"util.pair\"><sync inputs=\"a,b\" tolerance_ms=\"4\"/></node>"
                          "<node name=\"sink\" plugin=\"util.record\"/>"
                          "<edge from=\"a.image\" to=\"p.a\" queue=\"block:4\"/>"
                          "<edge from=\"b.image\" to=\"p.b\" queue=\"block:4\"/>"
                          "<edge from=\"p.pair\" to=\"sink.in\" queue=\"block:4\"/></graph>",
                      threads(3));
  ASSERT_TRUE(g->run().ok());
  auto pairs = recorded<Region>("sink");
  ASSERT_EQ(pairs.size(), 30u);
  for (const auto& p : pairs) EXPECT_EQ(p->center.x, p->center.y);
}

const std::string kFeedback =
    "<graph>" + counter("src", 50) +
    "<node name=\"l\" plugin=\"util.latch\"/><node name=\"p\" plugin=\"util.passthrough\"/>"
    "<node name=\"sink\" plugin=\"util.record\"/>"
    "<edge from=\"src.image\" to=\"l.in\" queue=\"block:2\"/><edge from=\"l.out\" to=\"p.in\" queue=\"block:2\"/>"
    "<edge from=\"p.out\" to=\"l.side\" delay=\"1\"/><edge from=\"l.out\" to=\"sink.in\" queue=\"block:2\"/></graph>";

TEST_F(Executor, DelayedFeedbackSeesExactlyThePreviousFrameInDeterministicMode) {
  ExecutorOptions o;
  o.deterministic = true;
  auto g = open_graph(kFeedback, o);
  ASSERT_TRUE(g->run().ok());
  auto out = recorded<Region>("sink");
  ASSERT_EQ(out.size(), 50u);
  EXPECT_EQ(out[0]->center.y, -1.0);
  for (std::size_t t = 1; t < out.size(); ++t) EXPECT_EQ(out[t]->center.y, out[t]->center.x - 1) << t;
}

TEST_F(Executor, DelayedFeedbackNeverSeesTheFutureWithThreads) {
  auto g = open_graph(kFeedback, threads(2));
  ASSERT_TRUE(g->run().ok());
  auto out = recorded<Region>("sink");
  ASSERT_EQ(out.size(), 50u);
  for (const auto& r : out) EXPECT_LT(r->center.y, r->center.x);
}

// A node that sleeps in its call (a control loop pacing itself) acts on what
// its side inputs received while it slept, not on what they held when the
// call began: "go" fires at once, "side" sends frames 0, 1, 2 50 ms apart, and
// the latch sleeps 400 ms before it reads its side input.
TEST_F(Executor, ANodeThatSleepsSeesWhatItsSideInputsReceivedMeanwhile) {
  auto g = open_graph("<graph>" + counter("go", 1) + counter("side", 3, "<param name=\"rate_hz\" value=\"20\"/>") +
                          "<node name=\"l\" plugin=\"util.latch\"><param name=\"sleep_ms\" value=\"400\"/></node>"
                          "<node name=\"sink\" plugin=\"util.record\"/>"
                          "<edge from=\"go.image\" to=\"l.in\"/><edge from=\"side.image\" to=\"l.side\"/>"
                          "<edge from=\"l.out\" to=\"sink.in\"/></graph>",
                      threads(2));
  ASSERT_TRUE(g->run().ok());
  auto out = recorded<Region>("sink");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0]->center.y, 2.0) << "the side input's newest frame after the sleep";
}

TEST_F(Executor, EndOfStreamEndsAFileDrivenGraphByItself) {
  auto g = open_graph("<graph>" + counter("src", 5) +
                      "<node name=\"p\" plugin=\"util.passthrough\"/><node name=\"n\" plugin=\"util.null\"/>"
                      "<edge from=\"src.image\" to=\"p.in\" queue=\"block:1\"/><edge from=\"p.out\" to=\"n.in\" "
                      "queue=\"block:1\"/></graph>");
  ASSERT_TRUE(g->run().ok());
  EXPECT_EQ(g->stats("n").processed.load(), 5u);
}

TEST_F(Executor, ZeroCopyFanOutDeliversTheSamePointer) {
  auto g = open_graph(
      "<graph>" + counter("src", 20) +
          "<node name=\"p\" plugin=\"util.passthrough\"/>"
          "<node name=\"a\" plugin=\"util.record\"/><node name=\"b\" plugin=\"util.record\"/>"
          "<node name=\"c\" plugin=\"util.record\"/>"
          "<edge from=\"src.image\" to=\"p.in\" queue=\"block:2\"/>"
          "<edge from=\"p.out\" to=\"a.in\" queue=\"block:20\"/><edge from=\"p.out\" to=\"b.in\" queue=\"block:20\"/>"
          "<edge from=\"p.out\" to=\"c.in\" queue=\"block:20\"/></graph>",
      threads(3));
  ASSERT_TRUE(g->run().ok());
  auto a = recorded<Image>("a"), b = recorded<Image>("b"), c = recorded<Image>("c");
  ASSERT_EQ(a.size(), 20u);
  ASSERT_EQ(b.size(), 20u);
  ASSERT_EQ(c.size(), 20u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].get(), b[i].get());
    EXPECT_EQ(a[i].get(), c[i].get());
    EXPECT_EQ(a[i]->mat.data, c[i]->mat.data);
  }
}

TEST(MessagePool, RecyclesOnlyWhatNobodyHolds) {
  MessagePool pool;
  auto a = pool.acquire<Image>();
  a->mat.create(48, 64, CV_8UC1);
  const Image* first = a.get();
  const uchar* pixels = a->mat.data;
  a.reset();
  auto b = pool.acquire<Image>();
  EXPECT_EQ(b.get(), first);
  EXPECT_EQ(b->mat.data, pixels) << "an unshared buffer is kept for reuse";
  auto c = pool.acquire<Image>();
  EXPECT_NE(c.get(), first) << "a held message is never handed out twice";
  EXPECT_EQ(pool.allocations(), 2u);
}

TEST(MessagePool, DropsBuffersSharedWithSomeoneElse) {
  MessagePool pool;
  cv::Mat kept;
  {
    auto a = pool.acquire<Image>();
    a->mat.create(8, 8, CV_8UC1);
    a->mat.setTo(7);
    kept = a->mat;  // a downstream node kept a header on the pixels
  }
  auto b = pool.acquire<Image>();
  EXPECT_TRUE(b->mat.empty());
  b->mat.create(8, 8, CV_8UC1);
  b->mat.setTo(9);
  EXPECT_EQ(kept.at<uchar>(0, 0), 7) << "recycling must not write into pixels someone still reads";
}

TEST_F(Executor, ResultsDoNotDependOnTheThreadCount) {
  const std::string xml =
      "<graph>" + counter("a", 40) + counter("b", 40) +
      "<node name=\"pa\" plugin=\"util.passthrough\" inline=\"true\"/>"
      "<node name=\"pb\" plugin=\"util.passthrough\"/>"
      "<node name=\"p\" plugin=\"util.pair\"><sync inputs=\"a,b\"/></node>"
      "<node name=\"sink\" plugin=\"util.record\"/>"
      "<edge from=\"a.image\" to=\"pa.in\" queue=\"block:2\"/><edge from=\"b.image\" to=\"pb.in\" queue=\"block:2\"/>"
      "<edge from=\"pa.out\" to=\"p.a\" queue=\"block:2\"/><edge from=\"pb.out\" to=\"p.b\" queue=\"block:2\"/>"
      "<edge from=\"p.pair\" to=\"sink.in\" queue=\"block:2\"/></graph>";
  for (int n : {1, 2, 3, 4, 8}) {
    testing::Recorder::instance().clear();
    auto g = open_graph(xml, threads(n));
    ASSERT_TRUE(g->run().ok()) << n;
    auto pairs = recorded<Region>("sink");
    ASSERT_EQ(pairs.size(), 40u) << n << " threads";
    for (std::size_t i = 0; i < pairs.size(); ++i) EXPECT_EQ(pairs[i]->center, cv::Point2d(i, i)) << n;
  }
}

TEST_F(Executor, DeterministicModeIsBitIdenticalRunToRun) {
  const std::string xml =
      "<graph><node name=\"cam\" plugin=\"capture.synthetic\"><param name=\"count\" value=\"30\"/></node>"
      "<node name=\"retina\" plugin=\"retina\"/><node name=\"filters\" plugin=\"filters.bank\">"
      "<param name=\"features\" value=\"all\"/></node>"
      "<node name=\"sink\" plugin=\"util.record\"/>"
      "<edge from=\"cam.image\" to=\"retina.image\"/><edge from=\"retina.retina\" to=\"filters.retina\"/>"
      "<edge from=\"filters.maps\" to=\"sink.in\"/></graph>";
  std::vector<std::vector<std::shared_ptr<const FeatureMaps>>> runs;
  for (int r = 0; r < 2; ++r) {
    testing::Recorder::instance().clear();
    ExecutorOptions o;
    o.deterministic = true;
    auto g = open_graph(xml, o);
    ASSERT_TRUE(g->run().ok());
    runs.push_back(recorded<FeatureMaps>("sink"));
  }
  ASSERT_EQ(runs[0].size(), 30u);
  ASSERT_EQ(runs[1].size(), 30u);
  for (std::size_t f = 0; f < 30; ++f) {
    ASSERT_FALSE(runs[0][f]->maps.empty()) << "frame " << f;
    ASSERT_EQ(runs[0][f]->maps.size(), runs[1][f]->maps.size()) << "frame " << f;
  }
  for (std::size_t f = 0; f < 30; ++f)
    for (std::size_t i = 0; i < runs[0][f]->maps.size(); ++i)
      for (std::size_t l = 0; l < runs[0][f]->maps[i].size(); ++l) {
        const cv::Mat& a = runs[0][f]->maps[i][l];
        const cv::Mat& b = runs[1][f]->maps[i][l];
        ASSERT_EQ(a.total() * a.elemSize(), b.total() * b.elemSize());
        EXPECT_EQ(std::memcmp(a.data, b.data, a.total() * a.elemSize()), 0) << "frame " << f << " map " << i;
      }
}

TEST_F(Executor, NodeErrorStopsTheGraphAndNamesTheNode) {
  auto g = open_graph("<graph>" + counter("src", 100) +
                          "<node name=\"bad\" plugin=\"util.fail\"><param name=\"fail_at\" value=\"5\"/></node>"
                          "<node name=\"n\" plugin=\"util.null\"/>"
                          "<edge from=\"src.image\" to=\"bad.in\" queue=\"block:1\"/><edge from=\"bad.out\" "
                          "to=\"n.in\" queue=\"block:1\"/></graph>",
                      threads(2));
  Status s = g->run();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("node 'bad' (util.fail, line 1): injected failure at call 5"));
  // Stopped there: 'bad' passes on only what came before the failing call
  // (calls 0-4), and the source is not run to its end.
  EXPECT_LE(g->stats("n").processed.load(), 5u);
  EXPECT_LT(g->stats("src").emitted.load(), 50u);
}

TEST_F(Executor, ThrownExceptionsAreCaughtInsideThePlugin) {
  auto g = open_graph(
      "<graph>" + counter("src", 10) +
      "<node name=\"bad\" plugin=\"util.fail\"><param name=\"throw\" value=\"true\"/></node>"
      "<node name=\"n\" plugin=\"util.null\"/>"
      "<edge from=\"src.image\" to=\"bad.in\" queue=\"block:1\"/><edge from=\"bad.out\" to=\"n.in\"/></graph>");
  Status s = g->run();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("process threw: injected exception at call 3"));
}

TEST_F(Executor, OnErrorSkipDropsTheFrameAndCountsIt) {
  auto g = open_graph("<graph>" + counter("src", 100) +
                      "<node name=\"bad\" plugin=\"util.fail\" on_error=\"skip\"><param name=\"fail_at\" value=\"0\"/>"
                      "<param name=\"fail_every\" value=\"10\"/></node><node name=\"n\" plugin=\"util.null\"/>"
                      "<edge from=\"src.image\" to=\"bad.in\" queue=\"block:1\"/><edge from=\"bad.out\" to=\"n.in\" "
                      "queue=\"block:1\"/></graph>");
  ASSERT_TRUE(g->run().ok());
  EXPECT_EQ(g->stats("bad").errors.load(), 10u);
  EXPECT_EQ(g->stats("n").processed.load(), 90u);
}

TEST_F(Executor, OpenFailureNamesTheNode) {
  auto graph = test::resolve_xml(
      "<graph><node name=\"cam\" plugin=\"capture.video\"><param name=\"path\" value=\"/nonexistent/x.avi\"/></node>"
      "<node name=\"n\" plugin=\"util.null\"/><edge from=\"cam.image\" to=\"n.in\"/></graph>");
  saccade::Executor e(graph, testing::default_registry());
  Status s = e.open();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(),
              ::testing::HasSubstr(
                  "node 'cam' (capture.video, line 1) failed to open: /nonexistent/x.avi: no such video file"));
}

TEST_F(Executor, FrameLimitAndDurationStopEndlessSources) {
  {
    ExecutorOptions o;
    o.max_frames = 7;
    auto g = open_graph("<graph>" + counter("src", 0) +
                            "<node name=\"n\" plugin=\"util.null\"/>"
                            "<edge from=\"src.image\" to=\"n.in\" queue=\"block:1\"/></graph>",
                        o);
    ASSERT_TRUE(g->run().ok());
    EXPECT_EQ(g->stats("n").processed.load(), 7u);
  }
  {
    ExecutorOptions o;
    o.duration_s = 0.3;
    auto g = open_graph("<graph>" + counter("src", 0, "<param name=\"rate_hz\" value=\"100\"/>") +
                            "<node name=\"n\" plugin=\"util.null\"/><edge from=\"src.image\" to=\"n.in\"/></graph>",
                        o);
    ASSERT_TRUE(g->run().ok());
    EXPECT_GT(g->stats("n").processed.load(), 5u);
    EXPECT_LT(g->executor->elapsed_s(), 5.0);
  }
}

TEST_F(Executor, ExternalStopEndsCleanly) {
  std::atomic<bool> stop{false};
  ExecutorOptions o;
  o.external_stop = &stop;
  auto g = open_graph("<graph>" + counter("src", 0, "<param name=\"rate_hz\" value=\"200\"/>") +
                          "<node name=\"n\" plugin=\"util.null\"/><edge from=\"src.image\" to=\"n.in\"/></graph>",
                      o);
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    stop = true;
  });
  ASSERT_TRUE(g->run().ok());
  stopper.join();
  EXPECT_GT(g->stats("n").processed.load(), 0u);
}

TEST_F(Executor, InlineNodesRunOnTheProducersThread) {
  std::string chain = counter("src", 100);
  std::string edges = "<edge from=\"src.image\" to=\"p0.in\" queue=\"block:1\"/>";
  for (int i = 0; i < 10; ++i) {
    chain += "<node name=\"p" + std::to_string(i) + "\" plugin=\"util.passthrough\" inline=\"true\"/>";
    if (i > 0) edges += "<edge from=\"p" + std::to_string(i - 1) + ".out\" to=\"p" + std::to_string(i) + ".in\"/>";
  }
  chain += "<node name=\"sink\" plugin=\"util.record\" inline=\"true\"/>";
  edges += "<edge from=\"p9.out\" to=\"sink.in\"/>";
  auto g = open_graph("<graph>" + chain + edges + "</graph>", threads(1));
  ASSERT_TRUE(g->run().ok());
  auto got = recorded<Image>("sink");
  ASSERT_EQ(got.size(), 100u) << "inline hand-offs never drop: each consumer runs before the next frame";
  EXPECT_EQ(g->stats("p9").inputs[0]->dropped.load(), 0u);
}

TEST_F(Executor, InlineConsumersTimeIsNotChargedToTheProducer) {
  auto g = open_graph(
      "<graph>" + counter("src", 20) +
          "<node name=\"p\" plugin=\"util.passthrough\" inline=\"true\"><param name=\"busy_us\" value=\"3000\"/></node>"
          "<node name=\"sink\" plugin=\"util.null\" inline=\"true\"/>"
          "<edge from=\"src.image\" to=\"p.in\" queue=\"block:1\"/><edge from=\"p.out\" to=\"sink.in\"/></graph>",
      threads(1));
  ASSERT_TRUE(g->run().ok());
  EXPECT_EQ(g->stats("sink").processed.load(), 20u);
  const int64_t consumer = g->stats("p").process_time.percentile(0.5);
  EXPECT_GE(consumer, 3'000'000);
  // Relative, so that a slow host does not decide it: charged to the
  // producer, its median would be at least the consumer's.
  EXPECT_LT(g->stats("src").process_time.percentile(0.5), consumer / 2) << "the inline consumer's time is its own";
}

TEST_F(Executor, PacingSleepIsNotProcessingTime) {
  auto g = open_graph("<graph>" + counter("src", 10, "<param name=\"rate_hz\" value=\"100\"/>") +
                      "<node name=\"n\" plugin=\"util.null\"/><edge from=\"src.image\" to=\"n.in\"/></graph>");
  ASSERT_TRUE(g->run().ok());
  // Frames 10 ms apart: the run takes at least 9 gaps, of which the
  // source's processing time holds none (relative, so that a slow host does
  // not decide it).
  const double elapsed_ns = g->executor->elapsed_s() * 1e9;
  EXPECT_GT(elapsed_ns, 0.08e9);
  EXPECT_LT(g->stats("src").process_time.percentile(0.5), elapsed_ns / 9 / 4) << "the wait is not work";
}

TEST_F(Executor, StatsCountProcessingAndLatency) {
  auto g = open_graph("<graph>" + counter("src", 50) + slow_sink("sink", 200) +
                      "<edge from=\"src.image\" to=\"sink.in\" queue=\"block:1\"/></graph>");
  ASSERT_TRUE(g->run().ok());
  const auto& s = g->stats("sink");
  EXPECT_EQ(s.processed.load(), 50u);
  EXPECT_GE(s.process_time.percentile(0.5), 200'000);
  EXPECT_GE(s.latency.percentile(0.5), s.process_time.percentile(0.5) / 2);
  EXPECT_GT(s.rate_hz(), 0.0);
  std::string json = g->executor->stats_json();
  EXPECT_THAT(json, ::testing::HasSubstr("\"name\": \"sink\""));
}

}  // namespace
}  // namespace saccade

namespace saccade {
namespace {

TEST_F(Executor, ATapSeesEveryMessageOfAnOutputConnectedOrNot) {
  auto g = open_graph("<graph>" + counter("src", 50) + slow_sink("sink", 0) +
                          "<edge from=\"src.image\" to=\"sink.in\" queue=\"block:4\"/></graph>",
                      threads(2));
  std::vector<int64_t> seen;  // taps run on the emitting thread: one source, one thread
  ASSERT_TRUE(g->executor->add_tap("src", "image", [&](const MessagePtr& m) { seen.push_back(m->frame_id); }).ok());
  EXPECT_THAT(g->executor->add_tap("src", "nothing", [](const MessagePtr&) {}).message(),
              ::testing::HasSubstr("no output 'nothing'"));
  EXPECT_THAT(g->executor->add_tap("nobody", "image", [](const MessagePtr&) {}).message(),
              ::testing::HasSubstr("no node 'nobody'"));
  ASSERT_TRUE(g->run().ok());
  ASSERT_EQ(seen.size(), 50u);
  for (std::size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], static_cast<int64_t>(i));
  EXPECT_EQ(recorded<Image>("sink").size(), 50u) << "the consumers still get everything";
}

TEST_F(Executor, AnInjectedValueReachesASideInputAndOnlyASideInput) {
  // The retina's fovea input is a side input nobody feeds here.
  auto g = open_graph("<graph>" + counter("src", 3, "<param name=\"size\" value=\"320x240\"/>") +
                          "<node name=\"retina\" plugin=\"retina\"/>" + slow_sink("sink", 0) +
                          "<edge from=\"src.image\" to=\"retina.image\" queue=\"block:4\"/>"
                          "<edge from=\"retina.retina\" to=\"sink.in\" queue=\"block:4\"/></graph>",
                      ExecutorOptions{});
  auto fovea = std::make_shared<Region>();
  fovea->center = {20, 15};
  ASSERT_TRUE(g->executor->inject("retina", "fovea", fovea).ok());
  EXPECT_THAT(g->executor->inject("retina", "image", std::make_shared<Image>()).message(),
              ::testing::HasSubstr("not a side input"));
  EXPECT_THAT(g->executor->inject("retina", "fovea", std::make_shared<Image>()).message(),
              ::testing::HasSubstr("takes Region"));
  EXPECT_THAT(g->executor->inject("retina", "nothing", fovea).message(), ::testing::HasSubstr("no input 'nothing'"));
  ASSERT_TRUE(g->run().ok());
  const auto retinas = recorded<Retina>("sink");
  ASSERT_EQ(retinas.size(), 3u);
  const cv::Rect inner = retinas.back()->geometry.back().region;
  EXPECT_EQ(inner.tl(), cv::Point(4, 3)) << "the fovea centred on the injected point";
}

}  // namespace
}  // namespace saccade
