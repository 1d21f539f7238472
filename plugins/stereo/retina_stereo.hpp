#pragma once
// Stereo on a pair of retinas, coarse to fine: the outer level is searched over
// the whole range; every inner level searches only around what the level
// outside it found (mapped through the levels' geometry).
#include <cstdint>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "ncc.hpp"
#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::retina {
class RectifiedMap;
}

namespace saccade::stereo {

// The defaults are the densest configuration measured (semi-global along
// eight paths, gaps of up to two pixels and half-occluded strips filled, the
// fovea following the level outside it): make bench-stereo, docs/accuracy.md.
struct RetinaStereoConfig {
  NccConfig ncc;
  double max_disparity = 256;  // source pixels
  bool coarse_to_fine = true;
  int search_radius = 2;  // pixels of the outer level around its prediction
  bool left_right_check = true;
  float lr_tolerance = 1.0f;  // level pixels
  // Software vergence: the fixation disparity (at the fovea's centre) is found
  // coarse to fine with one large window per level, and each level then looks
  // at the right frame where the left level's scene is at that disparity
  // (needs the right retina's frame). Per-pixel searches run around it.
  bool vergence = true;
  cv::Size fixation_window{16, 12};  // level pixels of the window that finds the fixation disparity
  int fovea_radius = 6;              // fovea level with vergence: pixels searched around the fixation disparity
  // With vergence, the fovea also searches around what the level outside it
  // found at each pixel (coarse to fine, as the other levels do), so surfaces
  // farther than fovea_radius from the fixation's can be matched.
  bool fovea_prediction = true;
  // Each matched fovea pixel checked again the other way with the raw
  // correlation: its right window matched back over its disparity ± this many
  // pixels, and the pixel dropped where the window prefers another left pixel
  // (by more than lr_tolerance + 0.5). The fovea's pixels search only around
  // their predictions and the fixation, and a right pixel picks among the
  // pairs its left pixels searched, so the band a nearer surface hides from
  // the right camera can take the nearer surface's disparity and stay
  // consistent with itself; dropped, fill_occlusions gives it the farther
  // one. Fewer wrong disparities at a lower density (docs/accuracy.md). 0: off.
  int fovea_recheck = 0;
  // Level pixels sampled around each level from the frames (when the retinas
  // carry them), so that windows and matches at a level's edge see real
  // pixels; 0 matches on the level images alone.
  int pad = 8;
  // Give unmatched pixels (no texture, failed check) the disparity of the
  // nearest matched pixel on their row (the farther of the two neighbours), or
  // the fixation disparity; their confidence is 0 (matched: the NCC, > 0).
  bool fill = false;
  // Give unmatched runs of at most this many pixels on a row the smaller of
  // their two ends' disparities where those agree within a level pixel (one
  // surface, a gap its windows could not resolve); confidence 0. 0: off.
  // Before `fill`.
  int fill_gaps = 2;
  // Give unmatched pixels that a nearer surface hides from the right camera
  // the farther surface's disparity (confidence 0): on a row, in a run between
  // a far matched pixel (left) and a near one (right) whose disparities differ
  // by D source pixels, the pixels within D / step + `occlusion_slack` level
  // pixels of the near one. After `fill_gaps`, before `fill`.
  bool fill_occlusions = true;
  int occlusion_slack = 2;
  // The fovea's pixels whose windows are flat and whose aggregated costs
  // prefer no disparity (NccScratch::undecided, semi-global only) take the
  // level outside's disparity there (interpolated), which its larger cells
  // saw: in a textureless area (sky, a wall) the fovea's windows see only
  // noise, and the aggregation over the small fovea has nothing to carry in.
  bool fovea_flat_from_outer = true;
  // Each matched fovea pixel whose right window correlates better with
  // another surface than with its own match is dropped: a nearer one right
  // of it on the row (the fovea's or, beyond it, the outer levels'), or a
  // farther one left of it that was matched there at that disparity. The
  // right camera cannot see that pixel (docs/accuracy.md). Fewer wrong
  // disparities at a lower density, +0.1-0.4 ms per pair. Off by default.
  // Before the fills.
  bool occlusion_check = false;
  // Semi-global: a fovea pixel whose aggregated minimum lies at an end of its
  // range (around its prediction and the fixation) is not matched: its truth
  // may lie beyond what was searched (NccConfig::drop_range_edges). Fewer
  // wrong disparities at a lower density (docs/accuracy.md). Off by default.
  bool fovea_range_check = false;
  // The fovea's matched regions (4-neighbours within fovea_speckle_range level
  // pixels of each other) smaller than this many pixels are dropped, like
  // StereoSGBM's speckle filter (speckleWindowSize, speckleRange; it drops
  // regions of at most that many): a wrong match rarely spreads as far as a
  // surface does. Before the fills. Fewer wrong disparities at a lower
  // density (docs/accuracy.md). 0: off, the default; more than the fovea's
  // pixels (768 for 32x24) drops it all.
  int fovea_speckle_size = 0;
  double fovea_speckle_range = 1.0;
  // Keep, per level, the images actually compared (for comparisons with other
  // matchers on exactly the same pixels).
  bool keep_images = false;
};

// The plain matcher (the paper's NCC, coarse to fine, checked both ways: no
// semi-global aggregation, nothing filled, the fovea searched around the
// fixation alone): the defaults before the densest configuration became them,
// for the tests and comparisons that mean it.
inline RetinaStereoConfig plain_matcher_config() {
  RetinaStereoConfig c;
  c.ncc = plain_ncc_config();
  c.fill_gaps = 0;
  c.fill_occlusions = false;
  c.fovea_prediction = false;
  return c;
}

// The disparity at the point both retinas fixate, as found on each level.
struct Fixation {
  std::vector<double> per_level;  // source pixels; < 0 where not found
  double disparity = -1;          // the innermost level's estimate (source pixels), < 0 if none
  double score = -1;              // its NCC
  // The innermost level that found `disparity` (an outer one where the
  // fovea's window was flat: the disparity is then as precise as that
  // level's pixels are large, not the fovea's); -1 where none found it.
  int level() const {
    for (std::size_t k = per_level.size(); k-- > 0;)
      if (per_level[k] >= 0) return static_cast<int>(k);
    return -1;
  }
  // The fixation window of the innermost level that found `disparity` (the
  // fovea's, unless its window was flat), as the right frame sees it there,
  // matches back to it over the whole range (false: repeated texture or a
  // depth edge fooled the window, and the fovea's pixels follow the level
  // outside them instead of it; or nothing was found).
  bool confirmed = false;
};

struct LevelDisparity {
  cv::Mat disparity;          // CV_32F, source pixels, -1 invalid (left -> right)
  cv::Mat reverse;            // CV_32F, source pixels, -1 invalid (right -> left)
  cv::Mat score;              // CV_32F, NCC at the chosen disparity, -1 invalid
  double density = 0;         // share of matched pixels
  double filled_density = 0;  // share with a disparity, matched or filled
  double vergence = 0;        // source pixels the right level was moved by (0: not moved)
  double right_x0 = 0;        // left edge of the right level's region as matched, source pixels
  // With keep_images: the left and right images compared (the level with a
  // margin around it as far as the frames reach; the right one shifted by
  // `offset` level pixels),
  // and the level disparity range searched without a prediction.
  cv::Mat left_image, right_image;
  cv::Point margin;  // where the level's pixel (0, 0) is in them
  int offset = 0, range_lo = 0, range_hi = 0;
};

// Depth from disparity for rectified cameras: Z = focal * baseline / d.
struct StereoCalibration {
  double focal_px = 0;    // focal length of the rectified images, pixels
  double baseline_m = 0;  // distance between the optical centres, metres
  cv::Size image_size;    // the images the calibration was made for (empty: unknown)
  std::string path;       // the file it was read from (empty: parameters)
  bool valid() const { return focal_px > 0 && baseline_m > 0; }
  double depth(double disparity) const { return disparity > 0 ? focal_px * baseline_m / disparity : -1.0; }
};

// Reads focal length and baseline from an OpenCV calibration file (YAML or
// XML, as written by cv::stereoCalibrate / stereoRectify and OpenCV's
// stereo_calib sample): Q (the reprojection matrix), or P2 (the right
// rectified projection, P2(0,3) = -f B), or M1 with T. The calibration, or an
// error naming the file and what is missing.
Result<StereoCalibration> read_calibration(const std::string& path);

// Fills unmatched pixels (score <= 0) row by row from the nearest matched ones
// (the smaller of the two disparities), or with `fallback` (>= 0) on rows
// without any; filled pixels get score 0. Returns the share with a disparity.
double fill_holes(cv::Mat& disparity, cv::Mat& score, double fallback);

// Fills unmatched runs (disparity < 0) of at most `max_gap` pixels between
// two matched pixels of the same row whose disparities differ by at most
// `tolerance`, with the smaller of the two; filled pixels get score 0.
// Returns the share with a disparity.
double fill_gaps(cv::Mat& disparity, cv::Mat& score, int max_gap, double tolerance);

// Fills the unmatched pixels (disparity < 0) of each row that half occlusion
// explains: in a run between matched pixels a < b with d[b] > d[a] (b nearer),
// pixel i takes d[a] when b - i <= (d[b] - d[a]) / step + slack; such pixels
// get score 0. (Left of a near surface's edge, the right camera cannot see
// the (d[b] - d[a]) source pixels of the far one it hides.) Returns the share
// with a disparity.
double fill_occlusions(cv::Mat& disparity, cv::Mat& score, double step, int slack);

// Buffers drop_speckles reuses between calls.
struct SpeckleScratch {
  std::vector<uint8_t> seen;  // per pixel: already in a region
  std::vector<int> members;
};

// Drops (disparity and score -1) the matched pixels (disparity >= 0) of each
// region smaller than `min_size` pixels, a region being the pixels joined by
// 4-neighbours whose disparities differ by at most `max_step`. Returns the
// share with a disparity.
double drop_speckles(cv::Mat& disparity, cv::Mat& score, int min_size, double max_step, SpeckleScratch& scratch);

// Both retinas must have the same level size and steps; the right retina's
// regions may be shifted horizontally from the left's by whole level pixels
// (software vergence), or equal. Levels are 8-bit gray.
class RetinaStereo {
 public:
  explicit RetinaStereo(RetinaStereoConfig config) : config_(config) {}
  // Fills one LevelDisparity per level; an error says what is wrong with the pair.
  Status run(const Retina& left, const Retina& right, std::vector<LevelDisparity>& out);
  // The fixation disparity of the last run (with vergence).
  const Fixation& fixation() const { return fixation_; }
  // Finds the fixation disparity, coarse to fine, by correlating the central
  // window of each left level with the right frame sampled the same way;
  // coarse to fine, all levels but the fovea (run finds the fovea's from the
  // level outside it as matched). With the left frame, a fovea's fixation
  // found here is also confirmed (Fixation::confirmed).
  void find_fixation(const Retina& left, const cv::Mat* left_frame, const cv::Mat& right_frame, Fixation& out);

 private:
  // Buffers per level: the levels' padded sizes differ, and sharing one set
  // would reallocate on every level of every frame.
  struct LevelScratch {
    cv::Mat strip;
    cv::Mat left_padded, right_padded, lo_padded, hi_padded;
    cv::Mat lr, lr_score, rl, rl_score, valid;  // the matcher's results (padded when the level is)
    cv::Rect inside;                            // where the level lies in them
    NccScratch ncc;
  };
  // What a level's steps share, and the images it matches (retina_stereo.cpp).
  struct LevelPlan;
  struct LevelImages;
  // Search ranges for level k's left pixels, from the level outside it. With
  // `fixation` (level disparities lo..hi), pixels without a prediction search
  // it alone and, with `widen`, every prediction is widened to cover it.
  struct Span {
    int lo, hi;
  };
  void predict(const std::vector<LevelDisparity>& out, const Retina& left, std::size_t k, int full_lo, int full_hi,
               int offset, const Span* fixation, bool widen, cv::Mat& lo, cv::Mat& hi);
  int around_fixation_range(bool around, int full, bool low) const;
  void sample_around_level(const cv::Mat& frame, bool right, const cv::Mat& level, cv::Point2d origin,
                           const LevelGeometry& g, cv::Point at, cv::Size padded, cv::Range cols, bool crop,
                           cv::Mat& out) const;
  // One level's rule on the left or right frame: the plain grid, or the
  // rectified one when the retinas were rectified (rectified.hpp).
  void sample_frame(const cv::Mat& frame, bool right, double x0, double y0, double step_x, double step_y, cv::Size size,
                    bool crop, cv::Mat& out) const;
  // Keeps the pair's rectified maps; an error says why their rectifications
  // do not match or cannot be sampled.
  Status take_rectification(const Retina& left, const Retina& right);
  int correlate_window(const cv::Mat& window, const cv::Mat& strip, double wm, double ws, int s_lo, int s_hi);
  // The fixation search's best shift (level pixels, sub-pixel) of the left
  // level's `window` over the right frame within `span`, and its NCC.
  struct WindowMatch {
    double shift = -1;
    double score = -2;
  };
  // The fovea's fixation, from the level outside it as matched (coarse to fine).
  void fovea_fixation(const Retina& left, const LevelDisparity& outer, const cv::Mat* left_frame,
                      const cv::Mat& right_frame, Fixation& out);
  // Sets out.confirmed: whether the fixation matches back at the innermost
  // level that found it (no left frame to check against: true).
  void confirm_fixation(const Retina& left, const cv::Mat* left_frame, const cv::Mat& right_frame, Fixation& out);
  // The disparity (level pixels) at which the right frame's window `shift`
  // level pixels left of `window` best matches the left frame over the whole
  // range (`shift` again when the pair agrees); < 0 where it cannot be matched.
  double reverse_shift(const Retina& left, std::size_t k, cv::Rect window, const cv::Mat& left_frame,
                       const cv::Mat& right_frame, double shift);
  // Level k's fixation window searched over `span` (and, with `second_guess`,
  // around a verging head's own fixation): true, and `out` updated, when it
  // matched.
  bool take_fixation(const Retina& left, std::size_t k, const cv::Mat& right_frame, Span span, bool second_guess,
                     Fixation& out);
  static constexpr double kMinFixationScore = 0.3;
  // How much better the fovea's whole-range correlation must be to overrule
  // the surfaces the level outside saw (fovea_fixation).
  static constexpr double kFullRangeMargin = 0.2;
  // How far (level pixels) the fixation's right window may match back from
  // where it was matched.
  static constexpr double kMatchBackTolerance = 1.5;
  WindowMatch match_window(const Retina& left, std::size_t k, cv::Rect window, const cv::Mat& right_frame, Span span);
  // A rectified verging pair: the disparity where the optical axes meet (< 0: none).
  double vergence_prior(const Retina& left) const;
  // Run's steps on one level.
  void plan_level(const Retina& left, const Retina& right, const cv::Mat* right_frame, LevelPlan& plan,
                  LevelDisparity& level);
  void search_ranges(const LevelPlan& plan, const std::vector<LevelDisparity>& out, const Retina& left, cv::Mat& lo,
                     cv::Mat& hi);
  LevelImages level_images(const LevelPlan& plan, const std::vector<LevelDisparity>& out, const Retina& left);
  LevelImages padded_images(const LevelPlan& plan, const std::vector<LevelDisparity>& out, const Retina& left,
                            const Retina& right, const cv::Mat& left_frame, const cv::Mat& right_frame);
  void sample_padded(const LevelPlan& plan, const Retina& left, const Retina& right, const cv::Mat& left_frame,
                     const cv::Mat& right_frame, cv::Size padded, cv::Rect inside, LevelScratch& ls) const;
  void match_level(const LevelImages& images, const LevelPlan& plan, double step, LevelDisparity& level);
  void fill_level(const LevelPlan& plan, double step, LevelDisparity& level);
  void flat_from_outer(const Retina& left, std::vector<LevelDisparity>& out, std::size_t k);
  void drop_hidden(const Retina& left, const cv::Mat& left_frame, const cv::Mat& right_frame,
                   std::vector<LevelDisparity>& out, std::size_t k);
  struct HiddenScratch {
    std::vector<float> row, nearest_right, farthest_left, outer_left, outer_left_tolerance;
    float nearest = -1;             // the nearest surface on the row or right of it (sizes the left band)
    cv::Mat left, right;            // buffers for the row's bands of the frames, which only grow
    cv::Mat left_band, right_band;  // views of them
  };
  float hidden_row(const Retina& left, const std::vector<LevelDisparity>& out, std::size_t k, int y);
  bool hidden_pixel(int x, int own, int cols, int reach);
  HiddenScratch hidden_;
  SpeckleScratch speckles_;
  RetinaStereoConfig config_;
  Fixation fixation_;
  std::vector<LevelScratch> level_scratch_;
  std::vector<int32_t> column_sum_, column_sq_, products_, strip32_;
  std::vector<float> samples_, around_center_;
  std::vector<int> outer_col_, outer_center_;
  cv::Mat right_level_, right_gray_, left_gray_, reverse_window_;
  cv::Mat lo_, hi_;
  // The retinas' rectified grids (null when they are plain), made again only
  // when a rectification changes.
  std::shared_ptr<const retina::RectifiedMap> left_map_, right_map_;
};

}  // namespace saccade::stereo
