#include <algorithm>
#include <sstream>

#include "recognition.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::classifier;

class ClassifierNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static Contract contract() {
    return Contract("Recognises what the fovea sees: a feature vector from the retina (the model's recipe: levels, "
                    "features, size), a multilayer perceptron trained by backpropagation (OpenCV ANN_MLP, made by "
                    "'saccade train'), and the paper's three outcomes from thresholds.")
        .input<Retina>("retina", "the retina whose fovea is classified")
        .output<Classification>("result", "class scores, the best class, the outcome and the region looked at")
        .output<Region>("target", "when classified (or probable, with target_when=probable): the fovea's region and the "
                                  "class, for the fovea's top-down target")
        .required_string("model", "model file written by 'saccade train' (network, feature recipe, class names)")
        .param_double("classified", 0.7, 0.0, 1.0, "best score at least this (and ahead by 'margin'): classified")
        .param_double("margin", 0.2, 0.0, 1.0, "how far the best score must lead the second for 'classified'")
        .param_double("probable", 0.4, 0.0, 1.0, "best score at least this: probable; below: not classified")
        .param_enum("target_when", "classified", {"classified", "probable"},
                    "the weakest outcome that still produces a 'target'")
        .param_string("target_classes", "", "classes that produce a 'target' (comma-separated; empty: every class)")
        .param_string("levels", "", "if given, must match the model's levels (0 = the fovea), else the model's are used")
        .param_string("features", "", "if given, must match the model's features, else the model's are used");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    retina_ = ctx.input<Retina>("retina");
    result_out_ = ctx.output<Classification>("result");
    target_out_ = ctx.output<Region>("target");
    std::string error;
    const std::string path = p.get_string("model");
    model_ = Model::load(path, &error);
    if (!model_) return Status::error(error);
    // The graph may state the recipe it expects: a model made with another is refused.
    if (const std::string levels = p.get_string("levels"); !levels.empty()) {
      auto parsed = parse_levels(levels, &error);
      if (!parsed) return Status::error(error);
      if (*parsed != model_->recipe.levels)
        return Status::error("model '" + path + "' was trained on " + model_->recipe.describe() +
                             "; the graph asks for levels " + levels);
    }
    if (const std::string features = p.get_string("features"); !features.empty()) {
      auto parsed = parse_features(features, &error);
      if (!parsed) return Status::error(error);
      if (*parsed != model_->recipe.features)
        return Status::error("model '" + path + "' was trained on " + model_->recipe.describe() +
                             "; the graph asks for features " + features);
    }
    if (const std::string wanted = p.get_string("target_classes"); !wanted.empty()) {
      std::stringstream in(wanted);
      std::string name;
      while (std::getline(in, name, ',')) {
        auto it = std::find(model_->classes->begin(), model_->classes->end(), name);
        if (it == model_->classes->end())
          return Status::error("target_classes: the model has no class '" + name + "'");
        target_classes_.push_back(static_cast<int>(it - model_->classes->begin()));
      }
    }
    target_when_probable_ = p.get_string("target_when") == "probable";
    thresholds_.classified = p.get_double("classified");
    thresholds_.margin = p.get_double("margin");
    thresholds_.probable = p.get_double("probable");
    if (thresholds_.probable > thresholds_.classified) return Status::error("probable must not exceed classified");
    extractor_ = std::make_unique<FeatureExtractor>(model_->recipe);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(retina_);
    if (std::string e = extractor_->extract(*retina, row_); !e.empty()) return Status::error(e);
    auto result = ctx.make(result_out_);
    model_->scores(row_, result->scores);
    int best = -1;
    result->outcome = decide(result->scores, thresholds_, &best);
    result->best = best;
    result->score = best >= 0 ? result->scores[static_cast<std::size_t>(best)] : 0.0;
    result->classes = model_->classes;
    result->region = extractor_->region(*retina);
    result->camera_id = retina->camera_id;
    const bool wanted = target_classes_.empty() ||
                        std::find(target_classes_.begin(), target_classes_.end(), best) != target_classes_.end();
    const bool strong = result->outcome == Classification::Outcome::kClassified ||
                        (target_when_probable_ && result->outcome == Classification::Outcome::kProbable);
    if (strong && wanted) {
      auto target = ctx.make(target_out_);
      const cv::Rect r = retina->geometry.back().region;
      target->center = cv::Point2d(r.x + r.width / 2.0, r.y + r.height / 2.0);
      target->size = cv::Size2d(r.size());
      target->score = result->score;
      target->label = std::string(result->label());
      target->camera_id = retina->camera_id;
      ctx.emit(target_out_, std::move(target));
    }
    ctx.emit(result_out_, std::move(result));
    return {};
  }

 private:
  InputHandle<Retina> retina_;
  OutputHandle<Classification> result_out_;
  OutputHandle<Region> target_out_;
  std::unique_ptr<Model> model_;
  std::unique_ptr<FeatureExtractor> extractor_;
  Thresholds thresholds_;
  std::vector<int> target_classes_;
  bool target_when_probable_ = false;
  cv::Mat row_;
};

}  // namespace

SACCADE_PLUGIN("classifier", ClassifierNode)
