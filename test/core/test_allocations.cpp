// Steady state allocates nothing: the number of heap allocations a graph makes
// does not grow with the number of frames it runs. Its own executable, because
// it replaces the global operator new to count.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <new>
#include <utility>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "box_tracker.hpp"
#include "classifier_fixtures.hpp"
#include "frame_samples.hpp"
#include "recognition.hpp"

#include "saccade/graph.hpp"
#include "saccade/testing.hpp"
#include "support.hpp"

// OpenCV's own thread pool allocates per parallel job, as many as the timing
// of its workers makes: a loaded machine counted 3 more in one run than in the
// other. The graph's allocations are what is measured, so OpenCV runs inline.
static const bool kOpenCvSingleThread = (cv::setNumThreads(1), true);

// The replacement pair below is matched (malloc/free); GCC's check cannot see
// that through the replacement.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

namespace {
std::atomic<uint64_t> g_allocations{0};
}

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace saccade {
namespace {

// Allocations of a whole run of the graph for `frames` frames (set-up included).
uint64_t allocations_for(int frames, bool deterministic) {
  const std::string xml = "<graph><node name=\"cam\" plugin=\"capture.synthetic\"><param name=\"count\" value=\"" +
                          std::to_string(frames) +
                          "\"/></node>"
                          "<node name=\"retina\" plugin=\"retina\"/><node name=\"filters\" plugin=\"filters.bank\">"
                          "<param name=\"features\" value=\"all\"/></node><node name=\"sink\" plugin=\"util.null\"/>"
                          "<edge from=\"cam.image\" to=\"retina.image\" queue=\"block:2\"/>"
                          "<edge from=\"retina.retina\" to=\"filters.retina\" queue=\"block:2\"/>"
                          "<edge from=\"filters.maps\" to=\"sink.in\" queue=\"block:2\"/></graph>";
  ExecutorOptions o;
  o.deterministic = deterministic;
  o.threads = 1;
  auto run = test::open_graph(xml, o);
  uint64_t before = g_allocations.load();
  EXPECT_TRUE(run->run().ok());
  return g_allocations.load() - before;
}

// The heap allocations of `frames` calls of `step`, after `warm_up` calls
// that size every buffer.
uint64_t allocations_of(int warm_up, int frames, const std::function<void()>& step) {
  for (int i = 0; i < warm_up; ++i) step();
  const uint64_t before = g_allocations.load();
  for (int i = 0; i < frames; ++i) step();
  return g_allocations.load() - before;
}

TEST(SteadyState, RunningMoreFramesAllocatesNothingMore) {
  // Warm the registry and the plugins' one-time set-up first.
  allocations_for(5, true);
  uint64_t short_run = allocations_for(20, true);
  uint64_t long_run = allocations_for(220, true);
  EXPECT_EQ(long_run, short_run) << "200 more frames made " << (long_run - short_run) << " more heap allocations";
}

TEST(SteadyState, HarnessedRetinaAndFiltersReuseEverything) {
  auto retina = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  auto filters =
      testing::NodeHarness::create(R"(<node plugin="filters.bank"><param name="features" value="all"/></node>)")
          .value_or(nullptr);
  ASSERT_TRUE(retina && filters);
  auto image = std::make_shared<Image>();
  image->mat.create(480, 640, CV_8UC1);
  cv::randu(image->mat, 0, 256);
  retina->set("image", image);
  auto step = [&] {
    retina->clear_outputs();
    filters->clear_outputs();
    ASSERT_TRUE(retina->process().ok());
    filters->set("retina", retina->outputs("retina").back());
    ASSERT_TRUE(filters->process().ok());
    filters->set("retina", nullptr);
  };
  EXPECT_EQ(allocations_of(3, 100, step), 0u);
}

TEST(SteadyState, HarnessedMotionAndStereoReuseEverything) {
  auto retina = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  auto motion = testing::NodeHarness::create(R"(<node plugin="motion"/>)").value_or(nullptr);
  // (With the opt-in checks of the fovea's matches too: they reuse their buffers.)
  auto stereo = testing::NodeHarness::create(R"(<node plugin="stereo"><param name="max_disparity" value="64"/>
                                                  <param name="occlusion_check" value="true"/>
                                                  <param name="fovea_recheck" value="8"/></node>)")
                    .value_or(nullptr);
  ASSERT_TRUE(retina && motion && stereo);
  auto left = std::make_shared<Image>(), right = std::make_shared<Image>();
  left->mat = test::random_image({640, 480}, 3);
  right->mat = test::random_image({640, 480}, 4);
  auto step = [&] {
    retina->clear_outputs();
    motion->clear_outputs();
    stereo->clear_outputs();
    retina->set("image", left);
    ASSERT_TRUE(retina->process().ok());
    retina->set("image", right);
    ASSERT_TRUE(retina->process().ok());
    motion->set("retina", retina->outputs("retina")[0]);
    ASSERT_TRUE(motion->process().ok());
    stereo->set("left", retina->outputs("retina")[0]);
    stereo->set("right", retina->outputs("retina")[1]);
    ASSERT_TRUE(stereo->process().ok());
    motion->set("retina", nullptr);
    stereo->set("left", nullptr);
    stereo->set("right", nullptr);
  };
  EXPECT_EQ(allocations_of(3, 20, step), 0u);
}

// A smooth 640x480 colour background and a sharper 60x50 textured target
// for the box tracker to follow.
std::pair<cv::Mat, cv::Mat> textured_scene() {
  std::pair<cv::Mat, cv::Mat> scene;
  cv::GaussianBlur(test::random_image({640, 480}, 11, CV_8UC3), scene.first, {0, 0}, 3);
  cv::GaussianBlur(test::random_image({60, 50}, 12, CV_8UC3), scene.second, {0, 0}, 1);
  return scene;
}

// The fovea's box tracker on a 640x480 scene (colour, or a monochrome
// camera's): a textured target followed, hidden (lost: the whole-frame search
// runs, by look and, in colour, by colour), found again, twice over. The
// first round sizes every buffer; the second allocates nothing, on any of its
// tracked, unsure or lost frames. Returns the second round's allocations.
uint64_t box_tracker_second_round_allocations(bool monochrome) {
  auto [background, target] = textured_scene();
  target.forEach<cv::Vec3b>([](cv::Vec3b& p, const int*) { p[2] = cv::saturate_cast<uint8_t>(p[2] + 90); });
  if (monochrome) {
    cv::cvtColor(background, background, cv::COLOR_BGR2GRAY);
    cv::cvtColor(target, target, cv::COLOR_BGR2GRAY);
  }
  // Visible for 60 frames, hidden for 60, and again; drifting and turning
  // back, so that it comes back elsewhere than it was lost.
  const auto visible = [](int k) { return k % 120 < 60; };
  const auto place = [](int k) {
    return cv::Point(200 + static_cast<int>(120 * std::sin(k / 40.0)), 180 + static_cast<int>(60 * std::sin(k / 70.0)));
  };
  cv::Mat frame;
  const auto draw = [&](int k) {
    background.copyTo(frame);
    if (visible(k)) target.copyTo(frame(cv::Rect(place(k), target.size())));
  };
  fovea::BoxTracker tracker;
  draw(0);
  EXPECT_TRUE(tracker.init(frame, cv::Rect2d(place(0), target.size())).ok());
  uint64_t second_round = 0;
  for (int k = 1; k < 480; ++k) {
    draw(k);
    const uint64_t before = g_allocations.load();
    const fovea::TrackEstimate estimate = tracker.update(frame);
    if (k >= 240) second_round += g_allocations.load() - before;
    // (Each phase did what it says, or the count would measure less than it claims.)
    if (k % 60 == 59) {
      EXPECT_EQ(estimate.state, visible(k) ? fovea::TrackState::kTracking : fovea::TrackState::kLost) << "frame " << k;
    }
  }
  return second_round;
}

TEST(SteadyState, TheBoxTrackerAllocatesNothingWhileTrackingLosingAndFindingItsTarget) {
  EXPECT_EQ(box_tracker_second_round_allocations(false), 0u) << "in colour";
  // (A monochrome frame's looks take the one pass too: OpenCV's warpAffine
  // allocates on every call. Without AVX2 that is the look, and allocates.)
  if (fovea::warp_to_gray_in_one_pass()) { EXPECT_EQ(box_tracker_second_round_allocations(true), 0u) << "monochrome"; }
}

// The same through the graph's nodes: the retina and the fovea node following
// the box, its state, fovea and gaze requests out every frame, the retina's
// fovea moved to where the fovea node puts it.
TEST(SteadyState, HarnessedFoveaFollowingABoxReusesEverything) {
  const auto [background, target] = textured_scene();
  const auto place = [](int k) {
    return cv::Point(200 + static_cast<int>(80 * std::sin(k / 30.0)), 180 + static_cast<int>(40 * std::sin(k / 45.0)));
  };
  auto retina = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  auto fovea = testing::NodeHarness::create(R"(<node plugin="fovea"><param name="init" value="200,180,60,50"/></node>)")
                   .value_or(nullptr);
  ASSERT_TRUE(retina && fovea);
  auto image = std::make_shared<Image>();
  int k = 0;
  auto step = [&] {
    background.copyTo(image->mat);
    target.copyTo(image->mat(cv::Rect(place(k), target.size())));
    ++k;
    retina->clear_outputs();
    fovea->clear_outputs();
    retina->set("image", image);
    ASSERT_TRUE(retina->process().ok());
    fovea->set("retina", retina->outputs("retina").back());
    ASSERT_TRUE(fovea->process().ok());
    fovea->set("retina", nullptr);
    // The fovea moves with the target, as graphs/tracking.xml's edge back to the retina moves it.
    retina->set("fovea", fovea->outputs("fovea").back());
  };
  EXPECT_EQ(allocations_of(20, 100, step), 0u);
  auto state = fovea->last<FoveaState>("state");
  ASSERT_TRUE(state);
  EXPECT_EQ(state->state, FoveaState::State::kTracking);
}

// The classifier on the fovea of every frame (the stripes of either class in
// turn, so its outcome and the target it offers change): its features, its
// network's scores, its messages.
TEST(SteadyState, HarnessedClassifierReusesEverything) {
  using classifier::test_fixtures::stripes;
  auto node = testing::NodeHarness::create("<node plugin=\"classifier\"><param name=\"model\" value=\"" +
                                           classifier::test_fixtures::stripes_model() + "\"/></node>")
                  .value_or(nullptr);
  ASSERT_TRUE(node);
  retina::RetinaSampler sampler({});
  std::array<std::shared_ptr<Retina>, 2> retinas{std::make_shared<Retina>(), std::make_shared<Retina>()};
  cv::Mat frame;
  for (int c = 0; c < 2; ++c) classifier::retina_of_view(stripes(c == 0, 7 + c), sampler, *retinas[c], frame);
  int k = 0;
  auto step = [&] {
    node->clear_outputs();
    node->set("retina", retinas[static_cast<std::size_t>(k++ % 2)]);
    ASSERT_TRUE(node->process().ok());
    node->set("retina", nullptr);
  };
  EXPECT_EQ(allocations_of(10, 100, step), 0u);
  auto result = node->last<Classification>("result");
  ASSERT_TRUE(result);
  EXPECT_EQ(result->outcome, Classification::Outcome::kClassified);
}

// The recorders on every frame: a JSON line per fovea state (util.jsonl) and
// an MCAP message per fovea state and per 640x480 image (mcap.record, its
// chunks of 1 MiB compressed as by default: one every three images), the
// messages' fields changing each frame. What the file's summary keeps of each
// chunk grows with the file, by doubling: 8 allocations over 400 frames (the
// test allows 16), where one a chunk would be over 130 (before 2026-11-30: 204).
TEST(SteadyState, HarnessedRecordersReuseEverything) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "saccade_allocations_recorders";
  std::filesystem::create_directories(dir);
  const auto node = [&](const std::string& plugin, const std::string& file) {
    return testing::NodeHarness::create("<node plugin=\"" + plugin + "\"><param name=\"path\" value=\"" +
                                        (dir / file).string() + "\"/></node>")
        .value_or(nullptr);
  };
  auto jsonl = node("util.jsonl", "states.jsonl"), states = node("mcap.record", "run.mcap");
  auto images = node("mcap.record", "run.mcap");
  ASSERT_TRUE(jsonl && states && images);
  auto state = std::make_shared<FoveaState>();
  auto image = std::make_shared<Image>();
  image->mat = test::random_image({640, 480}, 5);
  int k = 0;
  auto step = [&] {
    state->frame_id = image->frame_id = k;
    state->timestamp_ns = image->timestamp_ns = 1'000'000'000 + 33'000'000LL * k;
    state->target = {100.0 + k % 50, 80.5, 32, 24};
    state->confidence = 0.01 * (k % 100);
    image->mat.at<uint8_t>(k % 480, k % 640) = static_cast<uint8_t>(k);
    ++k;
    for (auto* h : {jsonl.get(), states.get()}) {
      h->set("in", state);
      ASSERT_TRUE(h->process().ok());
    }
    images->set("in", image);
    ASSERT_TRUE(images->process().ok());
  };
  EXPECT_LE(allocations_of(20, 400, step), 16u);
  for (auto* h : {jsonl.get(), states.get(), images.get()}) EXPECT_EQ(h->counter("write_errors"), 0u);
  jsonl.reset(), states.reset(), images.reset();
  std::filesystem::remove_all(dir);
}

// The kinematics node on a head's joint state every frame: the cameras' poses
// and the fixation point, as the rectified retina and the stereo ask for them;
// the cameras verging (a fixation) and diverging (none, and why) in turn.
TEST(SteadyState, HarnessedKinematicsReusesEverything) {
  auto kinematics = testing::NodeHarness::create(R"(<node plugin="kinematics"/>)").value_or(nullptr);
  ASSERT_TRUE(kinematics);
  auto state = std::make_shared<JointState>();
  state->position.assign(5, 0.0);
  int k = 0, fixated = 0;
  auto step = [&] {
    const double t = k++ / 25.0, vergence = 0.1 * std::sin(3 * t);
    state->position = {0.3 * std::sin(t), vergence, 0.1 * std::cos(t), -vergence, 0.1 * std::cos(t)};
    kinematics->clear_outputs();
    kinematics->set("state", state);
    ASSERT_TRUE(kinematics->process().ok());
    fixated += kinematics->last<HeadPose>("pose")->fixation_valid;
  };
  EXPECT_EQ(allocations_of(3, 100, step), 0u);
  EXPECT_GT(fixated, 10);
  EXPECT_LT(fixated, 93);
}

// The whole active vision loop, graphs/head_loop.xml in simulated time: the
// simulated head's cameras, the retina, the moving fovea, the gaze controller,
// the CANopen master, the virtual bus and the simulated drives, for `seconds`
// (its snapshots not written: encoding a picture to a file allocates).
uint64_t head_loop_allocations(int seconds) {
  Diagnostics diag;
  GraphDecl decl = load_graph_file(SACCADE_SOURCE_DIR "/graphs/head_loop.xml", diag);
  const std::string s = std::to_string(seconds);
  apply_overrides(
      decl, {"driver.realtime=false", "drives.realtime=false", "driver.duration=" + s, "drives.duration=" + s}, diag);
  for (auto& n : decl.nodes)
    if (n.name == "snapshot") n.plugin = "util.null", n.params.clear();
  auto graph = resolve_graph(decl, testing::default_registry(), diag);
  EXPECT_FALSE(diag.has_errors()) << diag.format();
  if (!graph) return 0;
  ExecutorOptions options;
  options.deterministic = true;
  const uint64_t before = g_allocations.load();
  Executor executor(*graph, testing::default_registry(), options);
  EXPECT_TRUE(executor.open().ok());
  EXPECT_TRUE(executor.run().ok());
  return g_allocations.load() - before;
}

TEST(SteadyState, TheActiveVisionLoopAllocatesOnlyInItsSimulatedCameras) {
  head_loop_allocations(2);  // the registry's and the plugins' one-time set-up
  const uint64_t shorter = head_loop_allocations(8), longer = head_loop_allocations(12);
  // What the 4 s more (1000 control cycles, 100 frames of each camera) may
  // make: the simulated cameras' OpenCV calls allocate inside, twice in each
  // render's cv::remap and once in the target's cv::resize (600), and the
  // target's buffers grow a few times as it comes nearer. Nothing else: an
  // allocation on every control cycle would add 1000, one on every frame 100.
  EXPECT_LE(longer - shorter, 650u) << "4 s more of the loop made " << (longer - shorter) << " more heap allocations";
}

}  // namespace
}  // namespace saccade
