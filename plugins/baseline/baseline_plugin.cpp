// Full-resolution OpenCV nodes: the paper's "original" column as ordinary nodes.
// Their FeatureMaps carry one "level" (the whole frame) and no retina.
#include <opencv2/imgproc.hpp>

#include "baseline.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::baseline;

Status require_gray(const Image& image) {
  if (image.mat.type() != CV_8UC1)
    return Status::error("expected an 8-bit gray frame, got " + cv::typeToString(image.mat.type()) +
                         " (set the capture's color=gray)");
  return {};
}

class Filters final : public Node {
 public:
  static constexpr const char* kName = "filters";
  static constexpr In<Image> kImage{"image", "8-bit gray frame"};
  static constexpr Out<FeatureMaps> kMaps{"maps", "one full-frame map per feature"};
  static Contract contract() {
    return Contract("OpenCV's GaussianBlur, Sobel, magnitude, Laplacian and LoG on the full frame (one level).")
        .ports(kImage, kMaps)
        .param_flags("features", "gauss,sobel_x,sobel_y,grad_mag,laplacian", full_frame_features(),
                     "features to compute (comma list, or all)");
  }
  Status open(OpenContext& ctx) override {
    names_ = ctx.params().get_flags("features");
    if (names_.empty()) return Status::error("features selects nothing");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto image = ctx.get(kImage);
    if (Status s = require_gray(*image); !s.ok()) return s;
    auto maps = ctx.make(kMaps);
    maps->set_layout(names_, 1);
    for (std::size_t i = 0; i < names_.size(); ++i)
      if (Status s = compute_feature(names_[i], image->mat, maps->maps[i][0], scratch_); !s.ok()) return s;
    ctx.emit(kMaps, std::move(maps));
    return {};
  }

 private:
  std::vector<std::string> names_;
  cv::Mat scratch_;
};

class FrameDifference final : public Node {
 public:
  static constexpr const char* kName = "motion";
  static constexpr In<Image> kImage{"image", "8-bit gray frame"};
  static constexpr Out<FeatureMaps> kMaps{"maps", "absdiff (CV_8U) and mask (255 above threshold)"};
  static Contract contract() {
    return Contract("OpenCV's absdiff of consecutive full frames and its threshold.")
        .ports(kImage, kMaps)
        .param_double("threshold", 15.0, 0.0, 255.0, "absdiff above this is motion");
  }
  Status open(OpenContext& ctx) override {
    threshold_ = ctx.params().get_double("threshold");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto image = ctx.get(kImage);
    if (Status s = require_gray(*image); !s.ok()) return s;
    auto maps = ctx.make(kMaps);
    maps->set_layout({"absdiff", "mask"}, 1);
    if (prev_ && prev_->mat.size() == image->mat.size())
      cv::absdiff(image->mat, prev_->mat, maps->maps[0][0]);
    else
      maps->maps[0][0] = cv::Mat::zeros(image->mat.size(), CV_8U);
    cv::threshold(maps->maps[0][0], maps->maps[1][0], threshold_, 255, cv::THRESH_BINARY);
    prev_ = image;
    ctx.emit(kMaps, std::move(maps));
    return {};
  }
  void close() override { prev_.reset(); }

 private:
  double threshold_ = 15;
  std::shared_ptr<const Image> prev_;
};

class Stereo final : public Node {
 public:
  static constexpr const char* kName = "stereo";
  static constexpr In<Image> kLeft{"left", "8-bit gray left frame"};
  static constexpr In<Image> kRight{"right", "8-bit gray right frame"};
  static constexpr Out<FeatureMaps> kMaps{"maps", "disparity_lr and/or disparity_rl (CV_32F)"};

  static void bind(ParamBinder<StereoConfig>& b) {
    b.field("algorithm", {{"bm", StereoAlgorithm::kBlockMatching}, {"sgbm", StereoAlgorithm::kSemiGlobal}},
            "block matching or semi-global matching", &StereoConfig::algorithm)
        .field("num_disparities", {16, 1024}, "search range, a multiple of 16", &StereoConfig::num_disparities)
        .field("block_size", {3, 51}, "matching window side, odd", &StereoConfig::block_size);
  }

  static Contract contract() {
    return Contract(
               "OpenCV's StereoBM or StereoSGBM (3-way) on full frames, left->right and right->left; "
               "disparity in pixels, -1 where invalid.")
        .ports(kLeft, kRight, kMaps)
        .params(&bind)
        .param_enum("direction", "both", {"left_to_right", "right_to_left", "both"}, "which disparity maps");
  }
  Status open(OpenContext& ctx) override {
    const StereoConfig config = ctx.config(&bind);
    if (config.num_disparities % 16 != 0) return Status::error("num_disparities must be a multiple of 16");
    if (config.block_size % 2 == 0) return Status::error("block_size must be odd");
    stereo_ = std::make_unique<FullFrameStereo>(config);
    const std::string& d = ctx.params().get_string("direction");
    if (d != "right_to_left") names_.push_back("disparity_lr");
    if (d != "left_to_right") names_.push_back("disparity_rl");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto l = ctx.get(kLeft);
    auto r = ctx.get(kRight);
    if (Status s = require_gray(*l); !s.ok()) return s;
    if (Status s = require_gray(*r); !s.ok()) return s;
    if (l->mat.size() != r->mat.size()) return Status::error("left and right frames differ in size");
    auto maps = ctx.make(kMaps);
    maps->set_layout(names_, 1);
    for (std::size_t i = 0; i < names_.size(); ++i) {
      if (names_[i] == "disparity_lr")
        stereo_->left_to_right(l->mat, r->mat, maps->maps[i][0]);
      else
        stereo_->right_to_left(l->mat, r->mat, maps->maps[i][0]);
    }
    ctx.emit(kMaps, std::move(maps));
    return {};
  }

 private:
  std::unique_ptr<FullFrameStereo> stereo_;
  std::vector<std::string> names_;
};

}  // namespace

SACCADE_PLUGIN("baseline", Filters, FrameDifference, Stereo)
