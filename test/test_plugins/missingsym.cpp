// A plugin that needs a symbol nobody provides: with RTLD_NOW the loader must
// refuse it at load time instead of crashing at the first call.
#include "saccade/plugin.hpp"

extern "C" int saccade_symbol_that_does_not_exist(int);

namespace {
class Broken final : public saccade::Node {
 public:
  static constexpr const char* kName = "broken";
  static saccade::Contract contract() { return saccade::Contract("never loads"); }
  saccade::Status process(saccade::ProcessContext&) override {
    return saccade_symbol_that_does_not_exist(1) ? saccade::Status() : saccade::Status::error("x");
  }
};
}  // namespace

SACCADE_PLUGIN("missingsym", Broken)
