// Runs a graph with the live view on a loopback port (the view may use half a
// core), for the browser and Foxglove-client test (view_test.mjs):
//   saccade_view_host GRAPH [PORT]
// Prints "view: <url>" once it listens, runs until its standard input closes
// (or the graph ends), then prints the server's counters as one JSON line
// ("counters: {...}") and exits 0 (1 when the graph failed).
#include <atomic>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>

#include "saccade/executor.hpp"
#include "saccade/graph.hpp"
#include "saccade/testing.hpp"
#include "view_server.hpp"

int main(int argc, char** argv) {
  using namespace saccade;
  if (argc < 2) {
    std::fprintf(stderr, "usage: saccade_view_host GRAPH [PORT]\n");
    return 2;
  }
  Diagnostics diag;
  GraphDecl decl = load_graph_file(argv[1], diag);
  std::optional<ResolvedGraph> graph;
  if (!diag.has_errors()) graph = resolve_graph(decl, testing::default_registry(), diag);
  if (!graph) {
    std::fprintf(stderr, "%s", diag.format().c_str());
    return 2;
  }
  std::atomic<bool> stop{false};
  ExecutorOptions options;
  options.threads = 2;
  options.external_stop = &stop;
  Executor executor(*graph, testing::default_registry(), options);
  if (Status s = executor.open(); !s.ok()) {
    std::fprintf(stderr, "%s\n", s.message().c_str());
    return 1;
  }
  view::ViewOptions view_options;
  view_options.port = argc > 2 ? std::stoi(argv[2]) : 0;
  // Half a core rather than the default 4%: this host serves the page's and
  // the Foxglove client's test, not the budget's (View.ATightCpuShare... has
  // its own), and under ThreadSanitizer's slowdown 4% let a picture out
  // about once a second (22871 budget waits in one run), too few for the
  // page's waits when the whole suite runs beside it.
  view_options.cpu_share = 0.5;
  auto started = view::start_view(executor, view_options);
  if (!started.ok()) {
    std::fprintf(stderr, "%s\n", started.error().c_str());
    return 1;
  }
  const std::unique_ptr<view::ViewServer>& server = *started;
  std::printf("view: %s\n", server->url().c_str());
  std::fflush(stdout);
  std::thread watch([&] {
    std::string line;
    while (std::getline(std::cin, line)) {}
    stop = true;
    executor.request_stop();
  });
  watch.detach();
  const Status status = executor.run();
  const view::ViewCounters c = server->counters();
  server->stop();
  std::printf(
      "counters: {\"connections\": %llu, \"messages_sent\": %llu, \"malformed\": %llu, \"oversize\": %llu, "
      "\"injected\": %llu, \"budget_waits\": %llu}\n",
      static_cast<unsigned long long>(c.connections), static_cast<unsigned long long>(c.messages_sent),
      static_cast<unsigned long long>(c.malformed), static_cast<unsigned long long>(c.oversize),
      static_cast<unsigned long long>(c.injected), static_cast<unsigned long long>(c.budget_waits));
  std::fflush(stdout);
  if (!status.ok() && !status.is_end_of_stream()) {
    std::fprintf(stderr, "%s\n", status.message().c_str());
    return 1;
  }
  return 0;
}
