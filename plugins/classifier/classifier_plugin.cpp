#include <algorithm>
#include <sstream>

#include "recognition.hpp"
#include "saccade/log.hpp"
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

// Labels what the fovea sees from a ground truth (a synthetic scene's): the
// label source of a training graph.
class TruthLabel final : public Node {
 public:
  static constexpr const char* kName = "truth_label";
  static Contract contract() {
    return Contract("Says what the fovea sees from a ground-truth region: 'inside' when the truth's centre lies in "
                    "the fovea's region, else 'outside'. The label source of a training graph (classifier.collect).")
        .input<Retina>("retina", "the retina whose fovea is labelled")
        .input<Region>("truth", "the object's true place in the frame (e.g. capture.synthetic's truth); sync with retina")
        .output<Region>("label", "the fovea's region with the label")
        .param_string("inside", "target", "label when the object's centre is in the fovea")
        .param_string("outside", "background", "label otherwise ('-': emit no label)");
  }
  Status open(OpenContext& ctx) override {
    retina_ = ctx.input<Retina>("retina");
    truth_ = ctx.input<Region>("truth");
    out_ = ctx.output<Region>("label");
    inside_ = ctx.params().get_string("inside");
    outside_ = ctx.params().get_string("outside");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(retina_);
    auto truth = ctx.get(truth_);
    const cv::Rect fovea = retina->geometry.back().region;
    const bool in = fovea.contains(cv::Point(static_cast<int>(truth->center.x), static_cast<int>(truth->center.y)));
    auto label = ctx.make(out_);
    label->center = cv::Point2d(fovea.x + fovea.width / 2.0, fovea.y + fovea.height / 2.0);
    label->size = cv::Size2d(fovea.size());
    label->label = in ? inside_ : outside_;
    ctx.emit(out_, std::move(label));
    return {};
  }

 private:
  InputHandle<Retina> retina_;
  InputHandle<Region> truth_;
  OutputHandle<Region> out_;
  std::string inside_, outside_;
};

// Collects labelled feature rows from a running graph for 'saccade train
// --samples': the retina's vector by the recipe, the label from another node.
class Collect final : public Node {
 public:
  static constexpr const char* kName = "collect";
  static Contract contract() {
    return Contract("Collects training samples from a graph run: the fovea's feature vector (by the recipe) with the "
                    "label a label source gives for the same frame; written at the end for 'saccade train --samples'.")
        .input<Retina>("retina", "the retina whose fovea is sampled")
        .input<Region>("label", "what the fovea sees: the label text names the class ('' or '-': skip); sync with retina")
        .required_string("out", "samples file to write (OpenCV FileStorage)")
        .param_string("levels", "0", "retina levels of the vector, 0 = the fovea")
        .param_string("features", "gray,grad_hist", "gray, grad_hist and/or filter-bank maps")
        .param_size("size", {8, 6}, "each map reduced to WxH (grad_hist: its cell grid)")
        .param_int("every", 1, 1, 1000000, "keep one frame in N");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    retina_ = ctx.input<Retina>("retina");
    label_ = ctx.input<Region>("label");
    out_path_ = p.get_string("out");
    std::string error;
    auto levels = parse_levels(p.get_string("levels"), &error);
    if (!levels) return Status::error(error);
    auto features = parse_features(p.get_string("features"), &error);
    if (!features) return Status::error(error);
    samples_.recipe.levels = *levels;
    samples_.recipe.features = *features;
    samples_.recipe.size = p.get_size("size");
    every_ = p.get_int("every");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(retina_);
    auto label = ctx.get(label_);
    if (retina->frame_id % every_ != 0 || label->label.empty() || label->label == "-") {
      ++skipped_;
      return {};
    }
    if (!extractor_) {
      // The retina's shape becomes part of the recipe.
      samples_.recipe.retina_levels = static_cast<int>(retina->levels.size());
      samples_.recipe.level_size = retina->levels.empty() ? cv::Size() : retina->levels[0].size();
      if (std::string e = samples_.recipe.check(); !e.empty()) return Status::error(e);
      extractor_ = std::make_unique<FeatureExtractor>(samples_.recipe);
    }
    if (std::string e = extractor_->extract(*retina, row_); !e.empty()) return Status::error(e);
    auto it = std::find(samples_.classes.begin(), samples_.classes.end(), label->label);
    if (it == samples_.classes.end()) it = samples_.classes.insert(samples_.classes.end(), label->label);
    samples_.x.push_back(row_);
    samples_.y.push_back(static_cast<int>(it - samples_.classes.begin()));
    return {};
  }
  void close() override {
    if (samples_.x.empty()) return;
    if (std::string e = samples_.save(out_path_); !e.empty()) log().error("classifier.collect: {}", e);
  }

 private:
  InputHandle<Retina> retina_;
  InputHandle<Region> label_;
  std::string out_path_;
  SampleSet samples_;
  std::unique_ptr<FeatureExtractor> extractor_;
  cv::Mat row_;
  int64_t every_ = 1, skipped_ = 0;
};

}  // namespace

SACCADE_PLUGIN("classifier", ClassifierNode, TruthLabel, Collect)
