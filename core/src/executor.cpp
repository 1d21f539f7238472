#include "saccade/executor.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <limits>
#include <mutex>
#include <thread>

#include "saccade/log.hpp"

namespace saccade {

namespace {

// Nodes waiting for a worker. Each node is queued at most once (its `queued`
// flag), so a ring of the graph's size never fills and never allocates.
class ReadyRing {
 public:
  void reset(std::size_t capacity) { slots_.assign(capacity, -1); }
  void push(int node) {
    slots_[(head_ + size_) % slots_.size()] = node;
    ++size_;
  }
  int pop() {
    int node = slots_[head_];
    head_ = (head_ + 1) % slots_.size();
    --size_;
    return node;
  }
  bool empty() const { return size_ == 0; }

 private:
  std::vector<int> slots_;
  std::size_t head_ = 0, size_ = 0;
};

// A bounded ring of messages with the queue policy applied at push.
class InputQueue {
 public:
  void configure(QueueSpec spec) {
    spec_ = spec;
    ring_.assign(static_cast<std::size_t>(spec.capacity) + 1, nullptr);
  }
  // Returns true when a message was dropped to make room.
  bool push(MessagePtr m) {
    bool dropped = false;
    if (size_ >= static_cast<std::size_t>(spec_.capacity) && spec_.policy != QueuePolicy::kBlock) {
      pop();  // latest and fifo keep the newest
      dropped = true;
    }
    if (size_ == ring_.size()) grow();
    ring_[(head_ + size_) % ring_.size()] = std::move(m);
    ++size_;
    return dropped;
  }
  MessagePtr pop() {
    MessagePtr m = std::move(ring_[head_]);
    head_ = (head_ + 1) % ring_.size();
    --size_;
    return m;
  }
  const MessagePtr& front() const { return ring_[head_]; }
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }
  bool full() const { return size_ >= static_cast<std::size_t>(spec_.capacity); }
  const QueueSpec& spec() const { return spec_; }

 private:
  // Only a block queue outgrows its capacity, by the messages one process() call
  // emits past the check that let the producer run.
  void grow() {
    std::vector<MessagePtr> bigger(ring_.size() * 2);
    for (std::size_t i = 0; i < size_; ++i) bigger[i] = std::move(ring_[(head_ + i) % ring_.size()]);
    ring_ = std::move(bigger);
    head_ = 0;
  }
  QueueSpec spec_;
  std::vector<MessagePtr> ring_;
  std::size_t head_ = 0, size_ = 0;
};

struct InputRt {
  InputKind kind = InputKind::kTrigger;
  bool connected = false;
  bool delayed = false;
  bool eos = false;
  int producer = -1;
  int group = -1;  // index into NodeRt::groups for trigger inputs
  InputQueue queue;
  MessagePtr side_latest;  // side and delayed inputs: newest value
  InputStats* stats = nullptr;
  bool triggers() const { return connected && !delayed && kind != InputKind::kSide; }
};

struct Target {
  int node;
  int input;
};

// Time spent in nested (inline) process() calls during the current one on this
// thread: it is the consumers' time, not the producer's.
thread_local int64_t t_nested_ns = 0;

// Runs `call`; `own_ns` is its duration less what calls nested in it took. Its
// whole duration is added to the enclosing call's nested time, so inline
// hand-offs cost no clock reads of their own.
template <class F>
Status timed_call(F&& call, int64_t& t0, int64_t& own_ns) {
  int64_t outer = t_nested_ns;
  t_nested_ns = 0;
  t0 = steady_now_ns();
  Status s = call();
  int64_t t1 = steady_now_ns();
  own_ns = (t1 - t0) - t_nested_ns;
  t_nested_ns = outer + (t1 - t0);
  return s;
}

struct SyncGroup {
  std::vector<int> inputs;
  int64_t tolerance_ns = std::numeric_limits<int64_t>::max();  // implicit join: any
};

}  // namespace

struct Executor::Impl {
  struct NodeRt;

  // Each node gets its own sink so emit() knows who emitted.
  struct NodeSink final : EmitSink {
    Impl* impl = nullptr;
    int node = -1;
    void emit(int output, MessagePtr message) override { impl->emit(node, output, std::move(message)); }
    bool stop_requested() const override { return impl->stop_.load(std::memory_order_relaxed); }
    bool sleep_until(int64_t steady_ns) override { return impl->sleep_until(steady_ns, node); }
  };

  struct NodeRt {
    const ResolvedNode* resolved = nullptr;
    std::shared_ptr<Node> node;
    NodeSlot slot;
    NodeSink sink;
    std::vector<InputRt> inputs;
    std::vector<std::vector<Target>> outputs;
    std::vector<std::vector<Executor::Tap>> taps;  // per output
    std::vector<SyncGroup> groups;
    std::unique_ptr<NodeStats> stats;
    bool source = false;
    bool running = false;
    bool queued = false;
    bool finished = false;
    bool opened = false;
    int64_t frames = 0;
  };

  const ResolvedGraph& graph;
  const Registry& registry;
  ExecutorOptions options;
  std::vector<NodeRt> nodes;
  std::vector<int> topo;  // node indices in topological order (delayed edges ignored)

  mutable std::mutex mu;
  std::condition_variable work_cv;  // workers wait for ready nodes
  std::condition_variable room_cv;  // sources wait for room downstream, or a stop
  std::condition_variable done_cv;  // run() waits for the end
  ReadyRing ready;
  std::vector<int> ended;  // finished nodes not yet told (inputs_ended); reserved, never reallocates
  int sleeping_workers = 0;
  int finished_count = 0;
  bool aborted = false;
  Status failure;
  std::atomic<bool> stop_{false};
  // Read by stats_json()/elapsed_s() from other threads (a live view, a progress line) while run() writes it.
  std::atomic<int64_t> start_ns{0};
  std::atomic<int64_t> end_ns{0};

  Impl(const ResolvedGraph& g, const Registry& r, ExecutorOptions o) : graph(g), registry(r), options(std::move(o)) {}

  // A source pacing itself sleeps inside process(): that time is not work, so it
  // is kept out of the node's processing time like an inline consumer's.
  bool sleep_until(int64_t steady_ns, int node) {
    int64_t start = steady_now_ns();
    struct Account {
      int64_t start;
      ~Account() { t_nested_ns += steady_now_ns() - start; }
    } account{start};
    std::unique_lock lock(mu);
    auto deadline = std::chrono::steady_clock::time_point(std::chrono::nanoseconds(steady_ns));
    room_cv.wait_until(lock, deadline, [&] { return stop_.load(); });
    // What arrived on the side inputs while it slept is what it acts on now: a
    // source pacing itself (a control loop's clock) would otherwise act on
    // values one period old.
    NodeRt& n = nodes[static_cast<std::size_t>(node)];
    for (std::size_t k = 0; k < n.inputs.size(); ++k)
      if (!n.inputs[k].triggers()) n.slot.current[k] = n.inputs[k].side_latest;
    return !stop_.load();
  }

  Status build() {
    nodes.resize(graph.nodes.size());
    ended.reserve(graph.nodes.size());
    ready.reset(std::max<std::size_t>(1, graph.nodes.size()));
    for (std::size_t i = 0; i < graph.nodes.size(); ++i) init_node(i);
    connect_edges();
    // After the edges: whether an input triggers depends on its edge's delay.
    for (NodeRt& n : nodes) build_sync_groups(n);
    order_topologically();
    return {};
  }

  // A node's runtime state and the slot its plugin sees, sized from its contract
  // and not yet connected to anything.
  void init_node(std::size_t i) {
    const ResolvedNode& rn = graph.nodes[i];
    NodeRt& n = nodes[i];
    n.resolved = &rn;
    n.stats = std::make_unique<NodeStats>();
    n.stats->name = rn.decl.name;
    n.stats->plugin = rn.decl.plugin;
    n.inputs.resize(rn.contract.inputs().size());
    n.outputs.resize(rn.contract.outputs().size());
    n.taps.resize(n.outputs.size());
    for (std::size_t k = 0; k < n.inputs.size(); ++k) {
      n.inputs[k].kind = rn.contract.inputs()[k].kind;
      n.inputs[k].queue.configure({});
      auto s = std::make_unique<InputStats>();
      s->name = rn.contract.inputs()[k].name;
      n.inputs[k].stats = s.get();
      n.stats->inputs.push_back(std::move(s));
    }
    n.slot.name = rn.decl.name;
    n.slot.contract = &rn.contract;
    n.slot.params = &rn.params;
    n.slot.current.resize(n.inputs.size());
    n.slot.pools.resize(n.outputs.size());
    n.slot.input_connected.assign(n.inputs.size(), false);
    n.slot.output_connected.assign(n.outputs.size(), false);
    n.slot.input_allocators.assign(n.inputs.size(), nullptr);
    n.slot.output_allocators.assign(n.outputs.size(), nullptr);
    n.sink.impl = this;
    n.sink.node = static_cast<int>(i);
    n.slot.sink = &n.sink;
    n.slot.stats = n.stats.get();
  }

  void connect_edges() {
    for (const auto& e : graph.edges) {
      NodeRt& from = nodes[static_cast<std::size_t>(e.from_node)];
      NodeRt& to = nodes[static_cast<std::size_t>(e.to_node)];
      from.outputs[static_cast<std::size_t>(e.from_port)].push_back({e.to_node, e.to_port});
      from.slot.output_connected[static_cast<std::size_t>(e.from_port)] = true;
      InputRt& in = to.inputs[static_cast<std::size_t>(e.to_port)];
      in.connected = true;
      in.delayed = e.delay > 0;
      in.producer = e.from_node;
      in.queue.configure(e.queue);
      to.slot.input_connected[static_cast<std::size_t>(e.to_port)] = true;
    }
  }

  // The declared sync groups first, in file order; every triggering input no
  // group names then joins one last implicit group, so a node with several
  // triggers waits for all of them unless told otherwise.
  void build_sync_groups(NodeRt& n) {
    const NodeDecl& decl = n.resolved->decl;
    n.source = n.resolved->contract.is_source();
    for (const auto& s : decl.syncs) {
      SyncGroup g;
      g.tolerance_ns = static_cast<int64_t>(s.tolerance_ms * 1e6);
      for (const auto& name : s.inputs) {
        int k = n.resolved->contract.input_index(name);
        if (k >= 0 && n.inputs[static_cast<std::size_t>(k)].triggers()) {
          g.inputs.push_back(k);
          n.inputs[static_cast<std::size_t>(k)].group = static_cast<int>(n.groups.size());
        }
      }
      if (!g.inputs.empty()) n.groups.push_back(std::move(g));
    }
    SyncGroup join;
    for (std::size_t k = 0; k < n.inputs.size(); ++k) {
      if (n.inputs[k].triggers() && n.inputs[k].group < 0) {
        n.inputs[k].group = static_cast<int>(n.groups.size());
        join.inputs.push_back(static_cast<int>(k));
      }
    }
    if (!join.inputs.empty()) n.groups.push_back(std::move(join));
  }

  // Topological order over undelayed edges (validation rejected other cycles).
  // Each node's consumers listed once: linear in the edges, for graphs of
  // tens of thousands of nodes too.
  void order_topologically() {
    std::vector<int> indegree(nodes.size(), 0);
    std::vector<std::vector<int>> consumers(nodes.size());
    for (const auto& e : graph.edges) {
      if (e.delay != 0) continue;
      ++indegree[static_cast<std::size_t>(e.to_node)];
      consumers[static_cast<std::size_t>(e.from_node)].push_back(e.to_node);
    }
    std::deque<int> q;
    for (std::size_t i = 0; i < nodes.size(); ++i)
      if (indegree[i] == 0) q.push_back(static_cast<int>(i));
    while (!q.empty()) {
      int u = q.front();
      q.pop_front();
      topo.push_back(u);
      for (int v : consumers[static_cast<std::size_t>(u)])
        if (--indegree[static_cast<std::size_t>(v)] == 0) q.push_back(v);
    }
  }

  // "node 'name' (plugin, line N)": which node of the file, for errors at open and at run.
  static std::string where(const NodeRt& n) {
    std::string out = "node '" + n.slot.name + "' (" + n.resolved->decl.plugin;
    if (n.resolved->decl.line > 0) out += ", line " + std::to_string(n.resolved->decl.line);
    return out + ")";
  }

  Status open_nodes() {
    for (int i : topo) {
      NodeRt& n = nodes[static_cast<std::size_t>(i)];
      Result<std::shared_ptr<Node>> node = registry.create(n.resolved->decl.plugin);
      if (!node.ok()) return Status::error("node '" + n.slot.name + "': " + node.error());
      n.node = std::move(node).value();
      OpenContext ctx(n.slot);
      Status s = n.node->open(ctx);
      if (!s.ok()) return Status::error(where(n) + " failed to open: " + s.message());
      n.opened = true;
    }
    // A consumer's frame allocator reaches its producers (the first offer
    // wins where an output feeds several): consumers open after producers.
    for (const auto& e : graph.edges) {
      cv::MatAllocator* offered =
          nodes[static_cast<std::size_t>(e.to_node)].slot.input_allocators[static_cast<std::size_t>(e.to_port)];
      cv::MatAllocator*& used =
          nodes[static_cast<std::size_t>(e.from_node)].slot.output_allocators[static_cast<std::size_t>(e.from_port)];
      if (offered != nullptr && used == nullptr) used = offered;
    }
    return {};
  }

  void close_nodes() {
    for (auto it = topo.rbegin(); it != topo.rend(); ++it) {
      NodeRt& n = nodes[static_cast<std::size_t>(*it)];
      if (n.opened) n.node->close();
      n.opened = false;
    }
  }

  // --- readiness (all under mu) ---

  // Drops messages that can no longer pair, then says whether every group has a
  // matched set at its fronts.
  bool group_matched(NodeRt& n, SyncGroup& g) {
    for (;;) {
      int64_t newest = std::numeric_limits<int64_t>::min();
      for (int k : g.inputs) {
        InputRt& in = n.inputs[static_cast<std::size_t>(k)];
        if (in.queue.empty()) return false;
        newest = std::max(newest, in.queue.front()->timestamp_ns);
      }
      if (g.tolerance_ns == std::numeric_limits<int64_t>::max()) return true;
      bool dropped = false;
      for (int k : g.inputs) {
        InputRt& in = n.inputs[static_cast<std::size_t>(k)];
        if (newest - in.queue.front()->timestamp_ns > g.tolerance_ns) {
          in.queue.pop();
          bump(in.stats->sync_dropped);
          wake_producer(in);
          dropped = true;
        }
      }
      if (!dropped) return true;
    }
  }

  bool has_room_downstream(const NodeRt& n) const {
    for (const auto& targets : n.outputs)
      for (const Target& t : targets) {
        const InputRt& in = nodes[static_cast<std::size_t>(t.node)].inputs[static_cast<std::size_t>(t.input)];
        if (in.queue.spec().policy == QueuePolicy::kBlock && in.queue.full()) return false;
      }
    return true;
  }

  bool inputs_exhausted(const NodeRt& n) const {
    bool any_trigger = false;
    for (const auto& in : n.inputs) {
      if (!in.triggers()) continue;
      any_trigger = true;
      if (in.eos && in.queue.empty()) return true;
    }
    return !any_trigger;
  }

  enum class Readiness { kWait, kRun, kFinish };

  Readiness readiness(NodeRt& n) {
    if (n.source || n.running || n.queued || n.finished || !n.opened || aborted) return Readiness::kWait;
    if (n.groups.empty()) return Readiness::kFinish;  // nothing can ever trigger it
    bool matched = true;
    for (auto& g : n.groups) matched = group_matched(n, g) && matched;
    if (matched) return has_room_downstream(n) ? Readiness::kRun : Readiness::kWait;
    return inputs_exhausted(n) ? Readiness::kFinish : Readiness::kWait;
  }

  void take_inputs(NodeRt& n) {
    n.slot.trigger = nullptr;
    for (std::size_t k = 0; k < n.inputs.size(); ++k) {
      InputRt& in = n.inputs[k];
      if (in.triggers()) {
        n.slot.current[k] = in.queue.pop();
        if (n.slot.trigger == nullptr) n.slot.trigger = n.slot.current[k].get();
        wake_producer(in);
      } else {
        n.slot.current[k] = in.side_latest;
      }
    }
  }

  void wake_producer(const InputRt& in) {
    if (in.queue.spec().policy != QueuePolicy::kBlock || in.producer < 0) return;
    NodeRt& p = nodes[static_cast<std::size_t>(in.producer)];
    if (p.source)
      room_cv.notify_all();
    else
      schedule(in.producer);
  }

  // Puts the node on the ready queue, or finishes it, as its inputs say.
  void schedule(int index) {
    if (options.deterministic) return;  // the single thread scans instead
    NodeRt& n = nodes[static_cast<std::size_t>(index)];
    switch (readiness(n)) {
      case Readiness::kWait: return;
      case Readiness::kFinish: finish(index); return;
      case Readiness::kRun:
        n.queued = true;
        ready.push(index);
        if (sleeping_workers > 0) work_cv.notify_one();
        return;
    }
  }

  void finish(int index) {
    NodeRt& n = nodes[static_cast<std::size_t>(index)];
    if (n.finished) return;
    n.finished = true;
    ++finished_count;
    if (n.opened && !n.source) {
      ended.push_back(index);  // told by the watching thread, outside the lock
      done_cv.notify_all();
    }
    // What is left in a trigger queue can never be used: it had no partner.
    for (auto& in : n.inputs) {
      if (!in.queue.empty()) bump(in.stats->sync_dropped, in.queue.size());
      while (!in.queue.empty()) in.queue.pop();
    }
    for (const auto& targets : n.outputs)
      for (const Target& t : targets) {
        nodes[static_cast<std::size_t>(t.node)].inputs[static_cast<std::size_t>(t.input)].eos = true;
        schedule(t.node);
      }
    if (finished_count == static_cast<int>(nodes.size())) {
      work_cv.notify_all();
      done_cv.notify_all();
    }
  }

  // --- emitting ---

  void emit(int from, int output, MessagePtr message) {
    NodeRt& n = nodes[static_cast<std::size_t>(from)];
    bump(n.stats->emitted);
    const auto& taps = n.taps[static_cast<std::size_t>(output)];
    const auto& targets = n.outputs[static_cast<std::size_t>(output)];
    if (targets.empty() && taps.empty()) return;
    int inline_run[8];
    int inline_count = 0;
    {
      std::lock_guard lock(mu);
      // Under the lock that delivers it: the taps see the graph's messages in
      // the order its nodes take them (a recording replays a side input's
      // value at the same place among the triggers it was read with).
      for (const Executor::Tap& tap : taps) tap(message);
      for (const Target& t : targets) {
        NodeRt& to = nodes[static_cast<std::size_t>(t.node)];
        InputRt& in = to.inputs[static_cast<std::size_t>(t.input)];
        bump(in.stats->received);
        if (to.finished) {
          // Its other trigger input has ended: this message can never pair.
          if (in.triggers()) bump(in.stats->sync_dropped);
          continue;
        }
        if (!in.triggers()) {
          in.side_latest = message;
          continue;
        }
        if (in.queue.push(message)) bump(in.stats->dropped);
        if (to.resolved->decl.run_inline && !options.deterministic && inline_count < 8 &&
            readiness(to) == Readiness::kRun) {
          to.running = true;
          take_inputs(to);
          inline_run[inline_count++] = t.node;
        } else {
          schedule(t.node);
        }
      }
    }
    for (int i = 0; i < inline_count; ++i) run_taken(inline_run[i]);
  }

  // --- running ---

  // Runs a node whose inputs were taken under the lock (running == true).
  void run_taken(int index) {
    NodeRt& n = nodes[static_cast<std::size_t>(index)];
    Status s = invoke(n);
    for (auto& m : n.slot.current) m.reset();
    std::lock_guard lock(mu);
    n.running = false;
    n.slot.trigger = nullptr;
    if (s.is_error()) on_error(n, s);
    if (s.is_end_of_stream())
      finish(index);
    else
      schedule(index);
  }

  // Calls process() and records its stats.
  Status invoke(NodeRt& n) {
    ProcessContext ctx(n.slot);
    int64_t t0 = 0, own = 0;
    Status s = timed_call([&] { return n.node->process(ctx); }, t0, own);
    NodeStats& st = *n.stats;
    if (st.processed.load(std::memory_order_relaxed) == 0) st.first_ns.store(t0, std::memory_order_relaxed);
    bump(st.processed);
    st.last_ns.store(t0, std::memory_order_relaxed);
    st.process_time.record(own);
    if (n.slot.trigger != nullptr && n.slot.trigger->origin_ns > 0)
      st.latency.record(t0 + own - n.slot.trigger->origin_ns);
    return s;
  }

  // Under mu.
  void on_error(NodeRt& n, const Status& s) {
    bump(n.stats->errors);
    if (n.resolved->decl.on_error == OnError::kSkip) {
      log().warn("node '{}' ({}): {} (frame skipped)", n.slot.name, n.resolved->decl.plugin, s.message());
      return;
    }
    if (failure.ok()) failure = Status::error(where(n) + ": " + s.message());
    aborted = true;
    stop_.store(true);
    room_cv.notify_all();
    work_cv.notify_all();
    done_cv.notify_all();
  }

  void worker_loop() {
    std::unique_lock lock(mu);
    for (;;) {
      if (aborted || finished_count == static_cast<int>(nodes.size())) return;
      if (ready.empty()) {
        ++sleeping_workers;
        work_cv.wait(lock);
        --sleeping_workers;
        continue;
      }
      int index = ready.pop();
      NodeRt& n = nodes[static_cast<std::size_t>(index)];
      n.queued = false;
      Readiness r = readiness(n);
      if (r == Readiness::kFinish) {
        finish(index);
        continue;
      }
      if (r != Readiness::kRun) continue;
      n.running = true;
      take_inputs(n);
      lock.unlock();
      run_taken(index);
      lock.lock();
    }
  }

  bool source_may_continue(NodeRt& n) { return options.max_frames < 0 || n.frames < options.max_frames; }

  void source_loop(int index) {
    NodeRt& n = nodes[static_cast<std::size_t>(index)];
    for (;;) {
      {
        std::unique_lock lock(mu);
        room_cv.wait(lock, [&] { return stop_.load() || aborted || has_room_downstream(n); });
        if (stop_.load() || aborted || !source_may_continue(n)) {
          finish(index);
          return;
        }
        n.running = true;
        take_inputs(n);  // a source's inputs are side inputs: their newest values
      }
      Status s = invoke(n);
      for (auto& m : n.slot.current) m.reset();
      std::lock_guard lock(mu);
      n.running = false;
      ++n.frames;
      if (s.is_error()) on_error(n, s);
      if (s.is_end_of_stream() || (s.is_error() && aborted)) {
        finish(index);
        return;
      }
    }
  }

  // One thread, fixed order: sources step in graph order, and after each step
  // every runnable node runs, lowest topological index first, until none is left.
  void deterministic_loop() {
    std::unique_lock lock(mu);
    for (;;) {
      if (aborted || finished_count == static_cast<int>(nodes.size())) return;
      bool progressed = false;
      for (int i : topo) {
        NodeRt& n = nodes[static_cast<std::size_t>(i)];
        if (!n.source || n.finished) continue;
        if (stop_.load() || !source_may_continue(n)) {
          finish(i);
          progressed = true;
          continue;
        }
        if (!has_room_downstream(n)) continue;
        take_inputs(n);
        lock.unlock();
        Status s = invoke(n);
        for (auto& m : n.slot.current) m.reset();
        lock.lock();
        ++n.frames;
        progressed = true;
        if (s.is_error()) on_error(n, s);
        if (aborted) return;
        if (s.is_end_of_stream()) finish(i);
        drain(lock);
      }
      progressed = drain(lock) || progressed;
      if (!progressed) {
        if (failure.ok()) failure = Status::error("graph stalled: no node can run and not every node has finished");
        aborted = true;
        return;
      }
    }
  }

  bool drain(std::unique_lock<std::mutex>& lock) {
    bool any = false;
    for (;;) {
      bool ran = false;
      for (int i : topo) {
        NodeRt& n = nodes[static_cast<std::size_t>(i)];
        Readiness r = readiness(n);
        if (r == Readiness::kFinish) {
          finish(i);
          ran = true;
          break;
        }
        if (r != Readiness::kRun) continue;
        n.running = true;
        take_inputs(n);
        lock.unlock();
        Status s = invoke(n);
        for (auto& m : n.slot.current) m.reset();
        lock.lock();
        n.running = false;
        n.slot.trigger = nullptr;
        if (s.is_error()) on_error(n, s);
        if (aborted) return true;
        if (s.is_end_of_stream()) finish(i);
        ran = true;
        break;
      }
      if (!ran) return any;
      any = true;
    }
  }

  Status run() {
    start_ns.store(steady_now_ns());
    std::vector<std::thread> threads;
    {
      std::lock_guard lock(mu);
      // Nodes that can never trigger end at once.
      for (std::size_t i = 0; i < nodes.size(); ++i)
        if (!nodes[i].opened) finish(static_cast<int>(i));
    }
    if (options.deterministic) {
      threads.emplace_back([this] {
        deterministic_loop();
        std::lock_guard lock(mu);
        end_ns = steady_now_ns();
        done_cv.notify_all();
      });
    } else {
      {
        std::lock_guard lock(mu);
        for (std::size_t i = 0; i < nodes.size(); ++i)
          if (nodes[i].opened && !nodes[i].source) schedule(static_cast<int>(i));
      }
      int workers =
          options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
      for (int w = 0; w < workers; ++w) threads.emplace_back([this] { worker_loop(); });
      for (std::size_t i = 0; i < nodes.size(); ++i)
        if (nodes[i].opened && nodes[i].source) threads.emplace_back([this, i] { source_loop(static_cast<int>(i)); });
    }
    // The calling thread watches: stop requests, duration, periodic stats.
    auto next_stats = std::chrono::steady_clock::now() + std::chrono::duration<double>(options.stats_interval_s);
    {
      std::unique_lock lock(mu);
      for (;;) {
        tell_ended(lock);
        bool all_done = finished_count == static_cast<int>(nodes.size());
        if (all_done || aborted || (options.deterministic && end_ns.load() != 0)) break;
        done_cv.wait_for(lock, std::chrono::milliseconds(20));
        bool external = options.external_stop && options.external_stop->load();
        bool timed_out = options.duration_s >= 0 && (steady_now_ns() - start_ns.load()) >= options.duration_s * 1e9;
        if ((external || timed_out) && !stop_.load()) {
          stop_.store(true);
          room_cv.notify_all();
        }
        if (options.stats_interval_s > 0 && options.on_stats && std::chrono::steady_clock::now() >= next_stats) {
          lock.unlock();
          options.on_stats(format_stats_table(collect(), elapsed()));
          lock.lock();
          next_stats += std::chrono::duration<double>(options.stats_interval_s);
        }
      }
      work_cv.notify_all();
      room_cv.notify_all();
    }
    for (auto& t : threads) t.join();
    {
      std::unique_lock lock(mu);
      tell_ended(lock);
    }
    if (end_ns.load() == 0) end_ns = steady_now_ns();
    close_nodes();
    std::lock_guard lock(mu);
    for (auto& n : nodes)
      for (auto& in : n.inputs) {
        while (!in.queue.empty()) in.queue.pop();
        in.side_latest.reset();
      }
    return failure;
  }

  // Calls inputs_ended() of the nodes that finished since the last call; `lock` holds mu.
  void tell_ended(std::unique_lock<std::mutex>& lock) {
    while (!ended.empty()) {
      int index = ended.back();
      ended.pop_back();
      lock.unlock();
      nodes[static_cast<std::size_t>(index)].node->inputs_ended();
      lock.lock();
    }
  }

  std::vector<const NodeStats*> collect() const {
    std::vector<const NodeStats*> out;
    for (int i : topo)
      if (nodes[static_cast<std::size_t>(i)].node) out.push_back(nodes[static_cast<std::size_t>(i)].stats.get());
    return out;
  }

  double elapsed() const {
    int64_t end = end_ns.load();
    const int64_t start = start_ns.load();
    if (start == 0) return 0.0;
    return static_cast<double>((end ? end : steady_now_ns()) - start) / 1e9;
  }
};

Executor::Executor(const ResolvedGraph& graph, const Registry& registry, ExecutorOptions options)
    : impl_(std::make_unique<Impl>(graph, registry, std::move(options))) {
  impl_->build();
}

Executor::~Executor() { impl_->close_nodes(); }

Status Executor::open() {
  Status s = impl_->open_nodes();
  if (!s.ok()) impl_->close_nodes();
  return s;
}

Status Executor::run() { return impl_->run(); }

void Executor::request_stop() {
  impl_->stop_.store(true);
  std::lock_guard lock(impl_->mu);
  impl_->room_cv.notify_all();
}

std::vector<const NodeStats*> Executor::stats() const { return impl_->collect(); }

const NodeStats* Executor::stats(const std::string& node) const {
  for (const auto& n : impl_->nodes)
    if (n.slot.name == node) return n.stats.get();
  return nullptr;
}

std::string Executor::stats_table() const { return format_stats_table(impl_->collect(), impl_->elapsed()); }
std::string Executor::stats_json() const { return format_stats_json(impl_->collect(), impl_->elapsed()); }
double Executor::elapsed_s() const { return impl_->elapsed(); }

Node* Executor::node(const std::string& name) const {
  for (const auto& n : impl_->nodes)
    if (n.slot.name == name) return n.node.get();
  return nullptr;
}

Status Executor::add_tap(const std::string& node, const std::string& port, Tap tap) {
  for (auto& n : impl_->nodes) {
    if (n.slot.name != node) continue;
    const int k = n.resolved->contract.output_index(port);
    if (k < 0)
      return Status::error("node '" + node + "' (" + n.resolved->decl.plugin + ") has no output '" + port + "'");
    n.taps[static_cast<std::size_t>(k)].push_back(std::move(tap));
    return {};
  }
  return Status::error("no node '" + node + "'");
}

Status Executor::inject(const std::string& node, const std::string& input, MessagePtr message) {
  for (auto& n : impl_->nodes) {
    if (n.slot.name != node) continue;
    const int k = n.resolved->contract.input_index(input);
    if (k < 0)
      return Status::error("node '" + node + "' (" + n.resolved->decl.plugin + ") has no input '" + input + "'");
    const auto& port = n.resolved->contract.inputs()[static_cast<std::size_t>(k)];
    if (port.kind != InputKind::kSide)
      return Status::error("input '" + node + "." + input + "' is not a side input: only its edge feeds it");
    if (message && port.type != "any" && message->type_name() != port.type)
      return Status::error("input '" + node + "." + input + "' takes " + port.type + ", not " +
                           std::string(message->type_name()));
    std::lock_guard lock(impl_->mu);
    InputRt& in = n.inputs[static_cast<std::size_t>(k)];
    bump(in.stats->received);
    in.side_latest = std::move(message);
    return {};
  }
  return Status::error("no node '" + node + "'");
}

const ResolvedGraph& Executor::graph() const { return impl_->graph; }

}  // namespace saccade
