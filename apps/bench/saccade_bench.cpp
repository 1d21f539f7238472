// saccade's performance figures, side by side with their peers in one run:
//   retina vs OpenCV resize(INTER_AREA); the fused filter bank vs the same
//   OpenCV calls on the levels and on the full frame; framework overhead per
//   edge (inline, across threads) vs GStreamer's identity element; the
//   capture(memory) -> retina -> filters pipeline; a message's CDR bytes
//   (what a DDS edge, an MCAP log and the live view carry) written and read.
// Single thread unless a benchmark says otherwise. Figures go to docs/performance.md.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench_util.hpp"
#include "box_tracker.hpp"
#include "frame_samples.hpp"
#include "kernels.hpp"
#include "real_fft.hpp"
#include "retina.hpp"
#include "saccade/cdr.hpp"
#include "saccade/executor.hpp"
#include "saccade/graph.hpp"
#include "saccade/registry.hpp"

namespace {

using namespace saccade;
using bench::PerCall;
using bench::size_arg;

cv::Mat frame_of(cv::Size size) {
  static cv::Mat aloe = [] {
    cv::Mat m = cv::imread(std::string(SACCADE_SAMPLE_DATA) + "/aloeL.jpg", cv::IMREAD_GRAYSCALE);
    if (m.empty()) {
      std::fprintf(stderr, "saccade_bench: %s/aloeL.jpg is missing: install opencv-doc\n", SACCADE_SAMPLE_DATA);
      std::exit(2);
    }
    return m;
  }();
  cv::Mat out;
  cv::resize(aloe, out, size, 0, 0, cv::INTER_AREA);
  return out;
}

// ---- CDR: a message's bytes, written from and read back into the message ----

Retina retina_message() {
  retina::RetinaSampler sampler(retina::RetinaConfig{});
  Retina retina;
  sampler.sample(frame_of({640, 480}), {320, 240}, retina);
  return retina;
}

// Into a buffer that has room, as a DDS edge serialises into its payload.
template <class M>
void cdr_write(benchmark::State& state, const M& message) {
  std::vector<uint8_t> bytes(cdr::size_of(message));
  for (auto _ : state) {
    if (cdr::write(message, cdr::Envelope{}, bytes.data(), bytes.size()) == 0) state.SkipWithError("no room");
    benchmark::DoNotOptimize(bytes.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes.size()));
}

template <class M>
void cdr_read(benchmark::State& state, const M& message) {
  std::vector<uint8_t> bytes;
  cdr::write(message, cdr::Envelope{}, bytes);
  M out;
  cdr::Envelope envelope;
  for (auto _ : state)
    if (Status s = cdr::read(bytes.data(), bytes.size(), out, envelope); !s.ok())
      state.SkipWithError(s.message().c_str());
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes.size()));
}

void BM_Cdr_Write_Retina(benchmark::State& state) { cdr_write(state, retina_message()); }
void BM_Cdr_Read_Retina(benchmark::State& state) { cdr_read(state, retina_message()); }
void BM_Cdr_Write_Image640x480(benchmark::State& state) {
  Image image;
  image.mat = frame_of({640, 480});
  cdr_write(state, image);
}
void BM_Cdr_Read_Image640x480(benchmark::State& state) {
  Image image;
  image.mat = frame_of({640, 480});
  cdr_read(state, image);
}
void BM_Cdr_Write_FoveaState(benchmark::State& state) {
  FoveaState fovea;
  fovea.state = FoveaState::State::kTracking;
  cdr_write(state, fovea);
}
void BM_Cdr_Read_FoveaState(benchmark::State& state) {
  FoveaState fovea;
  fovea.state = FoveaState::State::kTracking;
  cdr_read(state, fovea);
}
BENCHMARK(BM_Cdr_Write_Retina);
BENCHMARK(BM_Cdr_Read_Retina);
BENCHMARK(BM_Cdr_Write_Image640x480);
BENCHMARK(BM_Cdr_Read_Image640x480);
BENCHMARK(BM_Cdr_Write_FoveaState);
BENCHMARK(BM_Cdr_Read_FoveaState);

// ---- retina ----

void BM_Retina_FivePoint(benchmark::State& state) {
  cv::Mat frame = frame_of(size_arg(state));
  retina::RetinaSampler sampler({});
  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> geometry;
  cv::Point2d fovea(frame.cols * 0.45, frame.rows * 0.55);
  sampler.sample(frame, fovea, levels, geometry);
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    sampler.sample(frame, fovea, levels, geometry);
    benchmark::DoNotOptimize(levels[0].data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK(BM_Retina_FivePoint)->Args({1024, 768})->Args({640, 480});

// The fovea moves every frame, so the offset tables are rebuilt each time.
void BM_Retina_FivePointMovingFovea(benchmark::State& state) {
  cv::Mat frame = frame_of(size_arg(state));
  retina::RetinaSampler sampler({});
  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> geometry;
  int k = 0;
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    cv::Point2d fovea(200 + (k % 50), 200 + (k % 37));
    ++k;
    sampler.sample(frame, fovea, levels, geometry);
    benchmark::DoNotOptimize(levels[0].data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK(BM_Retina_FivePointMovingFovea)->Args({1024, 768})->Args({640, 480});

void BM_Retina_OpenCvResizeArea(benchmark::State& state) {
  cv::Mat frame = frame_of(size_arg(state));
  retina::RetinaConfig config;
  auto geometry = retina::retina_geometry(config, frame.size(), {frame.cols * 0.45, frame.rows * 0.55});
  std::vector<cv::Mat> levels(geometry.size());
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    for (std::size_t k = 0; k < geometry.size(); ++k)
      cv::resize(frame(geometry[k].region), levels[k], config.size, 0, 0, cv::INTER_AREA);
    benchmark::DoNotOptimize(levels[0].data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK(BM_Retina_OpenCvResizeArea)->Args({1024, 768})->Args({640, 480});

// ---- filter bank ----

std::vector<cv::Mat> retina_levels() {
  cv::Mat frame = frame_of({1024, 768});
  retina::RetinaSampler sampler({});
  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> geometry;
  sampler.sample(frame, {460, 420}, levels, geometry);
  return levels;
}

filters::BankConfig bank_config(bool all) {
  filters::BankConfig c;
  if (all) {
    c.wanted.fill(true);
  } else {
    for (int f : {filters::kGauss, filters::kSobelX, filters::kSobelY, filters::kGradMag, filters::kLaplacian})
      c.wanted[static_cast<std::size_t>(f)] = true;
  }
  return c;
}

// all = false: Gaussian 3x3, Sobel x/y, gradient magnitude, Laplacian (the set
// OpenCV is run on); all = true: the twelve maps, LoG and Gaussian gradient included.
void BM_Filters_Fused_5x32x24(benchmark::State& state, bool all) {
  auto levels = retina_levels();
  filters::FilterBank bank(bank_config(all));
  std::array<cv::Mat, filters::kFeatureCount> out;
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    for (const auto& level : levels) bank.run(level, out);
    benchmark::DoNotOptimize(out[0].data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK_CAPTURE(BM_Filters_Fused_5x32x24, CoreSet, false);
BENCHMARK_CAPTURE(BM_Filters_Fused_5x32x24, All, true);

void opencv_core_set(const cv::Mat& in, cv::Mat& g, cv::Mat& sx, cv::Mat& sy, cv::Mat& mag, cv::Mat& lap) {
  cv::GaussianBlur(in, g, {3, 3}, 0, 0, cv::BORDER_REFLECT_101);
  cv::Sobel(in, sx, CV_32F, 1, 0, 3);
  cv::Sobel(in, sy, CV_32F, 0, 1, 3);
  cv::magnitude(sx, sy, mag);
  cv::Laplacian(in, lap, CV_32F, 1);
}

void BM_Filters_OpenCvCoreSet_5x32x24(benchmark::State& state) {
  auto levels = retina_levels();
  cv::Mat g, sx, sy, mag, lap;
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    for (const auto& level : levels) opencv_core_set(level, g, sx, sy, mag, lap);
    benchmark::DoNotOptimize(lap.data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK(BM_Filters_OpenCvCoreSet_5x32x24);

void BM_Filters_OpenCvCoreSet_FullFrame(benchmark::State& state) {
  cv::Mat frame = frame_of(size_arg(state));
  cv::Mat g, sx, sy, mag, lap;
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    opencv_core_set(frame, g, sx, sy, mag, lap);
    benchmark::DoNotOptimize(lap.data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK(BM_Filters_OpenCvCoreSet_FullFrame)->Args({1024, 768})->Unit(benchmark::kMicrosecond);

// All twelve maps with OpenCV calls (the same definitions as the fused bank).
struct OpenCvAll {
  cv::Mat g, sx, sy, mag, mask, dir, lap, log, gx, gy, gmag, gmask, kg, kdg;
  OpenCvAll() {
    auto [a, b] = filters::gaussian_derivative_kernels(1.0f);
    kg = a;
    kdg = b;
  }
  void run(const cv::Mat& in) {
    cv::GaussianBlur(in, g, {3, 3}, 0, 0, cv::BORDER_REFLECT_101);
    cv::Sobel(in, sx, CV_32F, 1, 0, 3);
    cv::Sobel(in, sy, CV_32F, 0, 1, 3);
    cv::magnitude(sx, sy, mag);
    cv::threshold(mag, mask, 100, 255, cv::THRESH_BINARY);
    cv::phase(sx, sy, dir);
    cv::Laplacian(in, lap, CV_32F, 1);
    cv::Mat gf;
    g.convertTo(gf, CV_32F);
    cv::Laplacian(gf, log, CV_32F, 1);
    cv::sepFilter2D(in, gx, CV_32F, kdg, kg.t());
    cv::sepFilter2D(in, gy, CV_32F, kg, kdg.t());
    cv::magnitude(gx, gy, gmag);
    cv::threshold(gmag, gmask, 10, 255, cv::THRESH_BINARY);
  }
};

void BM_Filters_OpenCvAll_5x32x24(benchmark::State& state) {
  auto levels = retina_levels();
  OpenCvAll cv_all;
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    for (const auto& level : levels) cv_all.run(level);
    benchmark::DoNotOptimize(cv_all.gmask.data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK(BM_Filters_OpenCvAll_5x32x24);

void BM_Filters_OpenCvAll_FullFrame(benchmark::State& state) {
  cv::Mat frame = frame_of(size_arg(state));
  OpenCvAll cv_all;
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    cv_all.run(frame);
    benchmark::DoNotOptimize(cv_all.gmask.data);
    timing.stop();
  }
  timing.report(state);
}
BENCHMARK(BM_Filters_OpenCvAll_FullFrame)->Args({1024, 768})->Unit(benchmark::kMicrosecond);

// ---- framework overhead and pipeline (whole graphs) ----

const Registry& registry() {
  static Registry* r = [] {
    auto* reg = new Registry();
    reg->load_folders(Registry::default_search_path());
    return reg;
  }();
  return *r;
}

std::string bench_frame_file() {
  static std::string path = [] {
    std::string p = (std::filesystem::temp_directory_path() / "saccade_bench_1024x768.png").string();
    cv::imwrite(p, frame_of({1024, 768}));
    return p;
  }();
  return path;
}

// Runs a graph once; returns seconds and the executor (for stats).
double run_graph(const std::string& xml, ExecutorOptions options, std::unique_ptr<Executor>* keep = nullptr,
                 std::unique_ptr<ResolvedGraph>* keep_graph = nullptr) {
  Diagnostics diag;
  GraphDecl decl = load_graph_string(xml, "<bench>", diag);
  auto graph = std::make_unique<ResolvedGraph>(*resolve_graph(decl, registry(), diag));
  auto executor = std::make_unique<Executor>(*graph, registry(), options);
  if (!executor->open().ok() || !executor->run().ok()) {
    std::fprintf(stderr, "bench graph failed\n");
    std::exit(2);
  }
  double s = executor->elapsed_s();
  if (keep) *keep = std::move(executor);
  if (keep_graph) *keep_graph = std::move(graph);
  return s;
}

std::string chain_xml(int count, int frames, bool inline_nodes, double paced_fps = 0) {
  std::string pace = paced_fps > 0 ? "<param name=\"rate\" value=\"realtime\"/><param name=\"fps\" value=\"" +
                                         std::to_string(paced_fps) + "\"/>"
                                   : "<param name=\"rate\" value=\"fast\"/>";
  std::string xml = "<graph><node name=\"src\" plugin=\"capture.image\"><param name=\"path\" value=\"" +
                    bench_frame_file() + "\"/><param name=\"count\" value=\"" + std::to_string(frames) + "\"/>" + pace +
                    "<param name=\"color\" value=\"unchanged\"/></node>";
  std::string attr = inline_nodes ? " inline=\"true\"" : "";
  std::string prev = "src.image";
  for (int i = 0; i < count; ++i) {
    std::string n = "p" + std::to_string(i);
    xml += "<node name=\"" + n + "\" plugin=\"util.passthrough\"" + attr + "/>";
    xml += "<edge from=\"" + prev + "\" to=\"" + n + ".in\" queue=\"block:4\"/>";
    prev = n + ".out";
  }
  xml += "<node name=\"sink\" plugin=\"util.null\"" + attr + "/><edge from=\"" + prev +
         "\" to=\"sink.in\" queue=\"block:4\"/></graph>";
  return xml;
}

// Throughput per edge: (time with 10 pass-through nodes - time with none) / frames
// / 10, all inline on one thread as GStreamer's pipeline below runs.
void BM_Framework_PerEdge_Inline(benchmark::State& state) {
  const int frames = 20000;
  ExecutorOptions o;
  o.threads = 1;
  double per_edge = 0;
  for (auto _ : state) {
    double t0 = run_graph(chain_xml(0, frames, true), o);
    double t10 = run_graph(chain_xml(10, frames, true), o);
    per_edge = (t10 - t0) / frames / 10;
    state.SetIterationTime(per_edge);
  }
  state.counters["us_per_edge"] = per_edge * 1e6;
}
BENCHMARK(BM_Framework_PerEdge_Inline)->UseManualTime()->Iterations(3)->Unit(benchmark::kMicrosecond);

// Latency per edge: frames paced at 2 kHz (queues stay empty) through 10
// pass-through nodes; (capture->sink latency p50 with 10 - with none) / 10.
void framework_latency(benchmark::State& state, bool inline_nodes) {
  const int frames = 2000;
  ExecutorOptions o;
  o.threads = inline_nodes ? 1 : 2;
  double per_edge = 0, p99 = 0;
  for (auto _ : state) {
    std::unique_ptr<Executor> e0, e10;
    std::unique_ptr<ResolvedGraph> g0, g10;
    run_graph(chain_xml(0, frames, inline_nodes, 2000), o, &e0, &g0);
    run_graph(chain_xml(10, frames, inline_nodes, 2000), o, &e10, &g10);
    const auto& l0 = e0->stats("sink")->latency;
    const auto& l10 = e10->stats("sink")->latency;
    per_edge = (l10.mean() - l0.mean()) / 10 / 1e9;
    p99 = static_cast<double>(l10.percentile(0.99)) / 1e3;
    state.SetIterationTime(std::max(per_edge, 1e-12));
  }
  state.counters["us_per_edge_mean"] = per_edge * 1e6;
  state.counters["chain_latency_p99_us"] = p99;
}
void BM_Framework_LatencyPerEdge_Inline(benchmark::State& state) { framework_latency(state, true); }
void BM_Framework_LatencyPerEdge_AcrossThreads(benchmark::State& state) { framework_latency(state, false); }
BENCHMARK(BM_Framework_LatencyPerEdge_Inline)->UseManualTime()->Iterations(1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Framework_LatencyPerEdge_AcrossThreads)->UseManualTime()->Iterations(1)->Unit(benchmark::kMicrosecond);

double time_command(const std::string& cmd) {
  auto t0 = std::chrono::steady_clock::now();
  if (std::system(cmd.c_str()) != 0) return -1;
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The peer: GStreamer's fakesrc ! identity x10 ! fakesink, per element.
void BM_GStreamer_PerElement_Identity(benchmark::State& state) {
  const int buffers = 200000;
  std::string base = "gst-launch-1.0 -q fakesrc num-buffers=" + std::to_string(buffers) + " ";
  std::string chain;
  for (int i = 0; i < 10; ++i) chain += "! identity ";
  double per = 0;
  for (auto _ : state) {
    double t0 = time_command(base + "! fakesink sync=false > /dev/null 2>&1");
    double t10 = time_command(base + chain + "! fakesink sync=false > /dev/null 2>&1");
    if (t0 < 0 || t10 < 0) {
      state.SkipWithError("gst-launch-1.0 failed (install gstreamer1.0-tools)");
      return;
    }
    per = (t10 - t0) / buffers / 10;
    state.SetIterationTime(per);
  }
  state.counters["us_per_element"] = per * 1e6;
}
BENCHMARK(BM_GStreamer_PerElement_Identity)->UseManualTime()->Iterations(3)->Unit(benchmark::kMicrosecond);

// capture(memory) -> retina -> filters, as fast as it goes.
void BM_Pipeline_MemoryRetinaFilters(benchmark::State& state) {
  const int frames = 5000;
  const bool inline_nodes = state.range(0) != 0;
  std::string attr = inline_nodes ? " inline=\"true\"" : "";
  std::string xml = "<graph><node name=\"src\" plugin=\"capture.image\"><param name=\"path\" value=\"" +
                    bench_frame_file() + "\"/><param name=\"count\" value=\"" + std::to_string(frames) +
                    "\"/><param name=\"rate\" value=\"fast\"/><param name=\"color\" value=\"unchanged\"/></node>"
                    "<node name=\"retina\" plugin=\"retina\"" +
                    attr +
                    "/>"
                    "<node name=\"filters\" plugin=\"filters.bank\"" +
                    attr +
                    "/>"
                    "<node name=\"sink\" plugin=\"util.null\"" +
                    attr +
                    "/>"
                    "<edge from=\"src.image\" to=\"retina.image\" queue=\"block:2\"/>"
                    "<edge from=\"retina.retina\" to=\"filters.retina\" queue=\"block:2\"/>"
                    "<edge from=\"filters.maps\" to=\"sink.in\" queue=\"block:2\"/></graph>";
  ExecutorOptions o;
  o.threads = inline_nodes ? 1 : 2;
  for (auto _ : state) {
    std::unique_ptr<Executor> e;
    std::unique_ptr<ResolvedGraph> g;
    double s = run_graph(xml, o, &e, &g);
    state.SetIterationTime(s / frames);
    const NodeStats* f = e->stats("filters");
    state.counters["frames_per_s"] = frames / s;
    state.counters["latency_p50_us"] = static_cast<double>(f->latency.percentile(0.5)) / 1e3;
    state.counters["latency_p99_us"] = static_cast<double>(f->latency.percentile(0.99)) / 1e3;
    state.counters["retina_p50_us"] = static_cast<double>(e->stats("retina")->process_time.percentile(0.5)) / 1e3;
    state.counters["filters_p50_us"] = static_cast<double>(f->process_time.percentile(0.5)) / 1e3;
  }
}
BENCHMARK(BM_Pipeline_MemoryRetinaFilters)
    ->Arg(1)
    ->Arg(0)
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMicrosecond);

// ---- The box tracker: its transform against OpenCV's, and whole frames ----

// Forward and back, as each look of the tracker takes five and one.
void BM_Tracker_Fft64_Saccade(benchmark::State& state) {
  cv::Mat image(64, 64, CV_32F), back;
  cv::randu(image, -1.0f, 1.0f);
  fovea::RealFft2d fft(64);
  fovea::HalfSpectrum spectrum;
  for (auto _ : state) {
    fft.forward(image, spectrum);
    fft.inverse(spectrum, back);
    benchmark::DoNotOptimize(back.data);
  }
}
BENCHMARK(BM_Tracker_Fft64_Saccade);

void BM_Tracker_Fft64_OpenCv(benchmark::State& state) {
  cv::Mat image(64, 64, CV_32F), spectrum, back;
  cv::randu(image, -1.0f, 1.0f);
  for (auto _ : state) {
    cv::dft(image, spectrum, cv::DFT_COMPLEX_OUTPUT);
    cv::idft(spectrum, back, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
    benchmark::DoNotOptimize(back.data);
  }
}
BENCHMARK(BM_Tracker_Fft64_OpenCv);

// A look's patch before it is halved: 128x128 pixels sampled every 1.875
// source pixels of a 640x480 frame (a 120-pixel target's), upright
// (first argument 0), turned by 5 degrees, as the turn search's looks are,
// or by 20, as a target turned in the image's plane is followed; from a
// colour frame (second argument 3) or a monochrome one (1).
// SACCADE_AVX512=0 keeps every look on the eight-pixel gathers.
void BM_Tracker_LookWarp(benchmark::State& state) {
  cv::Mat frame = frame_of({640, 480});
  if (state.range(1) == 3) cv::cvtColor(frame, frame, cv::COLOR_GRAY2BGR);
  const double angle = static_cast<double>(state.range(0)) * CV_PI / 180, step = 1.875;
  const double c = std::cos(angle) * step, s = std::sin(angle) * step, middle = 63.5;
  const cv::Matx23d map(c, -s, 320 - (c - s) * middle, s, c, 240 - (s + c) * middle);
  cv::Mat out, scratch;
  for (auto _ : state) {
    fovea::warp_to_gray(frame, map, {128, 128}, out, scratch);
    benchmark::DoNotOptimize(out.data);
  }
}
BENCHMARK(BM_Tracker_LookWarp)->ArgsProduct({{0, 5, 20}, {3, 1}})->Unit(benchmark::kMicrosecond);

// The whole-frame search's coarse view of a 640x480 frame for a 32x24
// target (192x144 cell means, 3.33 source pixels a cell), of a colour frame
// (argument 3) or a monochrome one (1). SACCADE_AVX512=0 keeps both on the
// eight-cell gathers.
void BM_Tracker_CoarseView640(benchmark::State& state) {
  cv::Mat frame = frame_of({640, 480});
  if (state.range(0) == 3) cv::cvtColor(frame, frame, cv::COLOR_GRAY2BGR);
  const cv::Size size(192, 144);
  std::vector<float> cells(static_cast<std::size_t>(size.area()));
  for (auto _ : state) {
    fovea::sample_cell_means(frame, {320, 240}, 640.0 / size.width, 480.0 / size.height, size, cells.data());
    benchmark::DoNotOptimize(cells.data());
  }
}
BENCHMARK(BM_Tracker_CoarseView640)->Arg(3)->Arg(1)->Unit(benchmark::kMicrosecond);

// A 640x480 colour frame and a 96x72 target on it (scaled Aloe); or the
// monochrome camera's frame (its looks warped without the gray conversion).
cv::Mat tracker_frame(bool monochrome = false) {
  if (monochrome) return frame_of({640, 480});
  cv::Mat frame;
  cv::cvtColor(frame_of({640, 480}), frame, cv::COLOR_GRAY2BGR);
  return frame;
}
const cv::Rect2d kTrackerTarget(272, 204, 96, 72);

// A tracked frame: the filter's look (and every fourth frame two turned
// ones), the scale filter, learning. The target stands still.
void tracked_frames(benchmark::State& state, bool monochrome) {
  const cv::Mat frame = tracker_frame(monochrome);
  fovea::BoxTracker tracker;
  if (!tracker.init(frame, kTrackerTarget).ok()) state.SkipWithError("init");
  for (auto _ : state)
    if (tracker.update(frame).state != fovea::TrackState::kTracking) state.SkipWithError("not tracked");
}
void BM_Tracker_TrackedFrame640(benchmark::State& state) { tracked_frames(state, false); }
BENCHMARK(BM_Tracker_TrackedFrame640)->Unit(benchmark::kMicrosecond);
void BM_Tracker_TrackedFrame640Monochrome(benchmark::State& state) { tracked_frames(state, true); }
BENCHMARK(BM_Tracker_TrackedFrame640Monochrome)->Unit(benchmark::kMicrosecond);

// A frame while the target is lost: the looks at the last place and at the
// whole-frame search's proposals (every other frame), on a frame without it.
void lost_frames(benchmark::State& state, bool monochrome) {
  const cv::Mat frame = tracker_frame(monochrome);
  // A frame without it: the first upside down, on which a small target's look
  // finds look-alikes to follow, so noise for those.
  cv::Mat other(frame.size(), frame.type());
  if (state.range(0) >= 64) {
    cv::flip(frame, other, -1);
  } else {
    // The same noise on every run of the benchmark (OpenCV's shared generator
    // moves on between runs, and on some noise the tracker follows a look-alike
    // for the 200 frames and is never lost).
    cv::RNG noise(0x5eed);
    noise.fill(other, cv::RNG::UNIFORM, 0, 255);
  }
  fovea::BoxTracker tracker;
  // The target's width (its height three quarters of it), centred where kTrackerTarget is.
  const double w = static_cast<double>(state.range(0)), h = 0.75 * w;
  const cv::Rect2d target(320 - w / 2, 240 - h / 2, w, h);
  if (!tracker.init(frame, target).ok()) state.SkipWithError("init");
  for (int i = 0; i < 200 && tracker.last().state != fovea::TrackState::kLost; ++i) tracker.update(other);
  if (tracker.last().state != fovea::TrackState::kLost) state.SkipWithError("never lost");
  for (auto _ : state) benchmark::DoNotOptimize(tracker.update(other));
}
// The whole-frame search sees the frame at the step that makes the target 8
// pixels wide: a small target's is the largest.
void BM_Tracker_LostFrame640(benchmark::State& state) { lost_frames(state, false); }
BENCHMARK(BM_Tracker_LostFrame640)->Arg(96)->Arg(32)->Unit(benchmark::kMicrosecond);
void BM_Tracker_LostFrame640Monochrome(benchmark::State& state) { lost_frames(state, true); }
BENCHMARK(BM_Tracker_LostFrame640Monochrome)->Arg(96)->Arg(32)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // the comparisons are single-thread, OpenCV's too
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
