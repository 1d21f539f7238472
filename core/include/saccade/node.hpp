#pragma once
// What a plugin author implements: a Node with open / process / close.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "saccade/contract.hpp"
#include "saccade/message.hpp"
#include "saccade/pool.hpp"
#include "saccade/status.hpp"

namespace saccade {

template <class T>
struct InputHandle {
  int index = -1;
};
template <class T>
struct OutputHandle {
  int index = -1;
};

// Receives what a node emits; the executor and the test harness implement it.
class EmitSink {
 public:
  virtual ~EmitSink();
  virtual void emit(int output, MessagePtr message) = 0;
  virtual bool stop_requested() const = 0;
  // Sleeps until the steady clock reaches `steady_ns`; false when woken by a
  // stop. On waking, the node's side inputs show their newest values.
  virtual bool sleep_until(int64_t steady_ns) = 0;
};

struct NodeStats;
class Histogram;

// Everything one node instance needs while it runs; owned by whoever runs it.
struct NodeSlot {
  std::string name;
  const Contract* contract = nullptr;
  const Params* params = nullptr;
  std::vector<MessagePtr> current;  // per input: what this call of process() sees
  std::vector<MessagePool> pools;   // per output
  std::vector<bool> input_connected;
  std::vector<bool> output_connected;
  const Message* trigger = nullptr;  // first trigger input that holds a message
  EmitSink* sink = nullptr;
  NodeStats* stats = nullptr;  // where the node's own counters go
  // Per input: the allocator the node asks its producers to make frames with.
  std::vector<cv::MatAllocator*> input_allocators;
  // Per output: the allocator a consumer asked for (nullptr: OpenCV's own).
  std::vector<cv::MatAllocator*> output_allocators;
};

int64_t steady_now_ns();

// Where a port constant stands in the node's contract; throws (a programming
// error: the node uses a constant its contract does not list) when absent.
std::size_t input_port_index(const NodeSlot& slot, const void* key, std::string_view name);
std::size_t output_port_index(const NodeSlot& slot, const void* key, std::string_view name);
template <class T, InputKind Kind>
std::size_t port_index(const NodeSlot& slot, const In<T, Kind>& port) {
  return input_port_index(slot, &port, port.name);
}
template <class T>
std::size_t port_index(const NodeSlot& slot, const Out<T>& port) {
  return output_port_index(slot, &port, port.name);
}

class OpenContext {
 public:
  explicit OpenContext(NodeSlot& slot) : slot_(&slot) {}
  const Params& params() const { return *slot_->params; }
  const std::string& node_name() const { return slot_->name; }

  template <class T>
  InputHandle<T> input(std::string_view name) const {
    return {checked_input(name, message_type_name<T>())};
  }
  template <class T>
  OutputHandle<T> output(std::string_view name) const {
    return {checked_output(name, message_type_name<T>())};
  }
  template <class T>
  bool connected(InputHandle<T> h) const {
    return slot_->input_connected[static_cast<std::size_t>(h.index)];
  }
  template <class T, InputKind Kind>
  bool connected(const In<T, Kind>& port) const {
    return slot_->input_connected[port_index(*slot_, port)];
  }
  template <class T>
  bool connected(const Out<T>& port) const {
    return slot_->output_connected[port_index(*slot_, port)];
  }
  // The node's parameters as its configuration struct (see Contract::params).
  template <class Config>
  Config config(void (*bind)(ParamBinder<Config>&)) const {
    Config config{};
    ParamBinder<Config> binder(params(), config);
    bind(binder);
    return config;
  }
  template <class T>
  bool connected(OutputHandle<T> h) const {
    return slot_->output_connected[static_cast<std::size_t>(h.index)];
  }
  // A counter of the node's own, shown by name in its stats (table and JSON)
  // next to the executor's counts; the same name gives the same counter. Valid
  // until the node is destroyed. Count with fetch_add where several threads may.
  std::atomic<uint64_t>& counter(std::string_view name) const;
  // A duration of the node's own (nanoseconds; Histogram::record from one
  // thread at a time), shown by name with its p50/p99/max and count.
  Histogram& timing(std::string_view name) const;
  // Asks the producers of input `h` to create their frames' pixels with
  // `allocator`: memory this node sends from without copying (dds.publish's
  // frame ring). Producers that can read it with ProcessContext::frame_allocator;
  // the allocator must outlive every Mat it made (the frame ring does).
  template <class T>
  void offer_frame_allocator(InputHandle<T> h, cv::MatAllocator* allocator) const {
    slot_->input_allocators[static_cast<std::size_t>(h.index)] = allocator;
  }
  template <class T, InputKind Kind>
  void offer_frame_allocator(const In<T, Kind>& port, cv::MatAllocator* allocator) const {
    slot_->input_allocators[port_index(*slot_, port)] = allocator;
  }

 private:
  int checked_input(std::string_view name, std::string_view type) const;
  int checked_output(std::string_view name, std::string_view type) const;
  NodeSlot* slot_;
};

class ProcessContext {
 public:
  explicit ProcessContext(NodeSlot& slot) : slot_(&slot) {}

  // The message on input `h` for this call, or nullptr (side input never fed,
  // optional input unconnected).
  template <class T>
  std::shared_ptr<const T> get(InputHandle<T> h) const {
    const MessagePtr& m = slot_->current[static_cast<std::size_t>(h.index)];
    if constexpr (std::is_same_v<T, Message>) {
      return m;
    } else {
      return std::static_pointer_cast<const T>(m);
    }
  }

  template <class T, InputKind Kind>
  std::shared_ptr<const T> get(const In<T, Kind>& port) const {
    return get(InputHandle<T>{static_cast<int>(port_index(*slot_, port))});
  }

  // A pooled message for output `h`, stamped with the trigger input's capture
  // time, origin and frame id.
  template <class T>
  std::shared_ptr<T> make(OutputHandle<T> h) {
    auto m = slot_->pools[static_cast<std::size_t>(h.index)].template acquire<T>();
    if (slot_->trigger != nullptr) m->stamp_from(*slot_->trigger);
    return m;
  }

  template <class T>
  std::shared_ptr<T> make(const Out<T>& port) {
    return make(OutputHandle<T>{static_cast<int>(port_index(*slot_, port))});
  }

  template <class T, class U>
  void emit(OutputHandle<T> h, std::shared_ptr<U> message) {
    static_assert(std::is_base_of_v<Message, U>);
    slot_->sink->emit(h.index, MessagePtr(std::move(message)));
  }
  template <class T, class U>
  void emit(const Out<T>& port, std::shared_ptr<U> message) {
    static_assert(std::is_base_of_v<T, U> || std::is_same_v<T, Message>, "a port emits the type it carries");
    emit(OutputHandle<T>{static_cast<int>(port_index(*slot_, port))}, std::move(message));
  }

  // The allocator a consumer of output `h` asked frames to be made with (see
  // OpenContext::offer_frame_allocator), or nullptr. A producer that supports
  // it sets it before create(): `image->mat.allocator = ctx.frame_allocator(out_)`;
  // the pool's recycling then never rewrites such a buffer in place.
  template <class T>
  cv::MatAllocator* frame_allocator(OutputHandle<T> h) const {
    const auto k = static_cast<std::size_t>(h.index);
    return k < slot_->output_allocators.size() ? slot_->output_allocators[k] : nullptr;
  }
  template <class T>
  cv::MatAllocator* frame_allocator(const Out<T>& port) const {
    return frame_allocator(OutputHandle<T>{static_cast<int>(port_index(*slot_, port))});
  }

  const Message* trigger() const { return slot_->trigger; }
  const std::string& node_name() const { return slot_->name; }
  bool stop_requested() const { return slot_->sink->stop_requested(); }
  bool sleep_until(int64_t steady_ns) { return slot_->sink->sleep_until(steady_ns); }

 private:
  NodeSlot* slot_;
};

class Node {
 public:
  virtual ~Node();
  // Reads parameters and allocates; a non-ok Status stops the graph before it runs.
  virtual Status open(OpenContext&) { return {}; }
  // Steady state: allocate nothing, throw nothing. A source returns
  // Status::end_of_stream() when it has nothing more.
  virtual Status process(ProcessContext& ctx) = 0;
  // Every trigger input has ended and process() will not be called again; soon
  // after, on another thread, before close(). A node that tells someone outside
  // the graph (a DDS bridge tells its readers) does it here, so that a peer
  // waiting for it can end while this graph is still running.
  virtual void inputs_ended() {}
  virtual void close() {}
};

}  // namespace saccade
