// Helpers of the fault suite (test/faults): an operator who presses the head's
// reset once every drive is ready again after a hold.
#include "saccade/plugin.hpp"

class ResetWhenReady final : public saccade::Node {
 public:
  static constexpr const char* kName = "reset_when_ready";
  static constexpr saccade::In<saccade::JointTargets> kTargets{"targets", "the head's targets (their hold flag)"};
  static constexpr saccade::Out<saccade::Region> kReset{"reset", "one message per hold, for the head's reset"};
  static saccade::Contract contract() {
    return saccade::Contract("Emits once per hold of the head, as soon as the driver reports every drive ready again.")
        .ports(kTargets)
        .side_input<saccade::JointState>("state", "the driver's joint state")
        .ports(kReset);
  }
  saccade::Status open(saccade::OpenContext& ctx) override {
    state_ = ctx.input<saccade::JointState>("state");
    return {};
  }
  saccade::Status process(saccade::ProcessContext& ctx) override {
    auto targets = ctx.get(kTargets);
    if (!targets->hold) {
      pressed_ = false;
      return {};
    }
    auto state = ctx.get(state_);
    if (pressed_ || !state || !state->all_ready()) return {};
    pressed_ = true;
    auto reset = ctx.make(kReset);
    reset->label = "reset";
    ctx.emit(kReset, std::move(reset));
    return {};
  }

 private:
  saccade::InputHandle<saccade::JointState> state_;
  bool pressed_ = false;
};

SACCADE_PLUGIN("faultkit", ResetWhenReady)
