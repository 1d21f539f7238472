// The classifier as the fovea's top-down target: attention visits salient
// places until the classifier recognises the wanted object, then the fovea
// keeps tracking it.
#include <gtest/gtest.h>

#include <cstdlib>
#include <algorithm>
#include <filesystem>
#include <sstream>

#include <unistd.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "readers.hpp"
#include "recognition.hpp"
#include "support.hpp"

static const bool kOpenCvSingleThread = (cv::setNumThreads(1), true);

namespace saccade {
namespace {

namespace fs = std::filesystem;

// The synthetic scene of capture.synthetic (a still textured square at the
// frame's centre over vtest.avi's first frame, 640x480): views of the square
// (the fovea within 8 px of its centre: where attention lands on it) and of
// anywhere else.
std::string train_target_model() {
  cv::VideoCapture video(test::sample_path("vtest.avi"));
  cv::Mat first, background;
  video.read(first);
  cv::resize(first, background, {640, 480}, 0, 0, cv::INTER_AREA);
  capture::SyntheticScene scene;
  scene.background = background;
  scene.target_size = 24;
  scene.path = "still";
  capture::SyntheticRenderer renderer(scene);
  cv::Mat left, right, gray;
  renderer.render(0, left, right);
  cv::cvtColor(left, gray, cv::COLOR_BGR2GRAY);
  const cv::Point2d center = renderer.target_center(0);
  classifier::FeatureRecipe recipe;
  classifier::FeatureExtractor extractor(recipe);
  retina::RetinaSampler sampler({});
  Retina retina;
  cv::Mat x, row;
  std::vector<int> y;
  cv::RNG rng(7);
  for (int i = 0; i < 160; ++i) {
    const bool target = i % 2 == 0;
    cv::Point2d at = center + cv::Point2d(rng.uniform(-8.0, 8.0), rng.uniform(-8.0, 8.0));
    while (!target && cv::norm(at - center) < 40) at = {rng.uniform(20.0, 620.0), rng.uniform(20.0, 460.0)};
    sampler.sample(gray, at, retina.levels, retina.geometry);
    EXPECT_TRUE(extractor.extract(retina, row).ok());
    x.push_back(row);
    y.push_back(target ? 0 : 1);
  }
  classifier::TrainConfig config;
  config.epochs = 30;
  classifier::Model model = classifier::train(x, y, {"target", "background"}, recipe, config, {}, {}, {});
  const fs::path dir = fs::path(SACCADE_BINARY_DIR) / "test_out" / "recognition";
  fs::create_directories(dir);
  const std::string path = (dir / "target.yml.gz").string();
  EXPECT_TRUE(model.save(path).ok());
  return path;
}

std::string graph_xml(const std::string& model, bool connected) {
  return R"(<graph name="recognise">
  <node name="scene" plugin="capture.synthetic">
    <param name="size" value="640x480"/><param name="target_size" value="24"/>
    <param name="path" value="still"/><param name="count" value="300"/>
  </node>
  <node name="retina" plugin="retina"><param name="fovea" value="120,100"/></node>
  <node name="classifier" plugin="classifier">
    <param name="model" value=")" +
         model + R"("/><param name="target_classes" value="target"/>
  </node>
  <node name="fovea" plugin="fovea">
    <param name="mode" value="attend"/><param name="dwell" value="8"/>
    <param name="track_label" value="target"/>
  </node>
  <node name="states" plugin="util.record"/>
  <node name="results" plugin="util.record"/>
  <edge from="scene.image" to="retina.image" queue="block:2"/>
  <edge from="retina.retina" to="classifier.retina" queue="block:2"/>
  <edge from="retina.retina" to="fovea.retina" queue="block:2"/>
  )" + std::string(connected ? R"(<edge from="classifier.target" to="fovea.target"/>)" : "") +
         R"(
  <edge from="classifier.result" to="results.in" queue="block:2"/>
  <edge from="fovea.fovea" to="retina.fovea" delay="1"/>
  <edge from="fovea.state" to="states.in" queue="block:2"/>
</graph>)";
}

// Share of the last 100 frames with the fovea's centre on the 24-px square.
double share_on_target(const std::string& xml) {
  testing::Recorder::instance().clear();
  ExecutorOptions options;
  options.deterministic = true;
  auto run = test::open_graph(xml, options);
  EXPECT_TRUE(run->run().ok());
  auto states = test::recorded<FoveaState>("states");
  EXPECT_EQ(states.size(), 300u);
  if (std::getenv("SACCADE_TEST_VERBOSE"))
    for (const auto& st : states)
      if (st->attention_shift || st->frame_id % 25 == 0)
        std::printf("%lld %s fovea %.0f,%.0f next %.0f,%.0f shift %d\n", static_cast<long long>(st->frame_id),
                    to_string(st->state), st->fovea.x, st->fovea.y, st->next.x, st->next.y, st->attention_shift);
  int on = 0;
  for (std::size_t i = states.size() - 100; i < states.size(); ++i)
    on += std::abs(states[i]->fovea.x - 320) <= 12 && std::abs(states[i]->fovea.y - 240) <= 12;
  return on / 100.0;
}

TEST(RecognitionGraph, TheClassifierStopsAttentionOnTheObjectItRecognises) {
  const std::string model = train_target_model();
  const double with_classifier = share_on_target(graph_xml(model, true));
  auto results = test::recorded<Classification>("results");
  int recognized = 0;
  for (const auto& r : results)
    recognized += r->outcome == Classification::Outcome::kClassified && r->label() == "target";
  const double without = share_on_target(graph_xml(model, false));
  std::printf(
      "fovea on the square in the last 100 frames: %.2f with the classifier's target, %.2f without; "
      "frames classified 'target': %d\n",
      with_classifier, without, recognized);
  EXPECT_GE(with_classifier, 0.95);
  EXPECT_LT(without, 0.6) << "without the classifier's target, attention keeps moving on";
  EXPECT_GT(recognized, 0);
}

}  // namespace
}  // namespace saccade

namespace saccade {
namespace {

// A graph run as the training data: a label source (classifier.truth_label,
// from the synthetic scene's truth) says what the fixed fovea sees while the
// square circles through it; classifier.collect writes the samples, which
// train a model that tells the two apart.
TEST(CollectGraph, ALabelSourceInAGraphMakesTrainingSamples) {
  const fs::path dir = fs::path(SACCADE_BINARY_DIR) / "test_out" / "recognition";
  fs::create_directories(dir);
  const std::string samples_path = (dir / ("samples_" + std::to_string(::getpid()) + ".yml.gz")).string();
  const std::string xml = R"(<graph name="collect">
  <node name="scene" plugin="capture.synthetic">
    <param name="size" value="640x480"/><param name="target_size" value="24"/>
    <param name="path" value="circle"/><param name="radius" value="120"/><param name="period" value="240"/>
    <param name="count" value="720"/>
  </node>
  <node name="retina" plugin="retina"><param name="fovea" value="440,240"/></node>
  <node name="labeller" plugin="classifier.truth_label"><sync inputs="retina,truth"/></node>
  <node name="collect" plugin="classifier.collect">
    <param name="out" value=")" +
                          samples_path + R"("/>
    <sync inputs="retina,label"/>
  </node>
  <edge from="scene.image" to="retina.image" queue="block:2"/>
  <edge from="scene.truth" to="labeller.truth" queue="block:2"/>
  <edge from="retina.retina" to="labeller.retina" queue="block:2"/>
  <edge from="retina.retina" to="collect.retina" queue="block:2"/>
  <edge from="labeller.label" to="collect.label" queue="block:2"/>
</graph>)";
  ExecutorOptions options;
  options.deterministic = true;
  auto run = test::open_graph(xml, options);
  ASSERT_TRUE(run->run().ok());
  run.reset();  // closes the nodes: the samples are written
  Result<classifier::SampleSet> loaded = classifier::SampleSet::load(samples_path);
  ASSERT_TRUE(loaded.ok()) << loaded.error();
  const classifier::SampleSet& samples = *loaded;
  // Classes in the order the labels first came: the square starts in the fovea.
  EXPECT_EQ(samples.classes, (std::vector<std::string>{"target", "background"}));
  EXPECT_EQ(samples.x.rows, 720);
  const int targets = static_cast<int>(std::count(samples.y.begin(), samples.y.end(), 0));
  EXPECT_GE(targets, 12) << "the square passes the fovea three times";
  classifier::FolderTraining job;
  job.train.epochs = 20;
  std::ostringstream log;
  Result<classifier::TrainingResult> trained = classifier::train_rows(samples, job, log);
  ASSERT_TRUE(trained.ok()) << trained.error();
  const classifier::TrainingResult& result = *trained;
  std::printf("%s", log.str().c_str());
  EXPECT_GE(result.validation_accuracy, 0.95);
  ASSERT_EQ(result.confusion.rows, 2);
  EXPECT_GE(result.confusion.at<int>(0, 0), 1) << "a square in the validation share is recognised";
}

}  // namespace
}  // namespace saccade
