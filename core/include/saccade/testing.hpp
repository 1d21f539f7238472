#pragma once
// Test one node in a few lines:
//   auto h = saccade::testing::NodeHarness::create(R"(<node plugin="filters.bank"/>)").value_or(nullptr);
//   ASSERT_NE(h, nullptr);
//   h->set("retina", retina);
//   ASSERT_TRUE(h->process().ok());
//   auto maps = h->last<saccade::FeatureMaps>("maps");
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "saccade/graph.hpp"
#include "saccade/node.hpp"
#include "saccade/registry.hpp"
#include "saccade/stats.hpp"

namespace saccade::testing {

// Registry over the default plugin folders, loaded once per process.
const Registry& default_registry();

class NodeHarness final : public EmitSink {
 public:
  // Builds and opens the node described by one <node> element (name optional);
  // the error (file:line messages) when it cannot.
  static Result<std::unique_ptr<NodeHarness>> create(const std::string& node_xml, const Registry* registry = nullptr);
  ~NodeHarness() override;

  // The message input `name` carries in the next process() call (nullptr clears it).
  void set(const std::string& input, MessagePtr message);
  // One call of the node's process(); inputs stay set until changed.
  Status process();
  // Everything emitted on `output` so far.
  const std::vector<MessagePtr>& outputs(const std::string& output) const;
  template <class T>
  std::shared_ptr<const T> last(const std::string& output) const {
    const auto& all = outputs(output);
    return all.empty() ? nullptr : std::dynamic_pointer_cast<const T>(all.back());
  }
  void clear_outputs();
  // What a consumer of `output` offers to make frames with (as the executor
  // passes a dds.publish's frame ring on): ProcessContext::frame_allocator.
  void set_frame_allocator(const std::string& output, cv::MatAllocator* allocator);
  // A counter the node registered at open (OpenContext::counter); throws if none.
  uint64_t counter(const std::string& name) const;
  // A timing the node registered at open (OpenContext::timing); throws if none.
  const Histogram& timing(const std::string& name) const;
  Node& node() { return *node_; }
  const ResolvedNode& resolved() const { return resolved_; }

  void emit(int output, MessagePtr message) override;
  bool stop_requested() const override { return false; }
  bool sleep_until(int64_t) override { return true; }

 private:
  NodeHarness() = default;
  ResolvedNode resolved_;
  NodeSlot slot_;
  NodeStats stats_;  // before node_: the node's counters outlive it
  std::shared_ptr<Node> node_;
  std::vector<std::vector<MessagePtr>> emitted_;
  bool opened_ = false;
};

// A process-wide store the util.record sink writes into, so a test can read what
// reached the end of a whole graph.
class Recorder {
 public:
  static Recorder& instance();
  void record(const std::string& key, MessagePtr message);
  std::vector<MessagePtr> get(const std::string& key) const;
  void clear();

 private:
  mutable std::mutex mu_;
  std::map<std::string, std::vector<MessagePtr>> messages_;
};

}  // namespace saccade::testing
