#include "retina_stereo.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::stereo;

class StereoNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static Contract contract() {
    return Contract("Disparity between a left and a right retina by normalized cross correlation, both ways, with a "
                    "left-right check, sub-pixel peaks and a confidence, coarse to fine across levels. Pair the inputs "
                    "with <sync inputs=\"left,right\"/>.")
        .input<Retina>("left", "left retina (8-bit gray)")
        .input<Retina>("right", "right retina, same level size; regions equal or shifted by whole level pixels")
        .output<Region>("fixation", "the fixation disparity (score, source pixels; -1 when not found) at the left "
                                    "fovea (center), and its depth when calibrated: for the head's vergence")
        .output<FeatureMaps>("maps", "per level on the left geometry: disparity (source pixels, -1 invalid), "
                                     "disparity_rl (right->left, on the right geometry), confidence (NCC)")
        .param_int("window", 5, 3, 9, "NCC window side (odd: 3 or 5 in the paper)")
        .param_double("max_disparity", 256.0, 1.0, 4096.0, "largest disparity searched, source pixels")
        .param_double("min_score", 0.5, -1.0, 1.0, "matches whose NCC is below this are invalid")
        .param_double("min_texture", 2.0, 0.0, 128.0, "windows whose standard deviation is below this are not matched")
        .param_bool("coarse_to_fine", true, "search inner levels only around the outer level's result")
        .param_int("search_radius", 2, 0, 32, "coarse to fine: level pixels searched around the prediction")
        .param_bool("lr_check", true, "keep only matches the right->left search confirms")
        .param_double("lr_tolerance", 1.0, 0.0, 16.0, "left-right check tolerance, level pixels")
        .param_bool("subpixel", true, "refine the peak with a parabola")
        .param_bool("vergence", true,
                    "software vergence: find the fixation disparity coarse to fine and sample the right frame there "
                    "(needs the retinas' frames)")
        .param_int("fovea_radius", 6, 1, 256, "with vergence: fovea pixels searched around the fixation disparity")
        .param_bool("fovea_prediction", false,
                    "with vergence: the fovea also searches around what the level outside it found at each pixel "
                    "(surfaces farther than fovea_radius from the fixation)")
        .param_int("pad", 8, 0, 64, "level pixels sampled around each level from the frames (0: the levels alone)")
        .param_bool("fill", false, "give unmatched pixels the nearest matched disparity on their row (confidence 0)")
        .param_int("fill_gaps", 0, 0, 64,
                   "give unmatched runs of at most this many pixels on a row the smaller of their ends' disparities "
                   "where those agree within a level pixel (confidence 0; 0: off; before fill)")
        .param_bool("fill_occlusions", false,
                    "give unmatched pixels a nearer surface hides from the right camera the farther surface's "
                    "disparity (confidence 0; after fill_gaps, before fill)")
        .param_int("occlusion_slack", 2, 0, 64,
                   "fill_occlusions: level pixels beyond the hidden width (d_near - d_far) / step also filled")
        .param_bool("semi_global", false,
                    "semi-global aggregation of the NCC costs along four paths: denser where windows alone are "
                    "ambiguous or flat (min_score then does not apply)")
        .param_double("sgm_p1", 0.2, 0.0, 8.0, "semi-global: cost of a disparity step of one (NCC units)")
        .param_double("sgm_p2", 0.8, 0.0, 8.0, "semi-global: cost of a larger disparity step (NCC units)")
        .param_enum("sgm_paths", "4", {"4", "8"},
                    "semi-global: paths summed, along rows and columns (4) or also the diagonals (8: a little "
                    "denser on Aloe's fovea, a third slower)")
        .param_double("focal", 0.0, 0.0, 1e6, "focal length of the rectified images, pixels (with baseline: depth)")
        .param_double("baseline", 0.0, 0.0, 100.0, "distance between the cameras, metres")
        .param_string("calibration", "",
                      "OpenCV calibration file (Q, or P2, or M1 and T) giving focal length and baseline for depth");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    left_ = ctx.input<Retina>("left");
    right_ = ctx.input<Retina>("right");
    out_ = ctx.output<FeatureMaps>("maps");
    RetinaStereoConfig c;
    c.ncc.window = static_cast<int>(p.get_int("window"));
    if (c.ncc.window % 2 == 0) return Status::error("window must be odd");
    c.ncc.min_score = static_cast<float>(p.get_double("min_score"));
    c.ncc.min_texture = static_cast<float>(p.get_double("min_texture"));
    c.ncc.subpixel = p.get_bool("subpixel");
    c.max_disparity = p.get_double("max_disparity");
    c.coarse_to_fine = p.get_bool("coarse_to_fine");
    c.search_radius = static_cast<int>(p.get_int("search_radius"));
    c.left_right_check = p.get_bool("lr_check");
    c.lr_tolerance = static_cast<float>(p.get_double("lr_tolerance"));
    c.vergence = p.get_bool("vergence");
    c.fovea_radius = static_cast<int>(p.get_int("fovea_radius"));
    c.pad = static_cast<int>(p.get_int("pad"));
    c.fill = p.get_bool("fill");
    c.fill_gaps = static_cast<int>(p.get_int("fill_gaps"));
    c.fill_occlusions = p.get_bool("fill_occlusions");
    c.occlusion_slack = static_cast<int>(p.get_int("occlusion_slack"));
    c.fovea_prediction = p.get_bool("fovea_prediction");
    c.ncc.semi_global = p.get_bool("semi_global");
    c.ncc.p1 = static_cast<float>(p.get_double("sgm_p1"));
    c.ncc.p2 = static_cast<float>(p.get_double("sgm_p2"));
    if (c.ncc.p2 < c.ncc.p1) return Status::error("sgm_p2 must not be smaller than sgm_p1");
    c.ncc.paths = p.get_string("sgm_paths") == "8" ? 8 : 4;
    calibration_.focal_px = p.get_double("focal");
    calibration_.baseline_m = p.get_double("baseline");
    if (const std::string file = p.get_string("calibration"); !file.empty()) {
      if (std::string e = read_calibration(file, calibration_); !e.empty()) return Status::error(e);
    } else if ((calibration_.focal_px > 0) != (calibration_.baseline_m > 0)) {
      return Status::error("depth needs both focal and baseline (or a calibration file)");
    }
    fixation_out_ = ctx.output<Region>("fixation");
    stereo_ = std::make_unique<RetinaStereo>(c);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto l = ctx.get(left_);
    auto r = ctx.get(right_);
    if (std::string e = stereo_->run(*l, *r, levels_); !e.empty()) return Status::error(e);
    auto maps = ctx.make(out_);
    maps->retina = l;
    if (calibration_.valid())
      maps->set_layout({"disparity", "disparity_rl", "confidence", "depth"}, levels_.size());
    else
      maps->set_layout({"disparity", "disparity_rl", "confidence"}, levels_.size());
    for (std::size_t k = 0; k < levels_.size(); ++k) {
      levels_[k].disparity.copyTo(maps->maps[0][k]);
      levels_[k].reverse.copyTo(maps->maps[1][k]);
      levels_[k].score.copyTo(maps->maps[2][k]);
      if (!calibration_.valid()) continue;
      cv::Mat& depth = maps->maps[3][k];
      depth.create(levels_[k].disparity.size(), CV_32F);
      for (int y = 0; y < depth.rows; ++y)
        for (int x = 0; x < depth.cols; ++x)
          depth.at<float>(y, x) = static_cast<float>(calibration_.depth(levels_[k].disparity.at<float>(y, x)));
    }
    ctx.emit(out_, std::move(maps));
    auto fixation = ctx.make(fixation_out_);
    const cv::Rect fovea = l->geometry.back().region;
    fixation->center = cv::Point2d(fovea.x + fovea.width / 2.0, fovea.y + fovea.height / 2.0);
    fixation->size = cv::Size2d(fovea.size());
    fixation->score = stereo_->fixation().disparity;
    fixation->depth = calibration_.valid() ? calibration_.depth(stereo_->fixation().disparity) : -1.0;
    fixation->camera_id = l->camera_id;
    fixation->label = "fixation";
    ctx.emit(fixation_out_, std::move(fixation));
    return {};
  }

 private:
  InputHandle<Retina> left_, right_;
  OutputHandle<FeatureMaps> out_;
  OutputHandle<Region> fixation_out_;
  StereoCalibration calibration_;
  std::unique_ptr<RetinaStereo> stereo_;
  std::vector<LevelDisparity> levels_;
};

}  // namespace

SACCADE_PLUGIN("stereo", StereoNode)
