#include <opencv2/imgproc.hpp>

#include "retina.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::retina;

class RetinaNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static Contract contract() {
    return Contract("Multi-resolution retina (Algorithm 1): L levels of WxH, the innermost a crop of the fovea, "
                    "the outer ones five-point means over growing regions up to the whole frame.")
        .input<Image>("image", "8-bit gray or BGR frame")
        .side_input<Region>("fovea", "moves the fovea (its centre); the newest value is used")
        .output<Retina>("retina", "levels (0 outermost) with their geometry")
        .param_int("levels", 5, 1, 16, "number of levels")
        .param_size("size", {32, 24}, "size of every level")
        .param_enum("mode", "five_point", {"five_point", "area_mean"}, "the paper's five-point mean, or the exact cell mean")
        .param_point("fovea", std::nullopt, "initial fovea centre x,y in source pixels (default: the frame's centre)")
        .param_enum("channels", "same", {"same", "gray"}, "sample the frame as it comes, or convert colour to gray first");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    image_ = ctx.input<Image>("image");
    fovea_in_ = ctx.input<Region>("fovea");
    out_ = ctx.output<Retina>("retina");
    RetinaConfig config;
    config.levels = static_cast<int>(p.get_int("levels"));
    config.size = p.get_size("size");
    if (config.size.width < 3 || config.size.height < 3) return Status::error("size must be at least 3x3");
    config.mode = p.get_string("mode") == "area_mean" ? SamplingMode::kAreaMean : SamplingMode::kFivePoint;
    sampler_ = std::make_unique<RetinaSampler>(config);
    if (p.has("fovea")) initial_fovea_ = p.get_point("fovea");
    gray_ = p.get_string("channels") == "gray";
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto image = ctx.get(image_);
    const cv::Mat* frame = &image->mat;
    if (gray_ && frame->channels() == 3) {
      cv::cvtColor(*frame, gray_frame_, cv::COLOR_BGR2GRAY);
      frame = &gray_frame_;
    }
    if (std::string e = sampler_->check(*frame); !e.empty()) return Status::error(e);
    cv::Point2d fovea(frame->cols / 2.0, frame->rows / 2.0);
    if (initial_fovea_) fovea = *initial_fovea_;
    if (auto f = ctx.get(fovea_in_)) fovea = f->center;
    auto retina = ctx.make(out_);
    // A zero-copy DDS edge downstream: the levels are made in its frame ring, in one buffer.
    if (cv::MatAllocator* ring = ctx.frame_allocator(out_))
      create_together(ring, static_cast<std::size_t>(sampler_->config().levels), sampler_->config().size, frame->type(),
                      retina->levels);
    sampler_->sample(*frame, fovea, *retina);
    retina->camera_id = image->camera_id;
    retina->source = image;
    ctx.emit(out_, std::move(retina));
    return {};
  }

 private:
  InputHandle<Image> image_;
  InputHandle<Region> fovea_in_;
  OutputHandle<Retina> out_;
  std::unique_ptr<RetinaSampler> sampler_;
  std::optional<cv::Point2d> initial_fovea_;
  cv::Mat gray_frame_;
  bool gray_ = false;
};

}  // namespace

SACCADE_PLUGIN("retina", RetinaNode)
