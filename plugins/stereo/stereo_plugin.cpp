#include "depth.hpp"
#include "retina_stereo.hpp"
#include "stereo_params.hpp"
#include "saccade/plugin.hpp"

#include "saccade/log.hpp"

namespace {

using namespace saccade;
using namespace saccade::stereo;

class StereoNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<Retina> kLeft{"left", "left retina (8-bit gray)"};
  static constexpr In<Retina> kRight{"right",
                                     "right retina, same level size; regions equal or shifted by whole level pixels"};
  static constexpr Out<StereoFixation> kFixation{
      "fixation",
      "the disparity at the left fovea's centre (-1 when not found), its NCC, whether it matches back "
      "(confirmed), and its depth when calibrated: for the head's vergence"};
  static constexpr SideIn<HeadPose> kHead{
      "head", "the cameras' poses (the kinematics node): the fixated point also in the head's frame, and gaze"};
  static constexpr Out<GazeRequest> kGaze{
      "gaze",
      "verge both cameras on the fixated point (kind point, head frame) when it is confirmed and its depth "
      "and the head's pose are known: connect to the head's gaze to close see -> verge -> fixate"};
  static constexpr Out<FeatureMaps> kMaps{
      "maps",
      "per level, every map on the left retina's level geometry (the message's retina): disparity (left->right, "
      "source pixels, -1 invalid), disparity_rl (right->left: at pixel (x, y), the right frame's pixel at the same "
      "source coordinates as the left level's pixel (x, y), whose scene point lies D source pixels further right "
      "in the left frame; -1 where invalid or not matched: with vergence a level's right image is sampled where "
      "the fixated scene is, so the columns it did not cover are -1, on a verged fovea often all), confidence "
      "(NCC; 0 where filled), depth (metres, when calibrated)"};

  static Contract contract() {
    return Contract(
               "Disparity between a left and a right retina by normalized cross correlation, both ways, with a "
               "left-right check, sub-pixel peaks and a confidence, coarse to fine across levels. Pair the inputs "
               "with <sync inputs=\"left,right\"/>.")
        .ports(kLeft, kRight, kHead, kFixation, kGaze, kMaps)
        .params(&bind_stereo_params);
  }
  Status open(OpenContext& ctx) override {
    StereoNodeConfig c = ctx.config(&bind_stereo_params);
    if (Status checked = check_stereo_params(c); !checked.ok()) return checked;
    calibration_ = c.calibration;
    if (!c.calibration_file.empty()) {
      Result<StereoCalibration> read = read_calibration(c.calibration_file);
      if (!read.ok()) return read.status();
      calibration_ = std::move(read).value();
    } else if ((calibration_.focal_px > 0) != (calibration_.baseline_m > 0)) {
      return Status::error("depth needs both focal and baseline (or a calibration file)");
    }
    config_ = c.stereo;
    disparity_sigma_ = c.disparity_sigma;
    name_ = ctx.node_name();
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto l = ctx.get(kLeft);
    auto r = ctx.get(kRight);
    fit_to_frame(*l);
    // A calibration for other images gives wrong depths: refuse it, once, by name.
    if (!calibration_.image_size.empty() && !l->rectification.enabled && l->source_size != calibration_.image_size)
      return Status::error(calibration_.path + " was made for " + std::to_string(calibration_.image_size.width) + "x" +
                           std::to_string(calibration_.image_size.height) + " images; the left retina's frame is " +
                           std::to_string(l->source_size.width) + "x" + std::to_string(l->source_size.height));
    if (Status matched = stereo_->run(*l, *r, levels_); !matched.ok()) return matched;
    const DepthModel model = depth_model(*l, calibration_);
    auto maps = ctx.make(kMaps);
    maps->retina = l;
    if (model.valid())
      maps->set_layout({"disparity", "disparity_rl", "confidence", "depth"}, levels_.size());
    else
      maps->set_layout({"disparity", "disparity_rl", "confidence"}, levels_.size());
    for (std::size_t k = 0; k < levels_.size(); ++k) {
      levels_[k].disparity.copyTo(maps->maps[0][k]);
      on_left_geometry(levels_[k].reverse, levels_[k].offset, maps->maps[1][k]);
      levels_[k].score.copyTo(maps->maps[2][k]);
      if (!model.valid()) continue;
      cv::Mat& depth = maps->maps[3][k];
      depth.create(levels_[k].disparity.size(), CV_32F);
      for (int y = 0; y < depth.rows; ++y)
        for (int x = 0; x < depth.cols; ++x)
          depth.at<float>(y, x) = static_cast<float>(model.depth(levels_[k].disparity.at<float>(y, x)));
    }
    ctx.emit(kMaps, std::move(maps));
    auto fixation = ctx.make(kFixation);
    const cv::Rect fovea = l->geometry.back().region;
    fixation->pixel = cv::Point2d(fovea.x + fovea.width / 2.0, fovea.y + fovea.height / 2.0);
    fixation->fovea = cv::Size2d(fovea.size());
    fixation->disparity = stereo_->fixation().disparity;
    fixation->score = stereo_->fixation().score;
    fixation->confirmed = stereo_->fixation().confirmed;
    fixation->rectified = l->rectification.enabled;
    fixation->camera_id = l->camera_id;
    // disparity_sigma is the fovea's; found on a coarser level (the fovea's
    // window flat), the disparity is as uncertain as that level's pixels are large.
    const int found_by = stereo_->fixation().level();
    const double coarser =
        found_by < 0
            ? 1.0
            : std::max(1.0, l->geometry[static_cast<std::size_t>(found_by)].step_x / l->geometry.back().step_x);
    const LocatedPoint at = locate(model, fixation->pixel, fixation->disparity, disparity_sigma_ * coarser);
    if (at.valid) {
      fixation->depth = at.depth;
      fixation->depth_sigma = at.depth_sigma;
      fixation->point = at.point;
      if (auto head = ctx.get(kHead)) {
        fixation->point_head = in_head_frame(*head, at.point);
        fixation->point_head_valid = true;
        // An unconfirmed fixation may be repeated texture's: the head does not verge on it.
        if (fixation->confirmed) {
          auto gaze = ctx.make(kGaze);
          gaze->stamp_from(*fixation);
          gaze->kind = GazeRequest::Kind::kPoint;
          gaze->point = fixation->point_head;
          gaze->pixel = fixation->pixel;
          gaze->depth = at.depth;
          gaze->camera_id = l->camera_id;
          gaze->reason = "fixation";
          ctx.emit(kGaze, std::move(gaze));
        }
      }
    }
    ctx.emit(kFixation, std::move(fixation));
    return {};
  }

 private:
  // A point in the left camera's optical frame, in the head's base frame.
  static cv::Vec3d in_head_frame(const HeadPose& head, const cv::Vec3d& p) {
    const cv::Vec4d& q = head.left_rotation;  // w, x, y, z: optical frame -> base frame
    const cv::Vec3d u(q[1], q[2], q[3]);
    const cv::Vec3d t = 2.0 * u.cross(p);
    return head.left_position + p + q[0] * t + u.cross(t);
  }
  // The matcher for this frame size: max_disparity beyond the frame's width
  // is searched up to the width less one (a disparity the frame cannot hold
  // only finds false matches at its edge), with a warning naming the numbers;
  // so is a fovea that cannot reach it without vergence. Remade only when the
  // frame's width changes.
  void fit_to_frame(const Retina& left) {
    const int width = left.source_size.width;
    if (stereo_ && width == fitted_width_) return;
    fitted_width_ = width;
    RetinaStereoConfig c = config_;
    if (width > 1 && c.max_disparity > width - 1) {
      log().warn("{}: max_disparity {} is larger than the frame ({} px wide): disparities up to {} px are searched",
                 name_, c.max_disparity, width, width - 1);
      c.max_disparity = width - 1;
    }
    if (!c.vergence && !left.geometry.empty() && !left.levels.empty()) {
      const double fovea_reach = (left.levels.back().cols - 1) * left.geometry.back().step_x;
      if (c.max_disparity > fovea_reach)
        log().warn(
            "{}: max_disparity {} is beyond what the fovea ({} px wide) can match without vergence ({} px); "
            "turn vergence on or use a wider retina",
            name_, c.max_disparity, left.levels.back().cols, fovea_reach);
    }
    stereo_ = std::make_unique<RetinaStereo>(c);
  }
  // The matcher's right->left map lies on the right image it matched, which
  // starts `offset` level pixels left of the left level (vergence's shift):
  // its column x + offset is the right frame at the left level's column x.
  static void on_left_geometry(const cv::Mat& reverse, int offset, cv::Mat& out) {
    out.create(reverse.size(), CV_32F);
    for (int y = 0; y < reverse.rows; ++y) {
      const float* in = reverse.ptr<float>(y);
      float* o = out.ptr<float>(y);
      for (int x = 0; x < reverse.cols; ++x) {
        const int from = x + offset;
        o[x] = from >= 0 && from < reverse.cols ? in[from] : -1.0f;
      }
    }
  }
  RetinaStereoConfig config_;
  double disparity_sigma_ = 0.3;
  std::string name_;
  int fitted_width_ = -1;
  StereoCalibration calibration_;
  std::unique_ptr<RetinaStereo> stereo_;
  std::vector<LevelDisparity> levels_;
};

}  // namespace

SACCADE_PLUGIN("stereo", StereoNode)
