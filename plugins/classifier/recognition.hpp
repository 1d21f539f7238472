#pragma once
// Recognition of what the fovea sees: a feature vector from chosen retina
// levels and filter-bank maps (the recipe), a multilayer perceptron trained by
// backpropagation (OpenCV's ANN_MLP, BACKPROP or RPROP), the model file that
// keeps the recipe and the class names with the network, and the decision
// with the paper's three outcomes.
#include <functional>
#include <ostream>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/ml.hpp>

#include "kernels.hpp"
#include "retina.hpp"
#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::classifier {

// Which parts of the retina form the vector. Levels count from the fovea
// (0 = the fovea, 1 = the level around it, ...); each feature is "gray" (the
// level itself), a filter-bank map ("grad_mag", "laplacian", ...), reduced to
// `size` by area means, or "grad_hist": per cell of a `size` grid, a histogram
// of gradient orientations (8 bins over 180 degrees, weighted by the Sobel
// magnitude, L2-normalised per cell, as HOG does). The vector is normalised
// to zero mean and unit deviation.
struct FeatureRecipe {
  std::vector<int> levels{0};
  std::vector<std::string> features{"gray", "grad_hist"};
  cv::Size size{8, 6};
  // The retina it was made for: a model is refused on a different one.
  int retina_levels = 5;
  cv::Size level_size{32, 24};

  static constexpr int kOrientationBins = 8;
  int length() const;
  std::string describe() const;
  // An error saying what is wrong with the recipe itself.
  Status check() const;
  // An error saying why `retina` cannot give this recipe's vector.
  Status check(const Retina& retina) const;
  void write(cv::FileStorage& fs) const;
  // The recipe a model or samples file keeps, or what is missing or wrong in it.
  static Result<FeatureRecipe> read(const cv::FileNode& node);
  bool operator==(const FeatureRecipe& o) const;
};

// "64,32" -> {64, 32} (non-negative); `what` names the list in the error.
Result<std::vector<int>> parse_int_list(const std::string& text, const std::string& what);
// "0,1" -> {0, 1}; "gray,grad_mag" -> names; or the error naming the bad text.
Result<std::vector<int>> parse_levels(const std::string& text);
Result<std::vector<std::string>> parse_features(const std::string& text);

class FeatureExtractor {
 public:
  explicit FeatureExtractor(FeatureRecipe recipe);
  // Fills `row` (its buffer reused) with the 1 x length CV_32F vector, or
  // returns the error saying why this retina cannot give it.
  Status extract(const Retina& retina, cv::Mat& row);
  // The source region the vector looked at: the outermost level used.
  cv::Rect region(const Retina& retina) const;
  const FeatureRecipe& recipe() const { return recipe_; }

 private:
  FeatureRecipe recipe_;
  filters::FilterBank bank_;
  std::array<cv::Mat, filters::kFeatureCount> maps_;
  cv::Mat resized_, reduced_, gray_;
  std::vector<float> histogram_;
};

// A picture of an object as the fovea would see it: scaled to fill the fovea
// (aspect kept), centred in a frame four levels wide with its border
// replicated, and sampled by the retina looking at it. How training images
// become retinas, the same path a graph's frames take.
void retina_of_view(const cv::Mat& image, retina::RetinaSampler& sampler, Retina& out, cv::Mat& frame);

struct TrainConfig {
  std::vector<int> hidden{128};
  int epochs = 20;
  enum class Method { kBackprop, kRprop } method = Method::kBackprop;
  double learning_rate = 0.01;  // backprop
  double momentum = 0.1;        // backprop
  uint64_t seed = 1;            // the order samples are presented in (ANN_MLP's initial weights are its own, fixed)
};

struct EpochReport {
  int epoch = 0;
  double train_accuracy = 0, validation_accuracy = 0;
};

// A network's forward pass as OpenCV's ANN_MLP::predict computes it (the
// inputs' and outputs' scaling, each layer's weights and bias, the symmetric
// sigmoid), one row at a time into buffers kept between rows: predict
// allocates on every call, which a classifier running on every frame cannot
// afford. Its outputs are predict's to float precision (its own order of the
// layers' sums; test ForwardPass.*).
class ForwardPass {
 public:
  // The pass of a trained network; or the error naming what it cannot compute
  // (an activation other than the symmetric sigmoid, which train() uses).
  // `written`: the network's serialisation (ANN_MLP::write's node, as a model
  // file holds it), the only place its activation's parameters are given;
  // when empty, one is made (writing every weight: tens of milliseconds).
  static Result<ForwardPass> of(const cv::ml::ANN_MLP& net, const cv::FileNode& written = {});
  // The weights of `net` again (more training, the same layers and
  // activation); or the error saying what does not fit.
  Status take_weights(const cv::ml::ANN_MLP& net);
  int inputs() const { return inputs_; }
  int outputs() const { return outputs_; }
  // `in`: inputs() values; `out`: outputs() values.
  void run(const float* in, float* out);

 private:
  std::vector<cv::Mat> layers_;         // each (inputs + 1) x outputs, CV_64F: the weights, the bias in the last row
  cv::Mat input_scale_, output_scale_;  // 1 x 2n CV_64F: each value's factor and offset
  double alpha_ = 0, beta_ = 0;         // the sigmoid beta (1 - e^(-alpha x)) / (1 + e^(-alpha x))
  int inputs_ = 0, outputs_ = 0;
  std::vector<double> values_, sums_;  // a layer's values and the next one's sums
};

struct Model {
  cv::Ptr<cv::ml::ANN_MLP> net;  // trained, and read and written, by OpenCV
  FeatureRecipe recipe;
  std::shared_ptr<const std::vector<std::string>> classes;
  // The network's evaluation (kept in step with `net` by train() and load();
  // its buffers make scores() usable by one thread at a time).
  mutable ForwardPass forward;

  // Scores per class in 0..1.
  void scores(const cv::Mat& row, std::vector<float>& out) const;
  // Network, recipe and class names in one OpenCV FileStorage file; the error
  // names the file.
  Status save(const std::string& path) const;
  // The model, or the error naming the file and what is wrong in it.
  static Result<std::unique_ptr<Model>> load(const std::string& path);
};

// Trains on rows of `x` (CV_32F) with labels 0..classes-1, one epoch at a time,
// calling `progress` after each.
Model train(const cv::Mat& x, const std::vector<int>& y, std::vector<std::string> classes, const FeatureRecipe& recipe,
            const TrainConfig& config, const cv::Mat& val_x, const std::vector<int>& val_y,
            const std::function<void(const EpochReport&)>& progress);

double accuracy(const Model& model, const cv::Mat& x, const std::vector<int>& y);
// Rows: truth, columns: prediction (CV_32S).
cv::Mat confusion(const Model& model, const cv::Mat& x, const std::vector<int>& y);

struct Thresholds {
  double classified = 0.7;  // best score at least this, and
  double margin = 0.2;      // ahead of the second by at least this: classified
  double probable = 0.4;    // best score at least this: probable; else not classified
};
Classification::Outcome decide(const std::vector<float>& scores, const Thresholds& t, int* best = nullptr);

// Labelled samples from a folder with one sub-folder per class of images or
// videos (every `video_step`-th frame); classes sorted by name. Appended to
// `out`; the error names the folder or file it could not use.
struct Dataset {
  std::vector<std::string> classes;
  std::vector<cv::Mat> images;  // 8-bit gray
  std::vector<int> labels;
};
Status load_folder(const std::string& root, int video_step, Dataset& out);

// Feature rows (CV_32F) of pictures of objects, each seen through a retina
// (retina_of_view) and the recipe, into `rows` (its buffer reused); or the
// error saying what is wrong.
Status features_of_views(const std::vector<cv::Mat>& images, const FeatureRecipe& recipe, cv::Mat& rows);

// What `saccade train` does: a folder per class -> a split (per class, the
// first 1 - validation of its files, sorted by name, train; the rest
// validates) -> training with per-epoch progress on `log` -> the validation
// confusion matrix -> the model file. The result, or the error that stopped it
// (a bad recipe or folder, no training samples, an unwritable model file).
struct FolderTraining {
  std::string data, out;
  FeatureRecipe recipe;
  TrainConfig train;
  double validation = 0.2;
  int video_step = 5;
  int report_every = 1;  // epochs between progress lines
};
struct TrainingResult {
  double validation_accuracy = 0;
  cv::Mat confusion;
  std::vector<std::string> classes;
};
Result<TrainingResult> train_folder(const FolderTraining& job, std::ostream& log);

// Labelled feature rows as a graph collects them (the classifier.collect node):
// the recipe they were made with, the class names, the rows and their labels.
struct SampleSet {
  FeatureRecipe recipe;
  std::vector<std::string> classes;
  cv::Mat x;
  std::vector<int> y;
  // Writes the samples file; the error names it.
  Status save(const std::string& path) const;
  // The samples a file holds, or the error naming the file and what does not fit.
  static Result<SampleSet> load(const std::string& path);
};
// The same split, training, report and model file from rows (job.data unused).
Result<TrainingResult> train_rows(const SampleSet& samples, const FolderTraining& job, std::ostream& log);

// The confusion matrix as text, rows = truth.
std::string format_confusion(const cv::Mat& confusion, const std::vector<std::string>& classes);

}  // namespace saccade::classifier
