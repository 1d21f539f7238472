#include "kernels.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::filters;

std::vector<std::string> feature_choices() { return {kFeatureNames.begin(), kFeatureNames.end()}; }

class Bank final : public Node {
 public:
  static constexpr const char* kName = "bank";
  static constexpr In<Retina> kRetina{"retina", "8-bit gray retina"};
  static constexpr Out<FeatureMaps> kMaps{"maps", "the selected features per level, sharing the retina's geometry"};

  static void bind(ParamBinder<BankConfig>& b) {
    b.field("grad_threshold", {0, 1e6}, "grad_mask: Sobel magnitude above this is an edge", &BankConfig::grad_threshold)
        .field("ggrad_sigma", {0.3, 3}, "Gaussian gradient: sigma in level pixels", &BankConfig::ggrad_sigma)
        .field("ggrad_threshold", {0, 1e6}, "ggrad_mask: Gaussian-gradient magnitude above this is an edge",
               &BankConfig::ggrad_threshold)
        .field("border", {{"reflect101", Border::kReflect101}, {"replicate", Border::kReplicate}},
               "how pixels beyond a level's edge are read", &BankConfig::border);
  }

  static Contract contract() {
    return Contract(
               "The filter bank on every level of a retina, computed in fused passes: Gaussian 3x3, Sobel x/y, "
               "gradient magnitude/mask/direction, 4-neighbour Laplacian, LoG, Gaussian gradient x/y/magnitude/mask.")
        .ports(kRetina, kMaps)
        .param_flags("features", "gauss,sobel_x,sobel_y,grad_mag,grad_mask,grad_dir,laplacian,log", feature_choices(),
                     "features to compute (comma list, or all)")
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    BankConfig config = ctx.config(&bind);
    for (const auto& f : ctx.params().get_flags("features")) {
      int i = feature_index(f);
      config.wanted[static_cast<std::size_t>(i)] = true;
      selected_.push_back(i);
    }
    if (selected_.empty()) return Status::error("features selects nothing");
    bank_ = std::make_unique<FilterBank>(config);
    for (int i : selected_) names_.emplace_back(kFeatureNames[static_cast<std::size_t>(i)]);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(kRetina);
    if (retina->levels.empty()) return Status::error("retina has no levels");
    const cv::Mat& first = retina->levels.front();
    if (first.type() != CV_8UC1)
      return Status::error("expected 8-bit gray levels, got " + cv::typeToString(first.type()) +
                           " (set the retina's channels=gray or the capture's color=gray)");
    int r = gaussian_radius(bank_->config().ggrad_sigma);
    if (first.cols <= r || first.rows <= r)
      return Status::error("levels of " + std::to_string(first.cols) + "x" + std::to_string(first.rows) +
                           " are too small for ggrad_sigma (radius " + std::to_string(r) + ")");
    auto maps = ctx.make(kMaps);
    maps->retina = retina;
    maps->set_layout(names_, retina->levels.size());
    for (std::size_t level = 0; level < retina->levels.size(); ++level) {
      for (std::size_t i = 0; i < selected_.size(); ++i)
        std::swap(outs_[static_cast<std::size_t>(selected_[i])], maps->maps[i][level]);
      bank_->run(retina->levels[level], outs_);
      for (std::size_t i = 0; i < selected_.size(); ++i)
        std::swap(outs_[static_cast<std::size_t>(selected_[i])], maps->maps[i][level]);
    }
    ctx.emit(kMaps, std::move(maps));
    return {};
  }

 private:
  std::unique_ptr<FilterBank> bank_;
  std::vector<int> selected_;
  std::vector<std::string> names_;
  std::array<cv::Mat, kFeatureCount> outs_;
};

}  // namespace

SACCADE_PLUGIN("filters", Bank)
