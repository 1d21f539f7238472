// The guide's example (docs/guide.md): a whole plugin, one input, one output, two parameters.
#include <opencv2/imgproc.hpp>

#include "saccade/plugin.hpp"

struct ThresholdConfig {  // the algorithm's settings; their defaults live here, once
  double level = 128;
  bool invert = false;
};
class Threshold final : public saccade::Node {
 public:
  static constexpr const char* kName = "threshold";  // the node type is "example.threshold"
  static constexpr saccade::In<saccade::Retina> kRetina{"retina", "gray retina"};
  static constexpr saccade::Out<saccade::Retina> kBinary{"binary", "255 where brighter than level, else 0"};
  static void bind(saccade::ParamBinder<ThresholdConfig>& b) {
    b.field("level", {0, 255}, "gray level", &ThresholdConfig::level)
        .field("invert", "255 where darker instead", &ThresholdConfig::invert);
  }
  static saccade::Contract contract() {
    return saccade::Contract("A binary retina by a gray threshold.").ports(kRetina, kBinary).params(&bind);
  }
  saccade::Status open(saccade::OpenContext& ctx) override {
    config_ = ctx.config(&bind);
    return {};
  }
  saccade::Status process(saccade::ProcessContext& ctx) override {  // no allocation in steady state, no throw
    auto in = ctx.get(kRetina);
    auto out = ctx.make(kBinary);  // pooled, stamped with the input's time and frame id
    out->geometry = in->geometry, out->source_size = in->source_size, out->fovea = in->fovea;
    out->levels.resize(in->levels.size());
    const int type = config_.invert ? cv::THRESH_BINARY_INV : cv::THRESH_BINARY;
    for (std::size_t k = 0; k < in->levels.size(); ++k)
      cv::threshold(in->levels[k], out->levels[k], config_.level, 255, type);
    ctx.emit(kBinary, std::move(out));
    return {};
  }
 private:
  ThresholdConfig config_;
};
SACCADE_PLUGIN("example", Threshold)
