#include "recognition.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "saccade/simd.hpp"

namespace saccade::classifier {

namespace {

bool known_feature(const std::string& f) { return f == "gray" || f == "grad_hist" || filters::feature_index(f) >= 0; }

filters::BankConfig bank_for(const FeatureRecipe& recipe) {
  filters::BankConfig c;
  for (const auto& f : recipe.features) {
    const int i = filters::feature_index(f);
    if (i >= 0) c.wanted[static_cast<std::size_t>(i)] = true;
    if (f == "grad_hist") c.wanted[filters::kGradMag] = c.wanted[filters::kGradDir] = true;
  }
  return c;
}

// Orientation histograms of `dir` (radians) weighted by `mag`, per cell of a
// `cells` grid, each bin shared linearly with its neighbour, L2-normalised.
void orientation_histograms(const cv::Mat& mag, const cv::Mat& dir, cv::Size cells, std::vector<float>& out) {
  constexpr int kBins = FeatureRecipe::kOrientationBins;
  out.assign(static_cast<std::size_t>(cells.area() * kBins), 0.0f);
  for (int y = 0; y < mag.rows; ++y) {
    const float* m = mag.ptr<float>(y);
    const float* d = dir.ptr<float>(y);
    const int cy = std::min(cells.height - 1, y * cells.height / mag.rows);
    for (int x = 0; x < mag.cols; ++x) {
      const int cx = std::min(cells.width - 1, x * cells.width / mag.cols);
      float a = d[x] < 0 ? d[x] + static_cast<float>(CV_PI) : d[x];  // unsigned: 0 .. pi
      const float position = a / static_cast<float>(CV_PI) * kBins - 0.5f;
      const int b0 = static_cast<int>(std::floor(position));
      const float f = position - static_cast<float>(b0);
      float* h = out.data() + (cy * cells.width + cx) * kBins;
      h[(b0 + kBins) % kBins] += m[x] * (1.0f - f);
      h[(b0 + 1 + kBins) % kBins] += m[x] * f;
    }
  }
  for (int c = 0; c < cells.area(); ++c) {
    float* h = out.data() + c * kBins;
    float norm = 0;
    for (int b = 0; b < kBins; ++b) norm += h[b] * h[b];
    norm = std::sqrt(norm) + 1e-3f;
    for (int b = 0; b < kBins; ++b) h[b] /= norm;
  }
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ",") + s;
  return out;
}

}  // namespace

namespace {

// In 64 bits: a recipe read from a file may ask for more values than an int holds.
int64_t values_in(const FeatureRecipe& r) {
  const int64_t area = static_cast<int64_t>(r.size.width) * r.size.height;
  int64_t n = 0;
  for (const auto& f : r.features) n += f == "grad_hist" ? area * FeatureRecipe::kOrientationBins : area;
  return n * static_cast<int64_t>(r.levels.size());
}

constexpr int64_t kMostValues = int64_t{1} << 24;

}  // namespace

int FeatureRecipe::length() const { return static_cast<int>(std::min(values_in(*this), kMostValues)); }

std::string FeatureRecipe::describe() const {
  std::ostringstream o;
  o << "levels ";
  for (std::size_t i = 0; i < levels.size(); ++i) o << (i ? "," : "") << levels[i];
  o << "; features " << join(features) << "; each " << size.width << "x" << size.height << "; retina of "
    << retina_levels << " levels of " << level_size.width << "x" << level_size.height;
  return o.str();
}

Status FeatureRecipe::check() const {
  if (levels.empty()) return Status::error("the recipe names no level");
  if (features.empty()) return Status::error("the recipe names no feature");
  if (size.width < 1 || size.height < 1) return Status::error("the recipe's size must be at least 1x1");
  if (const int64_t n = values_in(*this); n > kMostValues)
    return Status::error("the recipe's feature vector would hold " + std::to_string(n) + " values; at most " +
                         std::to_string(kMostValues) + " (a smaller size, fewer levels or features)");
  for (int l : levels)
    if (l < 0 || l >= retina_levels)
      return Status::error("level " + std::to_string(l) + " is not one of the retina's " +
                           std::to_string(retina_levels) + " (0 = the fovea)");
  for (const auto& f : features)
    if (!known_feature(f)) return Status::error("unknown feature '" + f + "' (gray, grad_hist or a filter-bank map)");
  return {};
}

Status FeatureRecipe::check(const Retina& retina) const {
  const int n = static_cast<int>(retina.levels.size());
  const cv::Size s = n > 0 ? retina.levels[0].size() : cv::Size();
  if (n != retina_levels || s != level_size)
    return Status::error("the model was trained on a retina of " + std::to_string(retina_levels) + " levels of " +
                         std::to_string(level_size.width) + "x" + std::to_string(level_size.height) +
                         "; this retina has " + std::to_string(n) + " levels of " + std::to_string(s.width) + "x" +
                         std::to_string(s.height));
  return {};
}

void FeatureRecipe::write(cv::FileStorage& fs) const {
  fs << "levels" << levels << "features" << features << "size" << size << "retina_levels" << retina_levels
     << "level_size" << level_size;
}

Result<FeatureRecipe> FeatureRecipe::read(const cv::FileNode& node) {
  if (node.empty() || !node.isMap()) return Status::error("no feature recipe (saccade_recipe) in the model file");
  FeatureRecipe r;
  node["levels"] >> r.levels;
  node["features"] >> r.features;
  node["size"] >> r.size;
  node["retina_levels"] >> r.retina_levels;
  node["level_size"] >> r.level_size;
  if (Status s = r.check(); !s.ok()) return Status::error("feature recipe in the model file: " + s.message());
  return r;
}

bool FeatureRecipe::operator==(const FeatureRecipe& o) const {
  return levels == o.levels && features == o.features && size == o.size && retina_levels == o.retina_levels &&
         level_size == o.level_size;
}

Result<std::vector<int>> parse_levels(const std::string& text) {
  return parse_int_list(text, "levels (0 = the fovea)");
}

Result<std::vector<int>> parse_int_list(const std::string& text, const std::string& what) {
  std::vector<int> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    std::size_t used = 0;
    int v = -1;
    try {
      v = std::stoi(item, &used);
    } catch (...) { used = 0; }
    if (used != item.size() || v < 0) return Status::error(what + ": expected numbers like 0,1, got '" + text + "'");
    out.push_back(v);
  }
  if (out.empty()) return Status::error(what + ": empty");
  return out;
}

Result<std::vector<std::string>> parse_features(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!known_feature(item))
      return Status::error("features: unknown '" + item + "' (gray, grad_hist or a filter-bank map)");
    out.push_back(item);
  }
  if (out.empty()) return Status::error("features: empty");
  return out;
}

FeatureExtractor::FeatureExtractor(FeatureRecipe recipe) : recipe_(std::move(recipe)), bank_(bank_for(recipe_)) {}

cv::Rect FeatureExtractor::region(const Retina& retina) const {
  const int outer = *std::max_element(recipe_.levels.begin(), recipe_.levels.end());
  const int k = static_cast<int>(retina.geometry.size()) - 1 - outer;
  return k >= 0 ? retina.geometry[static_cast<std::size_t>(k)].region : cv::Rect();
}

Status FeatureExtractor::extract(const Retina& retina, cv::Mat& row) {
  if (Status s = recipe_.check(retina); !s.ok()) return s;
  row.create(1, recipe_.length(), CV_32F);
  float* out = row.ptr<float>(0);
  const int n = static_cast<int>(retina.levels.size());
  const int area = recipe_.size.area();
  for (int level : recipe_.levels) {
    const cv::Mat& raw = retina.levels[static_cast<std::size_t>(n - 1 - level)];
    const cv::Mat* gray = &raw;
    if (raw.channels() == 3) {
      cv::cvtColor(raw, gray_, cv::COLOR_BGR2GRAY);
      gray = &gray_;
    }
    bank_.run(*gray, maps_);
    for (const auto& f : recipe_.features) {
      if (f == "grad_hist") {
        orientation_histograms(maps_[filters::kGradMag], maps_[filters::kGradDir], recipe_.size, histogram_);
        out = std::copy(histogram_.begin(), histogram_.end(), out);
        continue;
      }
      const cv::Mat& map = f == "gray" ? *gray : maps_[static_cast<std::size_t>(filters::feature_index(f))];
      // (A buffer per type: one changing type at every call would be made anew each time.)
      if (map.type() == CV_32F) {
        cv::resize(map, reduced_, recipe_.size, 0, 0, cv::INTER_AREA);
      } else {
        cv::resize(map, resized_, recipe_.size, 0, 0, cv::INTER_AREA);
        resized_.convertTo(reduced_, CV_32F);
      }
      for (int y = 0; y < reduced_.rows; ++y)
        std::copy_n(reduced_.ptr<float>(y), reduced_.cols, out + y * reduced_.cols);
      out += area;
    }
  }
  // Zero mean, unit deviation: the same object under other lighting gives the same vector.
  cv::Scalar mean, stddev;
  cv::meanStdDev(row, mean, stddev);
  // (The arithmetic of row -= mean; row /= stddev, the mean as a float, without
  // the temporaries their expressions and cv::add's scalar allocate.)
  const float shift = static_cast<float>(-mean[0]);
  float* values = row.ptr<float>(0);
  for (int i = 0; i < row.cols; ++i) values[i] += shift;
  if (stddev[0] > 1e-6) row.convertTo(row, CV_32F, 1.0 / stddev[0]);
  return {};
}

void retina_of_view(const cv::Mat& image, retina::RetinaSampler& sampler, Retina& out, cv::Mat& frame) {
  const cv::Size fovea = sampler.config().size;
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  const double scale =
      std::min(static_cast<double>(fovea.width) / gray.cols, static_cast<double>(fovea.height) / gray.rows);
  cv::Mat scaled;
  const cv::Size fitted(std::max(1, static_cast<int>(std::lround(gray.cols * scale))),
                        std::max(1, static_cast<int>(std::lround(gray.rows * scale))));
  cv::resize(gray, scaled, fitted, 0, 0, scale < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  // Centred in a frame four fovea widths wide, the border replicated.
  const cv::Size size(fovea.width * 4, fovea.height * 4);
  const int left = (size.width - fitted.width) / 2, top = (size.height - fitted.height) / 2;
  cv::copyMakeBorder(scaled, frame, top, size.height - fitted.height - top, left, size.width - fitted.width - left,
                     cv::BORDER_REPLICATE);
  const cv::Point2d center(left + fitted.width / 2.0, top + fitted.height / 2.0);
  sampler.sample(frame, center, out);
}

namespace {

// sums[j] += value * row[j], j < n: a layer's sums take one value of the
// layer before at a time (its row of weights contiguous).
SACCADE_AVX2_CLONE void add_weighted(double* __restrict sums, const double* __restrict row, double value, int n) {
  for (int j = 0; j < n; ++j) sums[j] += value * row[j];
}

}  // namespace

Result<ForwardPass> ForwardPass::of(const cv::ml::ANN_MLP& net, const cv::FileNode& written) {
  cv::FileStorage made;
  cv::FileNode node = written;
  if (node.empty()) {
    cv::FileStorage out(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
    out << "net"
        << "{";
    net.write(out);
    out << "}";
    made.open(out.releaseAndGetString(), cv::FileStorage::READ | cv::FileStorage::MEMORY);
    node = made["net"];
  }
  const std::string activation = static_cast<std::string>(node["activation_function"]);
  if (activation != "SIGMOID_SYM")
    return Status::error("the network's activation is '" + activation + "'; its forward pass knows SIGMOID_SYM");
  ForwardPass pass;
  pass.alpha_ = static_cast<double>(node["f_param1"]);
  pass.beta_ = static_cast<double>(node["f_param2"]);
  if (Status taken = pass.take_weights(net); !taken.ok()) return taken;
  return pass;
}

Status ForwardPass::take_weights(const cv::ml::ANN_MLP& net) {
  const cv::Mat sizes = net.getLayerSizes();
  const int count = static_cast<int>(sizes.total());
  if (count < 2) return Status::error("the network has no layers");
  inputs_ = sizes.at<int>(0);
  outputs_ = sizes.at<int>(count - 1);
  net.getWeights(0).copyTo(input_scale_);
  net.getWeights(count).copyTo(output_scale_);
  layers_.resize(static_cast<std::size_t>(count - 1));
  int widest = inputs_;
  for (int i = 1; i < count; ++i) {
    cv::Mat& w = layers_[static_cast<std::size_t>(i - 1)];
    net.getWeights(i).copyTo(w);
    if (w.type() != CV_64F || w.rows != sizes.at<int>(i - 1) + 1 || w.cols != sizes.at<int>(i))
      return Status::error("the network's layer " + std::to_string(i) + " is not trained");
    widest = std::max(widest, w.cols);
  }
  values_.resize(static_cast<std::size_t>(widest));
  sums_.resize(static_cast<std::size_t>(widest));
  return {};
}

void ForwardPass::run(const float* in, float* out) {
  const double* scale = input_scale_.ptr<double>();
  for (int j = 0; j < inputs_; ++j) values_[static_cast<std::size_t>(j)] = in[j] * scale[2 * j] + scale[2 * j + 1];
  for (const cv::Mat& w : layers_) {
    const int n = w.rows - 1, m = w.cols;
    std::fill_n(sums_.begin(), m, 0.0);
    for (int i = 0; i < n; ++i) add_weighted(sums_.data(), w.ptr<double>(i), values_[static_cast<std::size_t>(i)], m);
    const double* bias = w.ptr<double>(n);
    for (int j = 0; j < m; ++j) {
      const double e = std::exp((sums_[static_cast<std::size_t>(j)] + bias[j]) * -alpha_);
      values_[static_cast<std::size_t>(j)] = std::isinf(e) ? -beta_ : beta_ * (1.0 - e) / (1.0 + e);
    }
  }
  scale = output_scale_.ptr<double>();
  for (int j = 0; j < outputs_; ++j)
    out[j] = static_cast<float>(values_[static_cast<std::size_t>(j)] * scale[2 * j] + scale[2 * j + 1]);
}

void Model::scores(const cv::Mat& row, std::vector<float>& out) const {
  CV_Assert(row.type() == CV_32F && row.isContinuous() && static_cast<int>(row.total()) == forward.inputs());
  out.resize(static_cast<std::size_t>(forward.outputs()));
  forward.run(row.ptr<float>(), out.data());
  for (float& score : out) score = std::clamp((score + 1.0f) / 2.0f, 0.0f, 1.0f);
}

Status Model::save(const std::string& path) const {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return Status::error("cannot write model file '" + path + "'");
    fs << net->getDefaultName() << "{";
    net->write(fs);
    fs << "}";
    fs << "saccade_recipe"
       << "{";
    recipe.write(fs);
    fs << "}";
    fs << "saccade_classes" << *classes;
  } catch (const cv::Exception& e) { return Status::error("cannot write model file '" + path + "': " + e.what()); }
  return {};
}

Result<std::unique_ptr<Model>> Model::load(const std::string& path) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return Status::error("cannot open model file '" + path + "'");
    auto model = std::make_unique<Model>();
    model->net = cv::ml::ANN_MLP::create();
    const cv::FileNode net = fs[model->net->getDefaultName()];
    if (net.empty()) return Status::error("model file '" + path + "' holds no " + model->net->getDefaultName());
    model->net->read(net);
    auto recipe = FeatureRecipe::read(fs["saccade_recipe"]);
    if (!recipe.ok()) return Status::error("model file '" + path + "': " + recipe.error());
    model->recipe = *recipe;
    std::vector<std::string> classes;
    fs["saccade_classes"] >> classes;
    const cv::Mat layers = model->net->getLayerSizes();
    if (layers.total() < 2 ||
        classes.size() != static_cast<std::size_t>(layers.at<int>(static_cast<int>(layers.total()) - 1)) ||
        layers.at<int>(0) != model->recipe.length())
      return Status::error("model file '" + path + "': the network's layers do not fit its recipe (" +
                           model->recipe.describe() + ") and " + std::to_string(classes.size()) + " classes");
    model->classes = std::make_shared<const std::vector<std::string>>(std::move(classes));
    auto forward = ForwardPass::of(*model->net, net);
    if (!forward.ok()) return Status::error("model file '" + path + "': " + forward.error());
    model->forward = std::move(forward).value();
    return model;
  } catch (const cv::Exception& e) { return Status::error("cannot read model file '" + path + "': " + e.what()); }
}

Model train(const cv::Mat& x, const std::vector<int>& y, std::vector<std::string> classes, const FeatureRecipe& recipe,
            const TrainConfig& config, const cv::Mat& val_x, const std::vector<int>& val_y,
            const std::function<void(const EpochReport&)>& progress) {
  CV_Assert(x.type() == CV_32F && x.rows == static_cast<int>(y.size()) && !classes.empty());
  const int n_classes = static_cast<int>(classes.size());
  cv::Mat targets(x.rows, n_classes, CV_32F, cv::Scalar(-1.0f));
  for (int i = 0; i < x.rows; ++i) targets.at<float>(i, y[static_cast<std::size_t>(i)]) = 1.0f;
  std::vector<int> layers{x.cols};
  layers.insert(layers.end(), config.hidden.begin(), config.hidden.end());
  layers.push_back(n_classes);
  Model model;
  model.recipe = recipe;
  model.classes = std::make_shared<const std::vector<std::string>>(std::move(classes));
  model.net = cv::ml::ANN_MLP::create();
  model.net->setLayerSizes(layers);
  model.net->setActivationFunction(cv::ml::ANN_MLP::SIGMOID_SYM);
  if (config.method == TrainConfig::Method::kBackprop)
    model.net->setTrainMethod(cv::ml::ANN_MLP::BACKPROP, config.learning_rate, config.momentum);
  else
    model.net->setTrainMethod(cv::ml::ANN_MLP::RPROP);
  // One epoch per call, so that progress can be reported; the weights carry over.
  model.net->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER, 1, 0));
  // ANN_MLP draws its initial weights from its own fixed generator, so the seed
  // sets what it can: the order the samples are presented in (which online
  // backprop follows; batch RPROP does not depend on it).
  std::vector<int> order(static_cast<std::size_t>(x.rows));
  for (int i = 0; i < x.rows; ++i) order[static_cast<std::size_t>(i)] = i;
  cv::RNG rng(config.seed);
  for (int i = x.rows - 1; i > 0; --i)
    std::swap(order[static_cast<std::size_t>(i)], order[static_cast<std::size_t>(rng.uniform(0, i + 1))]);
  cv::Mat shuffled_x(x.size(), x.type()), shuffled_t(targets.size(), targets.type());
  for (int i = 0; i < x.rows; ++i) {
    x.row(order[static_cast<std::size_t>(i)]).copyTo(shuffled_x.row(i));
    targets.row(order[static_cast<std::size_t>(i)]).copyTo(shuffled_t.row(i));
  }
  auto data = cv::ml::TrainData::create(shuffled_x, cv::ml::ROW_SAMPLE, shuffled_t);
  for (int epoch = 1; epoch <= config.epochs; ++epoch) {
    model.net->train(data, epoch == 1 ? 0 : cv::ml::ANN_MLP::UPDATE_WEIGHTS);
    // (The activation, which train() makes the one the pass knows, is read
    // once; each later epoch only changes the weights.)
    if (epoch == 1) {
      model.forward = ForwardPass::of(*model.net).value();
    } else {
      const Status taken = model.forward.take_weights(*model.net);
      CV_Assert(taken.ok());
    }
    if (progress) {
      EpochReport r;
      r.epoch = epoch;
      r.train_accuracy = accuracy(model, x, y);
      r.validation_accuracy = val_x.empty() ? 0.0 : accuracy(model, val_x, val_y);
      progress(r);
    }
  }
  return model;
}

namespace {

// The best class of every row of x.
std::vector<int> best_classes(const Model& model, const cv::Mat& x) {
  std::vector<int> out(static_cast<std::size_t>(x.rows));
  if (x.rows == 0) return out;
  CV_Assert(x.type() == CV_32F && x.cols == model.forward.inputs());
  std::vector<float> response(static_cast<std::size_t>(model.forward.outputs()));
  for (int i = 0; i < x.rows; ++i) {
    model.forward.run(x.ptr<float>(i), response.data());
    out[static_cast<std::size_t>(i)] =
        static_cast<int>(std::max_element(response.begin(), response.end()) - response.begin());
  }
  return out;
}

}  // namespace

double accuracy(const Model& model, const cv::Mat& x, const std::vector<int>& y) {
  if (x.rows == 0) return 0.0;
  const std::vector<int> predicted = best_classes(model, x);
  int right = 0;
  for (std::size_t i = 0; i < predicted.size(); ++i) right += predicted[i] == y[i];
  return static_cast<double>(right) / x.rows;
}

cv::Mat confusion(const Model& model, const cv::Mat& x, const std::vector<int>& y) {
  const int n = static_cast<int>(model.classes->size());
  cv::Mat m(n, n, CV_32S, cv::Scalar(0));
  const std::vector<int> predicted = best_classes(model, x);
  for (std::size_t i = 0; i < predicted.size(); ++i) ++m.at<int>(y[i], predicted[i]);
  return m;
}

Classification::Outcome decide(const std::vector<float>& scores, const Thresholds& t, int* best_index) {
  int best = -1;
  float first = -1.0f, second = -1.0f;
  for (std::size_t i = 0; i < scores.size(); ++i) {
    if (scores[i] > first) {
      second = first;
      first = scores[i];
      best = static_cast<int>(i);
    } else if (scores[i] > second) {
      second = scores[i];
    }
  }
  if (best_index != nullptr) *best_index = best;
  if (best < 0) return Classification::Outcome::kNotClassified;
  const double gap = first - std::max(0.0f, second);
  if (first >= t.classified && gap >= t.margin) return Classification::Outcome::kClassified;
  if (first >= t.probable) return Classification::Outcome::kProbable;
  return Classification::Outcome::kNotClassified;
}

Status load_folder(const std::string& root, int video_step, Dataset& out) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(root, ec))
    return Status::error("'" + root + "' is not a folder (expected one sub-folder per class)");
  std::vector<fs::path> folders;
  for (const auto& entry : fs::directory_iterator(root, ec))
    if (entry.is_directory()) folders.push_back(entry.path());
  std::sort(folders.begin(), folders.end());
  if (folders.size() < 2) return Status::error("'" + root + "' needs at least two sub-folders, one per class");
  auto lower = [](std::string s) {
    for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  };
  const std::vector<std::string> images = {".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff"};
  const std::vector<std::string> videos = {".avi", ".mp4", ".mkv", ".mov", ".webm", ".mpg"};
  for (const auto& folder : folders) {
    const int label = static_cast<int>(out.classes.size());
    out.classes.push_back(folder.filename().string());
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder, ec))
      if (entry.is_regular_file()) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    int count = 0;
    for (const auto& file : files) {
      const std::string ext = lower(file.extension().string());
      if (std::find(images.begin(), images.end(), ext) != images.end()) {
        cv::Mat m = cv::imread(file.string(), cv::IMREAD_GRAYSCALE);
        if (m.empty()) return Status::error("cannot read image '" + file.string() + "'");
        out.images.push_back(m);
        out.labels.push_back(label);
        ++count;
      } else if (std::find(videos.begin(), videos.end(), ext) != videos.end()) {
        cv::VideoCapture video(file.string());
        if (!video.isOpened()) return Status::error("cannot open video '" + file.string() + "'");
        cv::Mat frame, gray;
        for (int i = 0; video.read(frame); ++i) {
          if (i % std::max(1, video_step) != 0) continue;
          cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
          out.images.push_back(gray.clone());
          out.labels.push_back(label);
          ++count;
        }
      }
    }
    if (count == 0) return Status::error("class folder '" + folder.string() + "' holds no image or video");
  }
  return {};
}

Status features_of_views(const std::vector<cv::Mat>& images, const FeatureRecipe& recipe, cv::Mat& rows) {
  retina::RetinaConfig config;
  config.levels = recipe.retina_levels;
  config.size = recipe.level_size;
  retina::RetinaSampler sampler(config);
  FeatureExtractor extractor(recipe);
  Retina retina;
  cv::Mat frame, row;
  rows.create(static_cast<int>(images.size()), recipe.length(), CV_32F);
  for (std::size_t i = 0; i < images.size(); ++i) {
    retina_of_view(images[i], sampler, retina, frame);
    if (Status s = extractor.extract(retina, row); !s.ok()) return s;
    row.copyTo(rows.row(static_cast<int>(i)));
  }
  return {};
}

std::string format_confusion(const cv::Mat& confusion, const std::vector<std::string>& classes) {
  std::ostringstream o;
  std::size_t width = 5;
  for (const auto& c : classes) width = std::max(width, c.size() + 1);
  o << std::string(width, ' ');
  for (const auto& c : classes) o << std::string(width - std::min(width, c.size()), ' ') << c;
  o << "   <- predicted\n";
  for (int i = 0; i < confusion.rows; ++i) {
    const std::string& name = classes[static_cast<std::size_t>(i)];
    o << name << std::string(width - std::min(width, name.size()), ' ');
    for (int j = 0; j < confusion.cols; ++j) {
      const std::string v = std::to_string(confusion.at<int>(i, j));
      o << std::string(width - std::min(width, v.size()), ' ') << v;
    }
    o << "\n";
  }
  return o.str();
}

Status SampleSet::save(const std::string& path) const {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return Status::error("cannot write samples file '" + path + "'");
    fs << "saccade_recipe"
       << "{";
    recipe.write(fs);
    fs << "}";
    fs << "saccade_classes" << classes << "x" << x << "y" << y;
  } catch (const cv::Exception& e) { return Status::error("cannot write samples file '" + path + "': " + e.what()); }
  return {};
}

Result<SampleSet> SampleSet::load(const std::string& path) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return Status::error("cannot open samples file '" + path + "'");
    auto recipe = FeatureRecipe::read(fs["saccade_recipe"]);
    if (!recipe.ok()) return Status::error("samples file '" + path + "': " + recipe.error());
    SampleSet samples;
    samples.recipe = std::move(recipe).value();
    fs["saccade_classes"] >> samples.classes;
    fs["x"] >> samples.x;
    fs["y"] >> samples.y;
    if (samples.x.rows != static_cast<int>(samples.y.size()) ||
        (samples.x.rows > 0 && samples.x.cols != samples.recipe.length()) || samples.classes.size() < 2)
      return Status::error("samples file '" + path + "': its rows, labels, recipe and classes do not fit together");
    for (int label : samples.y)
      if (label < 0 || label >= static_cast<int>(samples.classes.size()))
        return Status::error("samples file '" + path + "': a label outside its classes");
    return samples;
  } catch (const cv::Exception& e) { return Status::error("cannot read samples file '" + path + "': " + e.what()); }
}

namespace {

// Per class, in order: the first samples train, the last `validation` share validates.
void split(const std::vector<int>& y, int classes, double validation, std::vector<int>& train_rows,
           std::vector<int>& val_rows) {
  for (int c = 0; c < classes; ++c) {
    std::vector<int> members;
    for (std::size_t i = 0; i < y.size(); ++i)
      if (y[i] == c) members.push_back(static_cast<int>(i));
    const std::size_t n_val = static_cast<std::size_t>(std::lround(validation * static_cast<double>(members.size())));
    for (std::size_t k = 0; k < members.size(); ++k)
      (k >= members.size() - n_val ? val_rows : train_rows).push_back(members[k]);
  }
}

}  // namespace

Result<TrainingResult> train_rows(const SampleSet& samples, const FolderTraining& job, std::ostream& log) {
  TrainingResult result;
  std::vector<int> train_rows, val_rows;
  split(samples.y, static_cast<int>(samples.classes.size()), job.validation, train_rows, val_rows);
  cv::Mat train_x, val_x;
  std::vector<int> train_y, val_y;
  for (int i : train_rows) {
    train_x.push_back(samples.x.row(i));
    train_y.push_back(samples.y[static_cast<std::size_t>(i)]);
  }
  for (int i : val_rows) {
    val_x.push_back(samples.x.row(i));
    val_y.push_back(samples.y[static_cast<std::size_t>(i)]);
  }
  log << "classes: " << samples.classes.size() << " (";
  for (std::size_t c = 0; c < samples.classes.size(); ++c) log << (c ? ", " : "") << samples.classes[c];
  log << "); " << train_y.size() << " training and " << val_y.size() << " validation samples\n";
  log << "features: " << samples.recipe.describe() << " (" << samples.recipe.length() << " values)\n";
  if (train_y.empty()) return Status::error("no training samples");
  Model model =
      train(train_x, train_y, samples.classes, samples.recipe, job.train, val_x, val_y, [&](const EpochReport& r) {
        if (r.epoch % std::max(1, job.report_every) == 0 || r.epoch == job.train.epochs)
          log << "epoch " << r.epoch << "/" << job.train.epochs << ": training accuracy " << r.train_accuracy
              << ", validation accuracy " << r.validation_accuracy << "\n";
      });
  result.classes = *model.classes;
  if (!val_y.empty()) {
    result.validation_accuracy = accuracy(model, val_x, val_y);
    result.confusion = confusion(model, val_x, val_y);
    log << "validation confusion matrix (rows: truth):\n" << format_confusion(result.confusion, result.classes);
  }
  if (!job.out.empty()) {
    if (Status s = model.save(job.out); !s.ok()) return s;
    log << "model written to " << job.out << "\n";
  }
  return result;
}

Result<TrainingResult> train_folder(const FolderTraining& job, std::ostream& log) {
  if (Status s = job.recipe.check(); !s.ok()) return s;
  Dataset data;
  if (Status s = load_folder(job.data, job.video_step, data); !s.ok()) return s;
  SampleSet samples;
  samples.recipe = job.recipe;
  samples.classes = data.classes;
  samples.y = data.labels;
  if (Status s = features_of_views(data.images, job.recipe, samples.x); !s.ok()) return s;
  return train_rows(samples, job, log);
}

}  // namespace saccade::classifier
