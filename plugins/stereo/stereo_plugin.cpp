#include "retina_stereo.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::stereo;

class StereoNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static Contract contract() {
    return Contract("Disparity between a left and a right retina by normalized cross correlation, both ways, with a "
                    "left-right check, sub-pixel peaks and a confidence, coarse to fine across levels. Pair the inputs "
                    "with <sync inputs=\"left,right\"/>.")
        .input<Retina>("left", "left retina (8-bit gray)")
        .input<Retina>("right", "right retina, same level size; regions equal or shifted by whole level pixels")
        .output<FeatureMaps>("maps", "per level on the left geometry: disparity (source pixels, -1 invalid), "
                                     "disparity_rl (right->left, on the right geometry), confidence (NCC)")
        .param_int("window", 5, 3, 9, "NCC window side (odd: 3 or 5 in the paper)")
        .param_double("max_disparity", 256.0, 1.0, 4096.0, "largest disparity searched, source pixels")
        .param_double("min_score", 0.5, -1.0, 1.0, "matches whose NCC is below this are invalid")
        .param_double("min_texture", 2.0, 0.0, 128.0, "windows whose standard deviation is below this are not matched")
        .param_bool("coarse_to_fine", true, "search inner levels only around the outer level's result")
        .param_int("search_radius", 2, 0, 32, "coarse to fine: level pixels searched around the prediction")
        .param_bool("lr_check", true, "keep only matches the right->left search confirms")
        .param_double("lr_tolerance", 1.0, 0.0, 16.0, "left-right check tolerance, level pixels")
        .param_bool("subpixel", true, "refine the peak with a parabola")
        .param_bool("vergence", false,
                    "experimental software vergence: inner levels sample the right frame where the outer level "
                    "predicts the scene (right on synthetic pairs; not yet on Aloe's fovea level)");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    left_ = ctx.input<Retina>("left");
    right_ = ctx.input<Retina>("right");
    out_ = ctx.output<FeatureMaps>("maps");
    RetinaStereoConfig c;
    c.ncc.window = static_cast<int>(p.get_int("window"));
    if (c.ncc.window % 2 == 0) return Status::error("window must be odd");
    c.ncc.min_score = static_cast<float>(p.get_double("min_score"));
    c.ncc.min_texture = static_cast<float>(p.get_double("min_texture"));
    c.ncc.subpixel = p.get_bool("subpixel");
    c.max_disparity = p.get_double("max_disparity");
    c.coarse_to_fine = p.get_bool("coarse_to_fine");
    c.search_radius = static_cast<int>(p.get_int("search_radius"));
    c.left_right_check = p.get_bool("lr_check");
    c.lr_tolerance = static_cast<float>(p.get_double("lr_tolerance"));
    c.vergence = p.get_bool("vergence");
    stereo_ = std::make_unique<RetinaStereo>(c);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto l = ctx.get(left_);
    auto r = ctx.get(right_);
    if (std::string e = stereo_->run(*l, *r, levels_); !e.empty()) return Status::error(e);
    auto maps = ctx.make(out_);
    maps->retina = l;
    maps->set_layout({"disparity", "disparity_rl", "confidence"}, levels_.size());
    for (std::size_t k = 0; k < levels_.size(); ++k) {
      levels_[k].disparity.copyTo(maps->maps[0][k]);
      levels_[k].reverse.copyTo(maps->maps[1][k]);
      levels_[k].score.copyTo(maps->maps[2][k]);
    }
    ctx.emit(out_, std::move(maps));
    return {};
  }

 private:
  InputHandle<Retina> left_, right_;
  OutputHandle<FeatureMaps> out_;
  std::unique_ptr<RetinaStereo> stereo_;
  std::vector<LevelDisparity> levels_;
};

}  // namespace

SACCADE_PLUGIN("stereo", StereoNode)
