#pragma once
// Runs a validated graph: sources on their own threads at their own pace, the
// other nodes on a worker pool (or inline on their producer's thread), or
// everything on one thread in a deterministic order.
#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "saccade/graph.hpp"
#include "saccade/registry.hpp"
#include "saccade/stats.hpp"
#include "saccade/status.hpp"

namespace saccade {

struct ExecutorOptions {
  int threads = 0;             // workers; 0 = one per core
  bool deterministic = false;  // one thread, fixed order: same input, same output
  int64_t max_frames = -1;     // each source stops after this many frames
  double duration_s = -1.0;    // stop after this long
  double stats_interval_s = 0.0;
  std::function<void(const std::string& table)> on_stats;  // every stats interval
  const std::atomic<bool>* external_stop = nullptr;        // e.g. set by SIGINT
};

class Executor {
 public:
  Executor(const ResolvedGraph& graph, const Registry& registry, ExecutorOptions options = {});
  ~Executor();
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  // Creates and opens every node; an error names the node.
  Status open();
  // Runs until every node reached end of stream, a stop, or a fatal node error
  // (returned, naming the node). Closes every node before it returns.
  Status run();
  // Thread-safe; the graph drains what is in flight and ends.
  void request_stop();

  std::vector<const NodeStats*> stats() const;
  const NodeStats* stats(const std::string& node) const;
  std::string stats_table() const;
  std::string stats_json() const;
  double elapsed_s() const;

  // The node instance, for tests and embedding.
  Node* node(const std::string& name) const;

  // Calls `tap` with every message node `node` emits on output `port`,
  // connected or not, on the emitting thread before its consumers get it (a
  // recorder, a live view). Taps run under the lock that delivers messages,
  // so all taps together see messages in the order consumers take them (a
  // side input's newest value among its node's triggers): keep a tap short,
  // hand the message off, never call back into the executor. Before run();
  // an error when there is no such node or output.
  using Tap = std::function<void(const MessagePtr&)>;
  Status add_tap(const std::string& node, const std::string& port, Tap tap);
  // Gives a node's side input `input` a value as an edge would (the newest
  // wins; the node sees it at its next process()): a target from a viewer.
  // Thread-safe, while running. An error when there is no such node, or it is
  // not a side input (a trigger input is fed by its edge alone).
  Status inject(const std::string& node, const std::string& input, MessagePtr message);
  // The graph this executor runs.
  const ResolvedGraph& graph() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace saccade
