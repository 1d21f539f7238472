#include <algorithm>
#include <sstream>

#include "recognition.hpp"
#include "saccade/log.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::classifier;

// The classifier node's parameters besides the model file.
struct ClassifierConfig {
  Thresholds thresholds;
  bool target_when_probable = false;  // else only 'classified' gives a target
  std::string target_classes;         // comma-separated; empty: every class
  std::string levels, features;       // empty: the model's
};

class ClassifierNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<Retina> kRetina{"retina", "the retina whose fovea is classified"};
  static constexpr Out<Classification> kResult{"result",
                                               "class scores, the best class, the outcome and the region looked at"};
  static constexpr Out<Region> kTarget{"target",
                                       "when classified (or probable, with target_when=probable): the "
                                       "fovea's region and the class, for the fovea's top-down target"};

  static void bind(ParamBinder<ClassifierConfig>& b) {
    using C = ClassifierConfig;
    using T = Thresholds;
    b.field("classified", {0, 1}, "best score at least this (and ahead by 'margin'): classified", &C::thresholds,
            &T::classified)
        .field("margin", {0, 1}, "how far the best score must lead the second for 'classified'", &C::thresholds,
               &T::margin)
        .field("probable", {0, 1}, "best score at least this: probable; below: not classified", &C::thresholds,
               &T::probable)
        .field("target_when", {{"classified", false}, {"probable", true}},
               "the weakest outcome that still produces a 'target'", &C::target_when_probable)
        .field("target_classes", "classes that produce a 'target' (comma-separated; empty: every class)",
               &C::target_classes)
        .field("levels", "if given, must match the model's levels (0 = the fovea), else the model's are used",
               &C::levels)
        .field("features", "if given, must match the model's features, else the model's are used", &C::features);
  }

  static Contract contract() {
    return Contract(
               "Recognises what the fovea sees: a feature vector from the retina (the model's recipe: levels, "
               "features, size), a multilayer perceptron trained by backpropagation (OpenCV ANN_MLP, made by "
               "'saccade train'), and the paper's three outcomes from thresholds.")
        .ports(kRetina, kResult, kTarget)
        .required_string("model", "model file written by 'saccade train' (network, feature recipe, class names)")
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    const ClassifierConfig c = ctx.config(&bind);
    const std::string path = ctx.params().get_string("model");
    auto model = Model::load(path);
    if (!model.ok()) return model.status();
    model_ = std::move(model).value();
    // The graph may state the recipe it expects: a model made with another is refused.
    if (!c.levels.empty()) {
      auto parsed = parse_levels(c.levels);
      if (!parsed.ok()) return parsed.status();
      if (*parsed != model_->recipe.levels)
        return Status::error("model '" + path + "' was trained on " + model_->recipe.describe() +
                             "; the graph asks for levels " + c.levels);
    }
    if (!c.features.empty()) {
      auto parsed = parse_features(c.features);
      if (!parsed.ok()) return parsed.status();
      if (*parsed != model_->recipe.features)
        return Status::error("model '" + path + "' was trained on " + model_->recipe.describe() +
                             "; the graph asks for features " + c.features);
    }
    if (!c.target_classes.empty()) {
      std::stringstream in(c.target_classes);
      std::string name;
      while (std::getline(in, name, ',')) {
        auto it = std::find(model_->classes->begin(), model_->classes->end(), name);
        if (it == model_->classes->end()) return Status::error("target_classes: the model has no class '" + name + "'");
        target_classes_.push_back(static_cast<int>(it - model_->classes->begin()));
      }
    }
    target_when_probable_ = c.target_when_probable;
    thresholds_ = c.thresholds;
    if (thresholds_.probable > thresholds_.classified) return Status::error("probable must not exceed classified");
    extractor_ = std::make_unique<FeatureExtractor>(model_->recipe);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(kRetina);
    if (Status s = extractor_->extract(*retina, row_); !s.ok()) return s;
    auto result = ctx.make(kResult);
    model_->scores(row_, result->scores);
    int best = -1;
    result->outcome = decide(result->scores, thresholds_, &best);
    result->best = best;
    result->score = best >= 0 ? result->scores[static_cast<std::size_t>(best)] : 0.0;
    result->classes = model_->classes;
    result->roi = extractor_->region(*retina);
    result->camera_id = retina->camera_id;
    const bool wanted = target_classes_.empty() ||
                        std::find(target_classes_.begin(), target_classes_.end(), best) != target_classes_.end();
    const bool strong = result->outcome == Classification::Outcome::kClassified ||
                        (target_when_probable_ && result->outcome == Classification::Outcome::kProbable);
    if (strong && wanted) {
      auto target = ctx.make(kTarget);
      const cv::Rect r = retina->geometry.back().region;
      target->center = cv::Point2d(r.x + r.width / 2.0, r.y + r.height / 2.0);
      target->size = cv::Size2d(r.size());
      target->score = result->score;
      target->label.assign(result->label());  // (into a reused message's buffer)
      target->camera_id = retina->camera_id;
      ctx.emit(kTarget, std::move(target));
    }
    ctx.emit(kResult, std::move(result));
    return {};
  }

 private:
  std::unique_ptr<Model> model_;
  std::unique_ptr<FeatureExtractor> extractor_;
  Thresholds thresholds_;
  std::vector<int> target_classes_;
  bool target_when_probable_ = false;
  cv::Mat row_;
};

struct TruthLabelConfig {
  std::string inside = "target";
  std::string outside = "background";
};

// Labels what the fovea sees from a ground truth (a synthetic scene's): the
// label source of a training graph.
class TruthLabel final : public Node {
 public:
  static constexpr const char* kName = "truth_label";
  static constexpr In<Retina> kRetina{"retina", "the retina whose fovea is labelled"};
  static constexpr In<Region> kTruth{
      "truth", "the object's true place in the frame (e.g. capture.synthetic's truth); sync with retina"};
  static constexpr Out<Region> kLabel{"label", "the fovea's region with the label"};

  static void bind(ParamBinder<TruthLabelConfig>& b) {
    b.field("inside", "label when the object's centre is in the fovea", &TruthLabelConfig::inside)
        .field("outside", "label otherwise ('-': emit no label)", &TruthLabelConfig::outside);
  }
  static Contract contract() {
    return Contract(
               "Says what the fovea sees from a ground-truth region: 'inside' when the truth's centre lies in "
               "the fovea's region, else 'outside'. The label source of a training graph (classifier.collect).")
        .ports(kRetina, kTruth, kLabel)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    config_ = ctx.config(&bind);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(kRetina);
    auto truth = ctx.get(kTruth);
    const cv::Rect fovea = retina->geometry.back().region;
    const bool in = fovea.contains(cv::Point(static_cast<int>(truth->center.x), static_cast<int>(truth->center.y)));
    auto label = ctx.make(kLabel);
    label->center = cv::Point2d(fovea.x + fovea.width / 2.0, fovea.y + fovea.height / 2.0);
    label->size = cv::Size2d(fovea.size());
    label->label = in ? config_.inside : config_.outside;
    ctx.emit(kLabel, std::move(label));
    return {};
  }

 private:
  TruthLabelConfig config_;
};

// Collects labelled feature rows from a running graph for 'saccade train
// --samples': the retina's vector by the recipe, the label from another node.
// The collect node's recipe as written (levels and features as text) and its sampling.
struct CollectConfig {
  std::string levels = "0";
  std::string features = "gray,grad_hist";
  FeatureRecipe recipe;  // its size; levels and features come from the text above
  int64_t every = 1;
};

class Collect final : public Node {
 public:
  static constexpr const char* kName = "collect";
  static constexpr In<Retina> kRetina{"retina", "the retina whose fovea is sampled"};
  static constexpr In<Region> kLabel{
      "label", "what the fovea sees: the label text names the class ('' or '-': skip); sync with retina"};

  static void bind(ParamBinder<CollectConfig>& b) {
    using C = CollectConfig;
    b.field("levels", "retina levels of the vector, 0 = the fovea", &C::levels)
        .field("features", "gray, grad_hist and/or filter-bank maps", &C::features)
        .field("size", "each map reduced to WxH (grad_hist: its cell grid)", &C::recipe, &FeatureRecipe::size)
        .field("every", {1, 1000000}, "keep one frame in N", &C::every);
  }
  static Contract contract() {
    return Contract(
               "Collects training samples from a graph run: the fovea's feature vector (by the recipe) with the "
               "label a label source gives for the same frame; written at the end for 'saccade train --samples'.")
        .ports(kRetina, kLabel)
        .required_string("out", "samples file to write (OpenCV FileStorage)")
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    const CollectConfig c = ctx.config(&bind);
    out_path_ = ctx.params().get_string("out");
    auto levels = parse_levels(c.levels);
    if (!levels.ok()) return levels.status();
    auto features = parse_features(c.features);
    if (!features.ok()) return features.status();
    samples_.recipe = c.recipe;
    samples_.recipe.levels = std::move(levels).value();
    samples_.recipe.features = std::move(features).value();
    every_ = c.every;
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(kRetina);
    auto label = ctx.get(kLabel);
    if (retina->frame_id % every_ != 0 || label->label.empty() || label->label == "-") {
      ++skipped_;
      return {};
    }
    if (!extractor_) {
      // The retina's shape becomes part of the recipe.
      samples_.recipe.retina_levels = static_cast<int>(retina->levels.size());
      samples_.recipe.level_size = retina->levels.empty() ? cv::Size() : retina->levels[0].size();
      if (Status s = samples_.recipe.check(); !s.ok()) return s;
      extractor_ = std::make_unique<FeatureExtractor>(samples_.recipe);
    }
    if (Status s = extractor_->extract(*retina, row_); !s.ok()) return s;
    auto it = std::find(samples_.classes.begin(), samples_.classes.end(), label->label);
    if (it == samples_.classes.end()) it = samples_.classes.insert(samples_.classes.end(), label->label);
    samples_.x.push_back(row_);
    samples_.y.push_back(static_cast<int>(it - samples_.classes.begin()));
    return {};
  }
  void close() override {
    if (samples_.x.empty()) return;
    if (Status s = samples_.save(out_path_); !s.ok()) log().error("classifier.collect: {}", s.message());
  }

 private:
  std::string out_path_;
  SampleSet samples_;
  std::unique_ptr<FeatureExtractor> extractor_;
  cv::Mat row_;
  int64_t every_ = 1, skipped_ = 0;
};

}  // namespace

SACCADE_PLUGIN("classifier", ClassifierNode, TruthLabel, Collect)
