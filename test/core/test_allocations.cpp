// Steady state allocates nothing: the number of heap allocations a graph makes
// does not grow with the number of frames it runs. Its own executable, because
// it replaces the global operator new to count.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include <opencv2/core.hpp>

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
  for (int i = 0; i < 3; ++i) step();
  uint64_t before = g_allocations.load();
  for (int i = 0; i < 100; ++i) step();
  EXPECT_EQ(g_allocations.load() - before, 0u);
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
  for (int i = 0; i < 3; ++i) step();
  uint64_t before = g_allocations.load();
  for (int i = 0; i < 20; ++i) step();
  EXPECT_EQ(g_allocations.load() - before, 0u);
}

}  // namespace
}  // namespace saccade
