// An out-of-tree plugin: one node, hello.invert, that turns an 8-bit image into
// its negative (level - pixel). Built with saccade_add_plugin() against an
// installed saccade (CMakeLists.txt beside it).
#include <atomic>

#include <opencv2/core.hpp>

#include "saccade/plugin.hpp"
#include "saccade/stats.hpp"  // saccade::bump

namespace {

struct InvertConfig {  // the algorithm's settings; their defaults live here, once
  int level = 255;
};

class Invert final : public saccade::Node {
 public:
  static constexpr const char* kName = "invert";  // the node type is "hello.invert"
  static constexpr saccade::In<saccade::Image> kImage{"image", "an 8-bit image"};
  static constexpr saccade::Out<saccade::Image> kInverted{"inverted", "level - pixel, saturated at 0"};
  static void bind(saccade::ParamBinder<InvertConfig>& b) {
    b.field("level", {0, 255}, "the value black becomes", &InvertConfig::level);
  }
  static saccade::Contract contract() {
    return saccade::Contract("The negative of an 8-bit image.").ports(kImage, kInverted).params(&bind);
  }
  saccade::Status open(saccade::OpenContext& ctx) override {
    config_ = ctx.config(&bind);
    skipped_ = &ctx.counter("skipped");  // frames that are not 8-bit, shown in --stats
    return {};
  }
  saccade::Status process(saccade::ProcessContext& ctx) override {
    auto in = ctx.get(kImage);
    if (in->mat.depth() != CV_8U) {
      saccade::bump(*skipped_);
      return {};
    }
    auto out = ctx.make(kInverted);  // pooled, stamped with the input's time and frame id
    out->camera_id = in->camera_id;
    cv::subtract(cv::Scalar::all(config_.level), in->mat, out->mat);
    ctx.emit(kInverted, std::move(out));
    return {};
  }

 private:
  InvertConfig config_;
  std::atomic<uint64_t>* skipped_ = nullptr;
};

}  // namespace

SACCADE_PLUGIN("hello", Invert)
