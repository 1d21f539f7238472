// The paper's Table 6, side by side in one run: per frame of a stereo pair, the
// retina pipeline (two retinas, the filter bank, motion, stereo both ways
// coarse to fine with vergence, the fovea update) against the same features by
// OpenCV at full resolution, at 1024x768 and 640x480. Single thread.
#include <benchmark/benchmark.h>

#include <map>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "baseline.hpp"
#include "bench_util.hpp"
#include "controller.hpp"
#include "kernels.hpp"
#include "motion.hpp"
#include "recognition.hpp"
#include "retina.hpp"
#include "retina_stereo.hpp"

namespace {

using namespace saccade;
using bench::PerCall;
using bench::size_arg;

// The Aloe pair at the benchmark's size (left, right), and the left frame
// shifted by (3, 1) pixels as the frame before (motion everywhere).
struct Scene {
  cv::Mat left, right, left_before;
  cv::Point2d fovea;
  int max_disparity = 0;
};

const Scene& scene(cv::Size size) {
  static std::map<int, Scene> scenes;
  Scene& s = scenes[size.width];
  if (!s.left.empty()) return s;
  const std::string data = SACCADE_SAMPLE_DATA;
  cv::Mat l = cv::imread(data + "/aloeL.jpg", cv::IMREAD_GRAYSCALE),
          r = cv::imread(data + "/aloeR.jpg", cv::IMREAD_GRAYSCALE);
  if (l.empty() || r.empty()) {
    std::fprintf(stderr, "saccade_bench: the Aloe pair is missing under %s: install opencv-doc\n", data.c_str());
    std::exit(2);
  }
  cv::resize(l, s.left, size, 0, 0, cv::INTER_AREA);
  cv::resize(r, s.right, size, 0, 0, cv::INTER_AREA);
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 3, 0, 1, 1);
  cv::warpAffine(s.left, s.left_before, shift, size, cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  // The fixation used in graphs/stereo.xml, scaled; Aloe's largest disparity
  // (211 px at 1282 wide), scaled and rounded up to OpenCV's multiple of 16.
  s.fovea = {550.0 * size.width / l.cols, 450.0 * size.height / l.rows};
  s.max_disparity = ((211 * size.width / l.cols) / 16 + 1) * 16;
  return s;
}

std::shared_ptr<Retina> make_retina(retina::RetinaSampler& sampler, const cv::Mat& frame, cv::Point2d fovea) {
  auto r = std::make_shared<Retina>();
  auto image = std::make_shared<Image>();
  image->mat = frame;
  r->source = image;
  sampler.sample(frame, fovea, *r);
  return r;
}

filters::BankConfig bank_of(std::initializer_list<int> features) {
  filters::BankConfig c;
  for (int f : features) c.wanted[static_cast<std::size_t>(f)] = true;
  return c;
}

// The plain matcher (the paper's NCC); the variants below add to it.
stereo::RetinaStereoConfig stereo_config(int window, int max_disparity) {
  stereo::RetinaStereoConfig c = stereo::plain_matcher_config();
  c.ncc.window = window;
  c.max_disparity = max_disparity;
  c.vergence = true;
  return c;
}

// Everything the retina column needs for one frame of the pair, reused.
struct RetinaPipeline {
  retina::RetinaSampler left_sampler{{}}, right_sampler{{}}, before_sampler{{}};
  filters::FilterBank bank{
      bank_of({filters::kGauss, filters::kSobelX, filters::kSobelY, filters::kGradMag, filters::kLaplacian})};
  std::array<cv::Mat, filters::kFeatureCount> maps;
  motion::LevelMotionEstimator motion{{}};
  motion::LevelMotion level_motion;
  std::vector<cv::Mat> dI;
  stereo::RetinaStereo stereo5, stereo3, stereo5_sgm, stereo5_sgm8, stereo5_densest;
  std::vector<stereo::LevelDisparity> disparity;
  fovea::FoveaController controller{[] {
    fovea::ControllerConfig c;
    c.lock_on_motion = false;
    return c;
  }()};
  std::shared_ptr<Retina> left, right, before;
  const Scene& s;
  explicit RetinaPipeline(cv::Size size)
      : stereo5(stereo_config(5, scene(size).max_disparity)),
        stereo3(stereo_config(3, scene(size).max_disparity)),
        stereo5_sgm([&] {
          stereo::RetinaStereoConfig c = stereo_config(5, scene(size).max_disparity);
          c.ncc.semi_global = true;
          return c;
        }()),
        stereo5_sgm8([&] {
          stereo::RetinaStereoConfig c = stereo_config(5, scene(size).max_disparity);
          c.ncc.semi_global = true;
          c.ncc.paths = 8;
          return c;
        }()),
        stereo5_densest([&] {  // docs/accuracy.md's densest configuration
          stereo::RetinaStereoConfig c = stereo_config(5, scene(size).max_disparity);
          c.ncc.semi_global = true;
          c.ncc.paths = 8;
          c.fill_gaps = 2;
          c.fill_occlusions = true;
          c.fovea_prediction = true;
          return c;
        }()),
        s(scene(size)) {
    left = make_retina(left_sampler, s.left, s.fovea);
    right = make_retina(right_sampler, s.right, s.fovea);
    before = make_retina(before_sampler, s.left_before, s.fovea);
    dI.resize(left->levels.size());
    // Lock on something, so that the fovea's update is the tracking step.
    for (int i = 0; i < 5; ++i) controller.step(*left, nullptr, nullptr);
  }
  void retinas() {
    left_sampler.sample(s.left, s.fovea, left->levels, left->geometry);
    right_sampler.sample(s.right, s.fovea, right->levels, right->geometry);
  }
  void filter_bank() {
    for (const auto& level : left->levels) bank.run(level, maps);
  }
  void motion_all() {
    for (std::size_t k = 0; k < left->levels.size(); ++k) {
      motion.run(left->levels[k], before->levels[k], cv::Mat(), level_motion);
      std::swap(dI[k], level_motion.diff);
    }
  }
  void stereo_pair(stereo::RetinaStereo& matcher) { matcher.run(*left, *right, disparity); }
  void fovea_update() { controller.step(*left, &dI, nullptr); }
  void whole_pair() {
    retinas();
    filter_bank();
    motion_all();
    stereo_pair(stereo5);
    fovea_update();
  }
};

template <class F>
void timed(benchmark::State& state, F&& body) {
  PerCall timing;
  for (auto _ : state) {
    timing.start();
    body();
    timing.stop();
  }
  timing.report(state);
}

void BM_Table6_Retina(benchmark::State& state, const char* row) {
  RetinaPipeline p(size_arg(state));
  const std::string r = row;
  if (r == "retina") {
    retina::RetinaSampler sampler({});
    timed(state, [&] { sampler.sample(p.s.left, p.s.fovea, p.left->levels, p.left->geometry); });
  } else if (r == "gauss" || r == "gradient" || r == "laplacian") {
    filters::FilterBank bank(r == "gauss"      ? bank_of({filters::kGauss})
                             : r == "gradient" ? bank_of({filters::kSobelX, filters::kSobelY, filters::kGradMag})
                                               : bank_of({filters::kLaplacian}));
    timed(state, [&] {
      for (const auto& level : p.left->levels) bank.run(level, p.maps);
    });
  } else if (r == "motion") {
    timed(state, [&] { p.motion_all(); });
  } else if (r == "stereo3") {
    timed(state, [&] { p.stereo_pair(p.stereo3); });
  } else if (r == "stereo5") {
    timed(state, [&] { p.stereo_pair(p.stereo5); });
  } else if (r == "stereo5_sgm") {
    timed(state, [&] { p.stereo_pair(p.stereo5_sgm); });
  } else if (r == "stereo5_sgm8") {
    timed(state, [&] { p.stereo_pair(p.stereo5_sgm8); });
  } else if (r == "stereo5_densest") {
    timed(state, [&] { p.stereo_pair(p.stereo5_densest); });
  } else if (r == "fovea") {
    p.motion_all();
    timed(state, [&] { p.fovea_update(); });
  } else if (r == "total") {
    timed(state, [&] { p.whole_pair(); });
  } else if (r == "sgbm_levels") {
    // OpenCV's StereoSGBM both ways on the very images our matcher compares.
    stereo::RetinaStereoConfig c = stereo_config(5, p.s.max_disparity);
    c.keep_images = true;
    stereo::RetinaStereo keep(c);
    keep.run(*p.left, *p.right, p.disparity);
    std::vector<cv::Ptr<cv::StereoSGBM>> lr, rl;
    std::vector<cv::Mat> flipped_left, flipped_right;
    for (const auto& level : p.disparity) {
      const int count = ((level.range_hi - level.range_lo + 1 + 15) / 16) * 16;
      lr.push_back(
          cv::StereoSGBM::create(level.range_lo, count, 5, 200, 800, 1, 0, 10, 0, 0, cv::StereoSGBM::MODE_SGBM_3WAY));
      cv::Mat fl, fr;
      cv::flip(level.left_image, fl, 1);
      cv::flip(level.right_image, fr, 1);
      flipped_left.push_back(fl);
      flipped_right.push_back(fr);
    }
    cv::Mat out;
    timed(state, [&] {
      for (std::size_t k = 0; k < p.disparity.size(); ++k) {
        lr[k]->compute(p.disparity[k].left_image, p.disparity[k].right_image, out);
        lr[k]->compute(flipped_right[k], flipped_left[k], out);  // right -> left, mirrored
      }
    });
  }
}

// The same rows by OpenCV on the full frame.
struct FullFrame {
  const Scene& s;
  cv::Mat g, sx, sy, mag, lap, diff, diff_f, smooth, mx, my, disparity;
  baseline::FullFrameStereo bm, sgbm3, sgbm5;
  explicit FullFrame(cv::Size size)
      : s(scene(size)),
        bm({baseline::StereoAlgorithm::kBlockMatching, scene(size).max_disparity, 5}),
        sgbm3({baseline::StereoAlgorithm::kSemiGlobal, scene(size).max_disparity, 3}),
        sgbm5({baseline::StereoAlgorithm::kSemiGlobal, scene(size).max_disparity, 5}) {}
  void gauss() { cv::GaussianBlur(s.left, g, {3, 3}, 0, 0, cv::BORDER_REFLECT_101); }
  void gradient() {
    cv::Sobel(s.left, sx, CV_32F, 1, 0, 3);
    cv::Sobel(s.left, sy, CV_32F, 0, 1, 3);
    cv::magnitude(sx, sy, mag);
  }
  void laplacian() { cv::Laplacian(s.left, lap, CV_32F, 1); }
  void motion() {
    // dI and its Gaussian derivatives (sigma 1), as the retina's motion node.
    cv::subtract(s.left, s.left_before, diff_f, cv::noArray(), CV_32F);
    cv::GaussianBlur(diff_f, smooth, {7, 7}, 1.0, 1.0, cv::BORDER_REFLECT_101);
    cv::Sobel(smooth, mx, CV_32F, 1, 0, 3);
    cv::Sobel(smooth, my, CV_32F, 0, 1, 3);
  }
  void stereo(baseline::FullFrameStereo& m) {
    m.left_to_right(s.left, s.right, disparity);
    m.right_to_left(s.left, s.right, disparity);
  }
};

void BM_Table6_FullFrame(benchmark::State& state, const char* row) {
  FullFrame f(size_arg(state));
  const std::string r = row;
  if (r == "gauss")
    timed(state, [&] { f.gauss(); });
  else if (r == "gradient")
    timed(state, [&] { f.gradient(); });
  else if (r == "laplacian")
    timed(state, [&] { f.laplacian(); });
  else if (r == "motion")
    timed(state, [&] { f.motion(); });
  else if (r == "stereo_bm")
    timed(state, [&] { f.stereo(f.bm); });
  else if (r == "stereo_sgbm3")
    timed(state, [&] { f.stereo(f.sgbm3); });
  else if (r == "stereo_sgbm5")
    timed(state, [&] { f.stereo(f.sgbm5); });
  else if (r == "total_bm")
    timed(state, [&] {
      f.gauss();
      f.gradient();
      f.laplacian();
      f.motion();
      f.stereo(f.bm);
    });
}

// The classifier on the fovea: the default recipe's vector (gray and gradient
// orientation histograms, 432 values) and an MLP of the digits' shape (432-128-10).
void BM_Classifier_Inference(benchmark::State& state) {
  RetinaPipeline p(cv::Size(640, 480));
  classifier::FeatureRecipe recipe;
  classifier::FeatureExtractor extractor(recipe);
  cv::Mat x(40, recipe.length(), CV_32F);
  cv::randu(x, -1.0, 1.0);
  std::vector<int> y(40);
  std::vector<std::string> names;
  for (int i = 0; i < 40; ++i) y[static_cast<std::size_t>(i)] = i % 10;
  for (int c = 0; c < 10; ++c) names.push_back(std::to_string(c));
  classifier::TrainConfig config;
  config.epochs = 1;
  const classifier::Model model = classifier::train(x, y, names, recipe, config, {}, {}, {});
  cv::Mat row;
  std::vector<float> scores;
  timed(state, [&] {
    extractor.extract(*p.left, row);
    model.scores(row, scores);
  });
}
BENCHMARK(BM_Classifier_Inference)->Unit(benchmark::kMicrosecond);

#define TABLE6_RETINA(row) \
  BENCHMARK_CAPTURE(BM_Table6_Retina, row, #row)->Args({1024, 768})->Args({640, 480})->Unit(benchmark::kMicrosecond)
#define TABLE6_FULL(row) \
  BENCHMARK_CAPTURE(BM_Table6_FullFrame, row, #row)->Args({1024, 768})->Args({640, 480})->Unit(benchmark::kMicrosecond)

TABLE6_RETINA(retina);
TABLE6_RETINA(gauss);
TABLE6_RETINA(gradient);
TABLE6_RETINA(laplacian);
TABLE6_RETINA(motion);
TABLE6_RETINA(stereo3);
TABLE6_RETINA(stereo5);
TABLE6_RETINA(stereo5_sgm);
TABLE6_RETINA(stereo5_sgm8);
TABLE6_RETINA(stereo5_densest);
TABLE6_RETINA(fovea);
TABLE6_RETINA(total);
TABLE6_RETINA(sgbm_levels);
TABLE6_FULL(gauss);
TABLE6_FULL(gradient);
TABLE6_FULL(laplacian);
TABLE6_FULL(motion);
TABLE6_FULL(stereo_bm);
TABLE6_FULL(stereo_sgbm3);
TABLE6_FULL(stereo_sgbm5);
TABLE6_FULL(total_bm);

}  // namespace
