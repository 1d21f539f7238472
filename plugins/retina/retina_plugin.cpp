#include <opencv2/imgproc.hpp>

#include "retina.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::retina;

class RetinaNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<Image> kImage{"image", "8-bit gray or BGR frame"};
  static constexpr SideIn<Region> kFovea{"fovea", "moves the fovea (its centre); the newest value is used"};
  static constexpr Out<Retina> kRetina{"retina", "levels (0 outermost) with their geometry"};

  static void bind(ParamBinder<RetinaConfig>& b) {
    b.field("levels", {1, 16}, "number of levels", &RetinaConfig::levels)
        .field("size", "size of every level", &RetinaConfig::size)
        .field("mode", {{"five_point", SamplingMode::kFivePoint}, {"area_mean", SamplingMode::kAreaMean}},
               "the paper's five-point mean, or the exact cell mean", &RetinaConfig::mode);
  }

  static Contract contract() {
    return Contract("Multi-resolution retina (Algorithm 1): L levels of WxH, the innermost a crop of the fovea, "
                    "the outer ones five-point means over growing regions up to the whole frame.")
        .ports(kImage, kFovea, kRetina)
        .params(&bind)
        // Unbound: it has no default (the frame's centre), which a struct field cannot express.
        .param_point("fovea", std::nullopt, "initial fovea centre x,y in source pixels (default: the frame's centre)")
        .param_enum("channels", "same", {"same", "gray"}, "sample the frame as it comes, or convert colour to gray first");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    const RetinaConfig config = ctx.config(&bind);
    if (config.size.width < 3 || config.size.height < 3) return Status::error("size must be at least 3x3");
    sampler_ = std::make_unique<RetinaSampler>(config);
    if (p.has("fovea")) initial_fovea_ = p.get_point("fovea");
    gray_ = p.get_string("channels") == "gray";
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto image = ctx.get(kImage);
    const cv::Mat* frame = &image->mat;
    if (gray_ && frame->channels() == 3) {
      cv::cvtColor(*frame, gray_frame_, cv::COLOR_BGR2GRAY);
      frame = &gray_frame_;
    }
    if (std::string e = sampler_->check(*frame); !e.empty()) return Status::error(e);
    cv::Point2d fovea(frame->cols / 2.0, frame->rows / 2.0);
    if (initial_fovea_) fovea = *initial_fovea_;
    if (auto f = ctx.get(kFovea)) fovea = f->center;
    auto retina = ctx.make(kRetina);
    // A zero-copy DDS edge downstream: the levels are made in its frame ring, in one buffer.
    if (cv::MatAllocator* ring = ctx.frame_allocator(kRetina))
      create_together(ring, static_cast<std::size_t>(sampler_->config().levels), sampler_->config().size, frame->type(),
                      retina->levels);
    sampler_->sample(*frame, fovea, *retina);
    retina->camera_id = image->camera_id;
    retina->source = image;
    ctx.emit(kRetina, std::move(retina));
    return {};
  }

 private:
  std::unique_ptr<RetinaSampler> sampler_;
  std::optional<cv::Point2d> initial_fovea_;
  cv::Mat gray_frame_;
  bool gray_ = false;
};

}  // namespace

SACCADE_PLUGIN("retina", RetinaNode)
