// A well-formed plugin that counts its live nodes, for the lifetime tests.
#include <atomic>

#include "saccade/plugin.hpp"

extern "C" __attribute__((visibility("default"))) int saccade_good_live_nodes();
static std::atomic<int> g_live{0};
int saccade_good_live_nodes() { return g_live.load(); }

namespace {
class Echo final : public saccade::Node {
 public:
  static constexpr const char* kName = "echo";
  static saccade::Contract contract() {
    return saccade::Contract("test node").input<saccade::Message>("in", "x").output<saccade::Message>("out", "x");
  }
  Echo() { ++g_live; }
  ~Echo() override { --g_live; }
  saccade::Status open(saccade::OpenContext& ctx) override {
    in_ = ctx.input<saccade::Message>("in");
    out_ = ctx.output<saccade::Message>("out");
    return {};
  }
  saccade::Status process(saccade::ProcessContext& ctx) override {
    ctx.emit(out_, ctx.get(in_));
    return {};
  }

 private:
  saccade::InputHandle<saccade::Message> in_;
  saccade::OutputHandle<saccade::Message> out_;
};
}  // namespace

SACCADE_PLUGIN("good", Echo)
