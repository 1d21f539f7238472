#include <opencv2/imgproc.hpp>

#include "motion.hpp"
#include "retina.hpp"
#include "saccade/fill.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::motion;

class MotionNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<Retina> kRetina{"retina", "8-bit gray retina"};
  static constexpr Out<FeatureMaps> kMaps{"maps", "dI, mx, my, mask per level (on the current retina's geometry)"};
  static constexpr Out<Motion> kMotion{"motion", "per level: energy, moving fraction, centroid in source pixels"};

  static void bind(ParamBinder<MotionConfig>& b) {
    using filters::Border;
    b.field("threshold", {0, 255}, "|dI| above this is motion (gray levels)", &MotionConfig::threshold)
        .field("sigma", {0.3, 3}, "sigma of the Gaussian derivatives, level pixels", &MotionConfig::sigma)
        .field("border", {{"reflect101", Border::kReflect101}, {"replicate", Border::kReplicate}},
               "border rule of the derivatives", &MotionConfig::border);
  }

  static Contract contract() {
    return Contract(
               "Frame difference per retina level, its Gaussian derivatives Mx/My, a motion mask, and per level "
               "the motion energy and centroid; a fovea shift is not reported as motion.")
        .ports(kRetina, kMaps, kMotion)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    estimator_ = std::make_unique<LevelMotionEstimator>(ctx.config(&bind));
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto cur = ctx.get(kRetina);
    if (cur->levels.empty() || cur->levels[0].type() != CV_8UC1)
      return Status::error("expected an 8-bit gray retina (set the retina's channels=gray)");
    const std::size_t n = cur->levels.size();
    auto summary = ctx.make(kMotion);
    summary->camera_id = cur->camera_id;
    summary->energy.assign(n, 0.0);
    summary->moving.assign(n, 0.0);
    summary->centroid.assign(n, cv::Point2d(-1, -1));
    summary->first = !prev_ || !compatible(*prev_, *cur);
    auto maps = ctx.make(kMaps);
    maps->retina = cur;
    maps->set_layout({"dI", "mx", "my", "mask"}, n);
    if (!summary->first) {
      const bool same_geometry = equal_geometry(*prev_, *cur);
      const bool from_source = !same_geometry && prev_->source && !prev_->source->mat.empty();
      if (from_source) resample_source(*cur);
      for (std::size_t k = 0; k < n; ++k) {
        const cv::Mat* prev_level = &prev_->levels[k];
        valid_.release();
        if (!same_geometry) {
          if (from_source) {
            prev_level = &resampled_[k];
          } else {
            resample_level(prev_->levels[k], prev_->geometry[k], cur->geometry[k], bilinear_, valid_);
            prev_level = &bilinear_;
          }
        }
        swap_in(*maps, k);
        estimator_->run(cur->levels[k], *prev_level, valid_, level_);
        swap_out(*maps, k);
        summary->energy[k] = level_.energy;
        summary->moving[k] = level_.moving;
        if (level_.centroid.x >= 0)
          summary->centroid[k] = cur->geometry[k].to_source(level_.centroid.x, level_.centroid.y);
      }
    } else {
      // Nothing to compare with yet: every map is zero.
      for (std::size_t f = 0; f < 4; ++f)
        for (std::size_t k = 0; k < n; ++k) {
          maps->maps[f][k].create(cur->levels[k].size(), f == 3 ? CV_8U : CV_32F);
          fill(maps->maps[f][k], 0);
        }
    }
    prev_ = cur;
    ctx.emit(kMaps, std::move(maps));
    ctx.emit(kMotion, std::move(summary));
    return {};
  }
  void close() override { prev_.reset(); }

 private:
  static bool compatible(const Retina& a, const Retina& b) {
    return a.levels.size() == b.levels.size() && a.source_size == b.source_size && !a.levels.empty() &&
           a.levels[0].size() == b.levels[0].size();
  }
  static bool equal_geometry(const Retina& a, const Retina& b) {
    for (std::size_t k = 0; k < a.geometry.size(); ++k)
      if (a.geometry[k].region != b.geometry[k].region) return false;
    return true;
  }
  // Samples the previous frame on the current geometry, the way the retina did.
  void resample_source(const Retina& cur) {
    const cv::Mat* frame = &prev_->source->mat;
    if (frame->channels() == 3) {
      cv::cvtColor(*frame, gray_, cv::COLOR_BGR2GRAY);
      frame = &gray_;
    }
    retina::RetinaConfig config;
    config.levels = static_cast<int>(cur.levels.size());
    config.size = cur.levels[0].size();
    config.mode = cur.sampling == Retina::Sampling::kAreaMean ? retina::SamplingMode::kAreaMean
                                                              : retina::SamplingMode::kFivePoint;
    if (!sampler_ || sampler_->config().levels != config.levels || sampler_->config().size != config.size ||
        sampler_->config().mode != config.mode)
      sampler_ = std::make_unique<retina::RetinaSampler>(config);
    cv::Point2d center(cur.geometry.back().region.x + config.size.width / 2.0,
                       cur.geometry.back().region.y + config.size.height / 2.0);
    sampler_->sample(*frame, center, resampled_, geometry_);
  }
  // The message's pooled buffers become the estimator's outputs and back: no copies.
  void swap_in(FeatureMaps& maps, std::size_t k) {
    std::swap(level_.diff, maps.maps[0][k]);
    std::swap(level_.mx, maps.maps[1][k]);
    std::swap(level_.my, maps.maps[2][k]);
    std::swap(level_.mask, maps.maps[3][k]);
  }
  void swap_out(FeatureMaps& maps, std::size_t k) { swap_in(maps, k); }

  std::unique_ptr<LevelMotionEstimator> estimator_;
  std::unique_ptr<retina::RetinaSampler> sampler_;
  std::shared_ptr<const Retina> prev_;
  std::vector<cv::Mat> resampled_;
  std::vector<LevelGeometry> geometry_;
  cv::Mat gray_, bilinear_, valid_;
  LevelMotion level_;
};

}  // namespace

SACCADE_PLUGIN("motion", MotionNode)
