#include "stereo_params.hpp"

namespace saccade::stereo {
namespace {

// The fills of unmatched pixels, the semi-global aggregation, depth.
void bind_fills_and_depth(ParamBinder<StereoNodeConfig>& b) {
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
      .field("sgm_p1", {0, 8}, "semi-global: cost of a disparity step of one (NCC units)", &C::stereo, &S::ncc, &N::p1)
      .field("sgm_p2", {0, 8}, "semi-global: cost of a larger disparity step (NCC units)", &C::stereo, &S::ncc, &N::p2)
      .field("sgm_flat_uniqueness", {0, 1},
             "semi-global: a pick without correlation (its window or its partner's flat) is undecided where "
             "another disparity, more than one away, aggregates within this share of the best (see "
             "fovea_flat_from_outer)",
             &C::stereo, &S::ncc, &N::flat_uniqueness)
      .field("sgm_paths", {{"4", 4}, {"8", 8}},
             "semi-global: paths summed, along rows and columns (4) or also the diagonals (8: a little "
             "denser on Aloe's fovea, a third slower)",
             &C::stereo, &S::ncc, &N::paths)
      .field("focal", {0, 1e6}, "focal length of the rectified images, pixels (with baseline: depth)", &C::calibration,
             &StereoCalibration::focal_px)
      .field("baseline", {0, 100}, "distance between the cameras, metres", &C::calibration,
             &StereoCalibration::baseline_m)
      .field("calibration",
             "OpenCV calibration file (Q, or P2, or M1 and T; saccade calibrate writes them) giving focal length "
             "and baseline for depth; rectified retinas carry their own",
             &C::calibration_file)
      .field("disparity_sigma", {0, 100},
             "standard deviation of the fovea's fixation disparity, pixels, for its depth's (make bench-verge "
             "measures 0.27 px RMS); a fixation found on a coarser level (the fovea's window flat) has it times "
             "that level's step",
             &C::disparity_sigma);
}

}  // namespace

void bind_stereo_params(ParamBinder<StereoNodeConfig>& b) {
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
      .field("fovea_radius", {1, 256}, "with vergence: fovea pixels searched around the fixation disparity", &C::stereo,
             &S::fovea_radius)
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
      .field("fovea_speckle_size", {0, 100000},
             "fovea: matched regions (neighbours within fovea_speckle_range) smaller than this many pixels are "
             "dropped, like StereoSGBM's speckle filter (fewer wrong disparities, lower density; the fovea has "
             "768 pixels at 32x24; 0: off)",
             &C::stereo, &S::fovea_speckle_size)
      .field("fovea_speckle_range", {0.1, 1000},
             "fovea_speckle_size: level pixels of disparity by which neighbours of one region may differ", &C::stereo,
             &S::fovea_speckle_range)
      .field("pad", {0, 64}, "level pixels sampled around each level from the frames (0: the levels alone)", &C::stereo,
             &S::pad);
  bind_fills_and_depth(b);
}

Status check_stereo_params(const StereoNodeConfig& c) {
  if (c.stereo.ncc.window % 2 == 0) return Status::error("window must be odd");
  if (c.stereo.ncc.p2 < c.stereo.ncc.p1) return Status::error("sgm_p2 must not be smaller than sgm_p1");
  return {};
}

}  // namespace saccade::stereo
