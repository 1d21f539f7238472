// What the live view costs a graph (issue 26's floor: a viewer attached at
// 30 Hz costs the demo <= 5% throughput). Runs a graph (graphs/demo.xml, the
// video looped, `--frames` frames) in turns: without a view server, with one
// nobody watches, and with one a viewer watches: a WebSocket client in this
// process subscribed to what the page shows (the first camera's frames as
// JPEG, the stats, every JSON channel), and one subscribed to every picture
// channel raw and as JPEG (a Foxglove layout showing them all), read as they
// come. Prints each run's frames per second and CPU time per frame (the whole
// process's: graph, server and viewer), the medians and the cost against no
// server.
//   saccade_view_bench [--graph FILE] [--frames N] [--rounds R] [--rate HZ] [--set node.param=value]...
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include "saccade/executor.hpp"
#include "saccade/graph.hpp"
#include "saccade/registry.hpp"
#include "view_server.hpp"

namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using json = nlohmann::json;
using namespace saccade;

enum class Mode { kNone, kIdle, kViewer, kAll };
const char* name(Mode m) {
  return m == Mode::kNone     ? "no server"
         : m == Mode::kIdle   ? "server, no viewer"
         : m == Mode::kViewer ? "page's viewer"
                              : "every picture";
}

struct Viewer {
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> messages{0};
  std::map<std::string, uint64_t> per_topic;  // after the thread joined
  std::thread thread;
  Status status;  // what ended the connection early (Beast throws)

  void start(int port, const std::vector<std::string>& topics) {
    thread = std::thread([this, port, topics] {
      try {
        net::io_context ioc;
        websocket::stream<tcp::socket> ws(ioc);
        ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)));
        ws.set_option(websocket::stream_base::decorator([](websocket::request_type& req) {
          req.set(beast::http::field::sec_websocket_protocol, "foxglove.websocket.v1");
        }));
        ws.handshake("127.0.0.1", "/");
        beast::flat_buffer buffer;
        std::map<uint32_t, std::string> subscribed;
        while (!stop) {
          buffer.consume(buffer.size());
          ws.read(buffer);
          if (ws.got_text()) {
            const json m = json::parse(beast::buffers_to_string(buffer.cdata()));
            if (m["op"] != "advertise") continue;
            json subs = json::array();
            for (const json& c : m["channels"]) {
              const std::string topic = c["topic"];
              if (std::find(topics.begin(), topics.end(), topic) == topics.end()) continue;
              const auto id = static_cast<uint32_t>(subscribed.size());
              subscribed[id] = topic;
              subs.push_back({{"id", id}, {"channelId", c["id"]}});
            }
            ws.text(true);
            ws.write(net::buffer(json{{"op", "subscribe"}, {"subscriptions", subs}}.dump()));
            continue;
          }
          const std::string data = beast::buffers_to_string(buffer.cdata());
          if (data.size() < 13) continue;
          uint32_t id = 0;
          std::memcpy(&id, data.data() + 1, 4);
          ++per_topic[subscribed[id]];
          ++messages;
        }
        beast::error_code ec;
        ws.next_layer().close(ec);
      } catch (const std::exception& e) {
        if (!stop) status = Status::error(e.what());
      }
    });
  }
  void end() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  ~Viewer() { end(); }  // a round that fails returns with the viewer still connected
};

struct RoundResult {
  double fps = 0;
  double viewer_hz = 0;
  std::map<std::string, uint64_t> per_topic;
  double seconds = 0;
  double cpu_us_per_frame = 0;  // the whole process's CPU time (graph, server, viewer) per frame
};

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v.size() % 2 ? v[v.size() / 2] : (v[v.size() / 2 - 1] + v[v.size() / 2]) / 2;
}

constexpr Mode kModes[] = {Mode::kNone, Mode::kIdle, Mode::kViewer, Mode::kAll};

// The graph with the --set overrides it has nodes for; nullopt (the problems
// printed) when it does not load or resolve.
std::optional<ResolvedGraph> load_bench_graph(const std::string& graph_file, const std::vector<std::string>& sets,
                                              const Registry& registry) {
  Diagnostics diag;
  GraphDecl decl = load_graph_file(graph_file, diag);
  // --set names nodes the graph may not have (the demo's camera and snapshot): only those it has.
  std::vector<std::string> present;
  for (const std::string& s : sets)
    if (decl.find_node(s.substr(0, s.find('.')))) present.push_back(s);
  apply_overrides(decl, present, diag);
  std::optional<ResolvedGraph> graph;
  if (!diag.has_errors()) graph = resolve_graph(decl, registry, diag);
  if (!graph) std::fprintf(stderr, "%s", diag.format().c_str());
  return graph;
}

// What each kind of viewer subscribes to. The page: the first image as JPEG,
// the stats, the JSON channels. Every picture: each image raw and as JPEG,
// each retina and feature maps as JPEG.
struct Topics {
  std::vector<std::string> page = {"/saccade/stats"}, all = {"/saccade/stats"};
};

Topics viewer_topics(const ResolvedGraph& graph) {
  Topics topics;
  for (const ResolvedNode& n : graph.nodes)
    for (const PortSpec& out : n.contract.outputs()) {
      const std::string base = "/" + n.decl.name + "/" + out.name;
      const bool picture = out.type == "Image" || out.type == "Retina" || out.type == "FeatureMaps";
      if (out.type == "Image") topics.all.push_back(base);
      if (picture) topics.all.push_back(base + "/jpeg");
      if (out.type == "Image" && topics.page.size() == 1) topics.page.push_back(base + "/jpeg");
      if (!picture) topics.page.push_back(base + "/json");
    }
  return topics;
}

struct Bench {
  const ResolvedGraph& graph;
  const Registry& registry;
  int threads = 0;
  int64_t frames = 0;
  double rate = 0;
  Topics topics;
  // The node whose processed count is the graph's throughput: the last one.
  std::string last;

  // One run of the graph in `mode`, its viewer (if any) connected and
  // subscribed before the first frame, so the whole run carries its load.
  // The round's figures, or what stopped the graph, the server or the viewer.
  Result<RoundResult> run(Mode mode) const {
    ExecutorOptions options;
    options.threads = threads;
    options.max_frames = frames;
    Executor executor(graph, registry, options);
    if (Status s = executor.open(); !s.ok()) return s;
    std::unique_ptr<view::ViewServer> server;
    Viewer viewer;
    if (mode != Mode::kNone) {
      auto served = serve(executor, mode, viewer);
      if (!served.ok()) return served.status();
      server = std::move(served).value();
    }
    const double cpu0 = cpu_seconds();
    const auto t0 = std::chrono::steady_clock::now();
    const uint64_t m0 = viewer.messages.load();
    if (Status s = executor.run(); !s.ok() && !s.is_end_of_stream()) return s;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const uint64_t m1 = viewer.messages.load();
    const double cpu = cpu_seconds() - cpu0;
    viewer.end();
    if (server) server->stop();
    if (!viewer.status.ok()) return Status::error("viewer: " + viewer.status.message());
    RoundResult r;
    r.fps = static_cast<double>(executor.stats(last)->processed.load()) / seconds;
    r.viewer_hz = static_cast<double>(m1 - m0) / seconds;
    r.per_topic = viewer.per_topic;
    r.seconds = seconds;
    r.cpu_us_per_frame = 1e6 * cpu / static_cast<double>(std::max<uint64_t>(1, executor.stats(last)->processed.load()));
    return r;
  }

  // The view server on a free port, its viewer connected (per `mode`).
  Result<std::unique_ptr<view::ViewServer>> serve(Executor& executor, Mode mode, Viewer& viewer) const {
    view::ViewOptions vo;
    vo.port = 0;
    vo.max_rate_hz = rate;
    auto started = view::start_view(executor, vo);
    if (!started.ok()) return started.status();
    std::unique_ptr<view::ViewServer> server = std::move(started).value();
    if (mode == Mode::kViewer || mode == Mode::kAll) {
      viewer.start(server->port(), mode == Mode::kAll ? topics.all : topics.page);
      for (int i = 0; i < 500 && server->counters().clients == 0; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      std::this_thread::sleep_for(std::chrono::milliseconds(50));  // its subscriptions arrive
    }
    return server;
  }
};

void print_round(int round, Mode m, const RoundResult& res) {
  std::printf("round %d  %-18s %8.1f frames/s %7.1f CPU us/frame", round, name(m), res.fps, res.cpu_us_per_frame);
  if (m == Mode::kViewer || m == Mode::kAll) {
    std::printf("  viewer got (Hz):");
    for (const auto& [topic, n] : res.per_topic)
      std::printf(" %s %.1f", topic.c_str(), static_cast<double>(n) / res.seconds);
  }
  std::printf("\n");
  std::fflush(stdout);
}

// Every run's figures per mode, in round order.
struct Runs {
  std::map<Mode, std::vector<double>> fps, viewer_hz, cpu;
};

// The median of a mode's runs (0 with no runs, --rounds 0).
double median_of(const std::map<Mode, std::vector<double>>& runs, Mode m) {
  const auto it = runs.find(m);
  return it == runs.end() ? median({}) : median(it->second);
}

void print_summary(const std::string& graph_file, const Bench& bench, int rounds, const Runs& runs) {
  auto fps = [&](Mode m) { return median_of(runs.fps, m); };
  auto cpu = [&](Mode m) { return median_of(runs.cpu, m); };
  const double base = fps(Mode::kNone);
  std::printf("\n%s, %lld frames a run, %d rounds, view rate %.0f Hz per channel; median frames/s:\n",
              graph_file.c_str(), static_cast<long long>(bench.frames), rounds, bench.rate);
  for (Mode m : kModes)
    std::printf("  %-18s %8.1f  (%+.1f%%)   CPU %.1f us/frame (%+.1f%%)\n", name(m), fps(m),
                100.0 * (fps(m) / base - 1.0), cpu(m), 100.0 * (cpu(m) / cpu(Mode::kNone) - 1.0));
  std::printf("  page's viewer: %.1f messages/s over %zu channels; every picture: %.1f messages/s over %zu channels\n",
              median_of(runs.viewer_hz, Mode::kViewer), bench.topics.page.size(), median_of(runs.viewer_hz, Mode::kAll),
              bench.topics.all.size());
  const double cost = 100.0 * (1.0 - fps(Mode::kViewer) / base);
  const double cpu_cost = 100.0 * (cpu(Mode::kViewer) / cpu(Mode::kNone) - 1.0);
  std::printf("floor (the page's viewer costs <= 5%% throughput): %s (%.1f%% throughput, %.1f%% CPU per frame)\n",
              cost <= 5.0 ? "met" : "NOT met", cost, cpu_cost);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"What the live view costs a graph's throughput"};
  std::string graph_file = "graphs/demo.xml";
  int64_t frames = 4000;
  int rounds = 5;
  double rate = 30;
  int threads = 0;
  std::vector<std::string> sets;
  app.add_option("--graph", graph_file, "the graph (its sources run as fast as the graph allows)");
  app.add_option("--frames", frames, "frames per run");
  app.add_option("--rounds", rounds, "runs of each kind, taken in turns");
  app.add_option("--rate", rate, "the view's rate per channel, Hz");
  app.add_option("--threads", threads, "executor workers (0: one per core)");
  app.add_option("--set", sets, "node.param=value");
  CLI11_PARSE(app, argc, argv);

  const std::string out_dir = (std::filesystem::temp_directory_path() / "saccade_view_bench").string();
  sets.push_back("snapshot.dir=" + out_dir);
  sets.push_back("camera.loop=true");
  Registry registry;
  registry.load_folders(Registry::default_search_path());
  const std::optional<ResolvedGraph> graph = load_bench_graph(graph_file, sets, registry);
  if (!graph) return 2;
  const Bench bench{*graph, registry, threads, frames, rate, viewer_topics(*graph), graph->nodes.back().decl.name};

  Runs runs;
  auto failed = [](const Status& s) {
    std::fprintf(stderr, "view_bench: %s\n", s.message().c_str());
    return 1;
  };
  // Warm-up: caches, the video file, the plugins.
  if (const Result<RoundResult> warm = bench.run(Mode::kNone); !warm.ok()) return failed(warm.status());
  for (int r = 0; r < rounds; ++r)
    for (Mode m : kModes) {
      const Result<RoundResult> res = bench.run(m);
      if (!res.ok()) return failed(res.status());
      runs.fps[m].push_back(res->fps);
      runs.viewer_hz[m].push_back(res->viewer_hz);
      runs.cpu[m].push_back(res->cpu_us_per_frame);
      print_round(r + 1, m, *res);
    }
  print_summary(graph_file, bench, rounds, runs);
  return 0;
}
