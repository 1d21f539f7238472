#include "depth.hpp"
#include "retina_stereo.hpp"
#include "saccade/plugin.hpp"

#include "saccade/log.hpp"

namespace {

using namespace saccade;
using namespace saccade::stereo;

// What the node reads from its parameters: the matcher's configuration, the
// calibration for depth, and a calibration file that overrides it.
struct StereoNodeConfig {
  RetinaStereoConfig stereo;
  StereoCalibration calibration;
  std::string calibration_file;
  // The fixation disparity's standard deviation for its depth's: the RMS
  // error make bench-verge measures on the verging sim head (0.27 px).
  double disparity_sigma = 0.3;
};

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

  static void bind(ParamBinder<StereoNodeConfig>& b) {
    using C = StereoNodeConfig;
    using S = RetinaStereoConfig;
    using N = NccConfig;
    b.field("window", {3, 9}, "NCC window side (odd: 3 or 5 in the paper)", &C::stereo, &S::ncc, &N::window)
        .field("max_disparity", {1, 4096},
               "largest disparity searched, source pixels (larger than the frame's width: a warning, and the "
               "width less one is searched)",
               &C::stereo, &S::max_disparity)
        .field("min_score", {-1, 1}, "matches whose NCC is below this are invalid", &C::stereo, &S::ncc, &N::min_score)
        .field("min_texture", {0, 128}, "windows whose standard deviation is below this are not matched", &C::stereo,
               &S::ncc, &N::min_texture)
        .field("coarse_to_fine", "search inner levels only around the outer level's result", &C::stereo,
               &S::coarse_to_fine)
        .field("search_radius", {0, 32}, "coarse to fine: level pixels searched around the prediction", &C::stereo,
               &S::search_radius)
        .field("lr_check", "keep only matches the right->left search confirms", &C::stereo, &S::left_right_check)
        .field("lr_tolerance", {0, 16}, "left-right check tolerance, level pixels", &C::stereo, &S::lr_tolerance)
        .field("subpixel", "refine the peak with a parabola", &C::stereo, &S::ncc, &N::subpixel)
        .field("vergence",
               "software vergence: find the fixation disparity coarse to fine and sample the right frame there "
               "(needs the retinas' frames)",
               &C::stereo, &S::vergence)
        .field("fovea_radius", {1, 256}, "with vergence: fovea pixels searched around the fixation disparity",
               &C::stereo, &S::fovea_radius)
        .field("fovea_prediction",
               "with vergence: the fovea also searches around what the level outside it found at each pixel "
               "(surfaces farther than fovea_radius from the fixation)",
               &C::stereo, &S::fovea_prediction)
        .field("fovea_recheck", {0, 64},
               "fovea: each matched pixel's right window matched back over its disparity +- this (raw "
               "correlation), the pixel dropped where it prefers another (fewer wrong disparities, lower "
               "density; 0: off)",
               &C::stereo, &S::fovea_recheck)
        .field("fovea_flat_from_outer",
               "semi-global: fovea pixels whose windows are flat and whose aggregated costs prefer no disparity "
               "take the level outside's (interpolated)",
               &C::stereo, &S::fovea_flat_from_outer)
        .field("occlusion_check",
               "fovea: each matched pixel dropped where its right window correlates better with a nearer surface "
               "right of it on the row, or a farther one matched left of it, than with its own match (the right "
               "camera cannot see it; fewer wrong disparities, lower density)",
               &C::stereo, &S::occlusion_check)
        .field("fovea_range_check",
               "semi-global: fovea pixels whose aggregated minimum lies at an end of their search range are not "
               "matched (the truth may lie beyond it; fewer wrong disparities, lower density)",
               &C::stereo, &S::fovea_range_check)
        .field("pad", {0, 64}, "level pixels sampled around each level from the frames (0: the levels alone)",
               &C::stereo, &S::pad);
    bind_fills_and_depth(b);
  }

  // The fills of unmatched pixels, the semi-global aggregation, depth.
  static void bind_fills_and_depth(ParamBinder<StereoNodeConfig>& b) {
    using C = StereoNodeConfig;
    using S = RetinaStereoConfig;
    using N = NccConfig;
    b.field("fill", "give unmatched pixels the nearest matched disparity on their row (confidence 0)", &C::stereo,
            &S::fill)
        .field("fill_gaps", {0, 64},
               "give unmatched runs of at most this many pixels on a row the smaller of their ends' disparities "
               "where those agree within a level pixel (confidence 0; 0: off; before fill)",
               &C::stereo, &S::fill_gaps)
        .field("fill_occlusions",
               "give unmatched pixels a nearer surface hides from the right camera the farther surface's "
               "disparity (confidence 0; after fill_gaps, before fill)",
               &C::stereo, &S::fill_occlusions)
        .field("occlusion_slack", {0, 64},
               "fill_occlusions: level pixels beyond the hidden width (d_near - d_far) / step also filled", &C::stereo,
               &S::occlusion_slack)
        .field("semi_global",
               "semi-global aggregation of the NCC costs along sgm_paths paths: denser where windows alone are "
               "ambiguous or flat (min_score then does not apply)",
               &C::stereo, &S::ncc, &N::semi_global)
        .field("sgm_p1", {0, 8}, "semi-global: cost of a disparity step of one (NCC units)", &C::stereo, &S::ncc,
               &N::p1)
        .field("sgm_p2", {0, 8}, "semi-global: cost of a larger disparity step (NCC units)", &C::stereo, &S::ncc,
               &N::p2)
        .field("sgm_paths", {{"4", 4}, {"8", 8}},
               "semi-global: paths summed, along rows and columns (4) or also the diagonals (8: a little "
               "denser on Aloe's fovea, a third slower)",
               &C::stereo, &S::ncc, &N::paths)
        .field("focal", {0, 1e6}, "focal length of the rectified images, pixels (with baseline: depth)",
               &C::calibration, &StereoCalibration::focal_px)
        .field("baseline", {0, 100}, "distance between the cameras, metres", &C::calibration,
               &StereoCalibration::baseline_m)
        .field("calibration",
               "OpenCV calibration file (Q, or P2, or M1 and T; saccade calibrate writes them) giving focal length "
               "and baseline for depth; rectified retinas carry their own",
               &C::calibration_file)
        .field("disparity_sigma", {0, 100},
               "standard deviation of the fixation disparity, pixels, for its depth's (make bench-verge measures "
               "0.27 px RMS)",
               &C::disparity_sigma);
  }

  static Contract contract() {
    return Contract(
               "Disparity between a left and a right retina by normalized cross correlation, both ways, with a "
               "left-right check, sub-pixel peaks and a confidence, coarse to fine across levels. Pair the inputs "
               "with <sync inputs=\"left,right\"/>.")
        .ports(kLeft, kRight, kHead, kFixation, kGaze, kMaps)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    StereoNodeConfig c = ctx.config(&bind);
    if (c.stereo.ncc.window % 2 == 0) return Status::error("window must be odd");
    if (c.stereo.ncc.p2 < c.stereo.ncc.p1) return Status::error("sgm_p2 must not be smaller than sgm_p1");
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
    const LocatedPoint at = locate(model, fixation->pixel, fixation->disparity, disparity_sigma_);
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
