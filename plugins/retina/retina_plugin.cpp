#include <cmath>

#include <opencv2/imgproc.hpp>

#include "head_rectification.hpp"
#include "rectified.hpp"
#include "retina.hpp"
#include "saccade/log.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::retina;

struct RetinaNodeConfig {
  RetinaConfig retina;
  // Rectified sampling for a stereo pair (rectified.hpp): the calibration file,
  // or without one the head model's ideal cameras of this field of view.
  bool rectify = false;
  std::string calibration;
  double model_hfov_deg = 60.0;  // capture.sim_head's default
  kinematics::HeadGeometry geometry;
};

class RetinaNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<Image> kImage{"image", "8-bit gray or BGR frame"};
  static constexpr SideIn<Region> kFovea{"fovea", "moves the fovea (its centre); the newest value is used"};
  static constexpr SideIn<JointState> kJoints{
      "joints",
      "with rectify: the head's joints (neck, vergence left, tilt left, vergence right, tilt right), "
      "radians; the newest value is used (none: the joints' zero)"};
  static constexpr Out<Retina> kRetina{"retina", "levels (0 outermost) with their geometry"};

  static void bind(ParamBinder<RetinaNodeConfig>& b) {
    using C = RetinaNodeConfig;
    using R = RetinaConfig;
    using G = kinematics::HeadGeometry;
    b.field("levels", {1, 16}, "number of levels", &C::retina, &R::levels)
        .field("size", "size of every level", &C::retina, &R::size)
        .field("mode", {{"five_point", SamplingMode::kFivePoint}, {"area_mean", SamplingMode::kAreaMean}},
               "the paper's five-point mean, or the exact cell mean", &C::retina, &R::mode)
        .field("rectify",
               "sample along the stereo pair's rectified geometry for the current joints (the image's camera_id: 0 "
               "left, 1 right), so that the two retinas' rows are epipolar lines at any vergence",
               &C::rectify)
        .field("calibration",
               "with rectify: the head's calibration file (saccade calibrate); empty: the head model's "
               "ideal cameras (model_hfov)",
               &C::calibration)
        .field("model_hfov", {1, 170},
               "with rectify and no calibration: the ideal cameras' horizontal field of view, degrees (as "
               "capture.sim_head's hfov)",
               &C::model_hfov_deg)
        .field("l1", {0, 10}, "with rectify, m: neck axis to the vergence axis (the paper's L1)", &C::geometry, &G::l1)
        .field("l2", {0, 10}, "with rectify, m: height of the tilt axis (L2)", &C::geometry, &G::l2)
        .field("l3", {0, 10}, "with rectify, m: tilt axis to the camera (L3)", &C::geometry, &G::l3);
  }

  static Contract contract() {
    return Contract(
               "Multi-resolution retina (Algorithm 1): L levels of WxH, the innermost a crop of the fovea, "
               "the outer ones five-point means over growing regions up to the whole frame.")
        .ports(kImage, kFovea, kJoints, kRetina)
        .params(&bind)
        // Unbound: it has no default (the frame's centre), which a struct field cannot express.
        .param_point("fovea", std::nullopt, "initial fovea centre x,y in source pixels (default: the frame's centre)")
        .param_enum("channels", "same", {"same", "gray"},
                    "sample the frame as it comes, or convert colour to gray first");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    config_ = ctx.config(&bind);
    const RetinaConfig& config = config_.retina;
    if (config.size.width < 3 || config.size.height < 3) return Status::error("size must be at least 3x3");
    sampler_ = std::make_unique<RetinaSampler>(config);
    if (config_.rectify) {
      if (config.mode != SamplingMode::kFivePoint) return Status::error("rectify needs mode five_point");
      if (!config_.calibration.empty()) {
        Result<kinematics::HeadCalibration> read = kinematics::read_head_calibration(config_.calibration);
        if (!read.ok()) return read.status();
        calibration_ = std::move(read).value();
        if (calibration_.left_distortion.size() > 14 || calibration_.right_distortion.size() > 14)
          return Status::error(config_.calibration + ": more than 14 distortion coefficients");
      }
    }
    short_joints_ = &ctx.counter("short_joint_states");
    if (p.has("fovea")) initial_fovea_ = p.get_point("fovea");
    gray_ = p.get_string("channels") == "gray";
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto image = ctx.get(kImage);
    const cv::Mat* frame = &image->mat;
    if (gray_ && frame->channels() == 3) {
      cv::cvtColor(*frame, gray_frame_, cv::COLOR_BGR2GRAY);
      frame = &gray_frame_;
    }
    if (Status fits = sampler_->check(*frame); !fits.ok()) return fits;
    cv::Point2d fovea(frame->cols / 2.0, frame->rows / 2.0);
    if (initial_fovea_) fovea = *initial_fovea_;
    if (auto f = ctx.get(kFovea)) fovea = f->center;
    auto retina = ctx.make(kRetina);
    // A zero-copy DDS edge downstream: the levels are made in its frame ring, in one buffer.
    if (cv::MatAllocator* ring = ctx.frame_allocator(kRetina))
      create_together(ring, static_cast<std::size_t>(sampler_->config().levels), sampler_->config().size, frame->type(),
                      retina->levels);
    if (config_.rectify) {
      if (Status st = update_rectification(ctx, frame->size(), image->camera_id); !st.ok()) return st;
      if (Status sampled = sample_rectified(config_.retina, *frame, *map_, fovea, *retina); !sampled.ok())
        return sampled;
    } else {
      sampler_->sample(*frame, fovea, *retina);
    }
    retina->camera_id = image->camera_id;
    retina->source = image;
    ctx.emit(kRetina, std::move(retina));
    return {};
  }

 private:
  // The rectification for the newest joints, made again only when they or the
  // frame's size change.
  Status update_rectification(ProcessContext& ctx, cv::Size frame, int camera_id) {
    kinematics::HeadJoints q;
    if (auto joints = ctx.get(kJoints)) {
      const std::vector<double>& p = joints->position;
      if (p.size() >= 5)
        q = {p[0], p[1], p[2], p[3], p[4]};
      else
        short_joints_->fetch_add(1, std::memory_order_relaxed);
      if (Status finite = check_joints(q); !finite.ok()) return finite;
    }
    const bool same = map_ && frame == rectified_size_ && camera_id == rectified_camera_ && q.neck == joints_.neck &&
                      q.vergence_left == joints_.vergence_left && q.tilt_left == joints_.tilt_left &&
                      q.vergence_right == joints_.vergence_right && q.tilt_right == joints_.tilt_right;
    if (same) return {};
    if (config_.calibration.empty()) {
      const double focal = (frame.width / 2.0) / std::tan(config_.model_hfov_deg * CV_PI / 360.0);
      calibration_ = model_calibration(frame, focal, config_.geometry);
    } else if (Status fits = kinematics::check_frame_size(calibration_, frame); !fits.ok()) {
      return fits;
    }
    if (camera_id != 0 && camera_id != 1)
      return Status::error("rectify: the image's camera_id is " + std::to_string(camera_id) +
                           "; a stereo pair's cameras are 0 (left) and 1 (right)");
    const Result<PairRectification> pair = rectify_pair(calibration_, config_.geometry, q);
    if (!pair.ok()) return pair.status();
    map_.emplace(camera_id == 0 ? pair->left : pair->right);
    if (!map_->status().ok()) return Status::error(calibration_.path + ": " + map_->status().message());
    joints_ = q;
    rectified_size_ = frame;
    rectified_camera_ = camera_id;
    return {};
  }

  // A joint that is not a number cannot be rectified for (an error); one
  // beyond the head's usual limits is warned about once (the head node has
  // the real ones).
  Status check_joints(const kinematics::HeadJoints& q) {
    const std::pair<const char*, double> joints[] = {{"neck", q.neck},
                                                     {"vergence_left", q.vergence_left},
                                                     {"tilt_left", q.tilt_left},
                                                     {"vergence_right", q.vergence_right},
                                                     {"tilt_right", q.tilt_right}};
    const kinematics::HeadLimits limits;
    const double bound[] = {limits.neck_max, limits.vergence_max, limits.tilt_max, limits.vergence_max,
                            limits.tilt_max};
    for (std::size_t i = 0; i < 5; ++i) {
      const auto& [name, value] = joints[i];
      if (!std::isfinite(value))
        return Status::error(std::string("rectify: joint ") + name + " is " + std::to_string(value));
      if (std::abs(value) > bound[i] && !warned_limits_) {
        warned_limits_ = true;
        log().warn("retina: rectifying for joint {} at {} rad, beyond the head's usual +-{} rad", name, value,
                   bound[i]);
      }
    }
    return {};
  }

  RetinaNodeConfig config_;
  bool warned_limits_ = false;
  kinematics::HeadCalibration calibration_;
  std::optional<RectifiedMap> map_;
  kinematics::HeadJoints joints_;
  cv::Size rectified_size_;
  int rectified_camera_ = -1;
  std::atomic<uint64_t>* short_joints_ = nullptr;
  std::unique_ptr<RetinaSampler> sampler_;
  std::optional<cv::Point2d> initial_fovea_;
  cv::Mat gray_frame_;
  bool gray_ = false;
};

}  // namespace

SACCADE_PLUGIN("retina", RetinaNode)
