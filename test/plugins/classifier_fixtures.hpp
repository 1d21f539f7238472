#pragma once
// A tiny recognition problem shared by the classifier's tests and the
// steady-state test: stripes of two orientations, their features, and a
// model file trained on them.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include <opencv2/core.hpp>

#include "recognition.hpp"

namespace saccade::classifier::test_fixtures {

// Stripes of a given orientation with random phase and contrast: two classes a
// small network separates.
inline cv::Mat stripes(bool vertical, int seed) {
  cv::RNG rng(static_cast<uint64_t>(seed));
  cv::Mat m(40, 40, CV_8U);
  const int period = 6 + rng.uniform(0, 4), phase = rng.uniform(0, period);
  const int lo = rng.uniform(20, 90), hi = rng.uniform(150, 240);
  for (int y = 0; y < m.rows; ++y)
    for (int x = 0; x < m.cols; ++x) m.at<uint8_t>(y, x) = (((vertical ? x : y) + phase) / (period / 2)) % 2 ? hi : lo;
  return m;
}

struct Tiny {
  cv::Mat x, val_x;
  std::vector<int> y, val_y;
  FeatureRecipe recipe;
  Tiny() {
    std::vector<cv::Mat> images, val_images;
    for (int i = 0; i < 40; ++i) {
      (i < 30 ? images : val_images).push_back(stripes(i % 2 == 0, i));
      (i < 30 ? y : val_y).push_back(i % 2);
    }
    EXPECT_EQ(features_of_views(images, recipe, x).message(), "");
    EXPECT_EQ(features_of_views(val_images, recipe, val_x).message(), "");
  }
  // A network trained on the training rows for `epochs`, the other settings the defaults.
  Model trained(int epochs, std::vector<int> hidden = {16}) const {
    TrainConfig config;
    config.hidden = std::move(hidden);
    config.epochs = epochs;
    return train(x, y, {"vertical", "horizontal"}, recipe, config, {}, {}, {});
  }
};

// A model file for the plugin tests, trained once per process.
inline std::string stripes_model() {
  static const std::string path = [] {
    namespace fs = std::filesystem;
    const Model model = Tiny().trained(15);
    const fs::path dir = fs::path(SACCADE_BINARY_DIR) / "test_out" / "classifier";
    fs::create_directories(dir);
    // CTest runs each test in its own process, in parallel: one file each.
    const std::string p = (dir / ("plugin_" + std::to_string(::getpid()) + ".yml.gz")).string();
    EXPECT_TRUE(model.save(p).ok());
    return p;
  }();
  return path;
}

}  // namespace saccade::classifier::test_fixtures
