#pragma once
// Stereo matching by normalized cross correlation (the paper's correlation
// coefficient) on small images: the building blocks of the stereo plugin.
//
// Convention: a left-image pixel x matches the right image at x - d (d >= 0 for
// points in front of the cameras); a right-image pixel x matches the left image
// at x + d. Disparities are in the images' own pixels.
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

namespace saccade::stereo {

struct NccConfig {
  int window = 5;            // odd: 3 or 5 in the paper
  bool subpixel = true;      // parabola through the scores around the best
  float min_score = 0.5f;    // below this the match is invalid
  float min_texture = 2.0f;  // window standard deviation (gray levels) below which nothing can be matched
  // Semi-global aggregation (ncc_match_cross only): each pixel's costs
  // (1 - NCC) are summed with those along four paths through the image,
  // which add p1 for a disparity step of one and p2 for a larger one, so that
  // where a window alone is ambiguous or flat its neighbours decide. The
  // score floor then does not apply; the left-right check still does. On by
  // default, along eight paths (make bench-stereo: docs/accuracy.md).
  bool semi_global = true;
  float p1 = 0.2f, p2 = 0.8f;
  int paths = 8;                  // semi-global: 4 (along rows and columns) or 8 (and along the diagonals)
  float flat_uniqueness = 0.05f;  // semi-global: see NccScratch::undecided
  // Semi-global: a left pixel whose aggregated minimum lies at an end of its
  // range is not matched (the minimum may lie beyond what was searched),
  // unless that end is one of the whole search's, range_floor or
  // range_ceiling, beyond which there is nothing.
  bool drop_range_edges = false;
  int range_floor = std::numeric_limits<int>::min(), range_ceiling = std::numeric_limits<int>::max();
};

// The paper's matcher: the best window correlation per pixel, without
// semi-global aggregation (the defaults aggregate along eight paths).
inline NccConfig plain_ncc_config() {
  NccConfig c;
  c.semi_global = false;
  c.paths = 4;
  return c;
}

enum class Direction { kLeftToRight, kRightToLeft };

// Buffers ncc_match reuses between calls, so a caller that keeps one allocates
// nothing in steady state.
struct NccScratch {
  cv::Mat ref_mean, ref_std, other_mean, other_std;
  cv::Mat ref_f, other_f;
  cv::Mat none_lo, none_hi, unused_d, unused_s;
  std::vector<float> scores, col, col2;
  std::vector<int> span_lo, span_hi;  // per disparity, the left columns the sweep computed
  // The sweep's correlations, one plane per disparity: at the left pixels
  // (volume) and at the right ones (volume_rl).
  std::vector<float> volume, volume_rl;
  std::vector<float> cost, aggregated, path, path_rows;  // semi-global aggregation
  std::vector<int> right_best;                           // its right pixels' picks, per row
  std::vector<float> right_cost;
  // The aggregation's left pixels whose pick has no correlation (their
  // window or their partner's flat, or a pair the sweep did not reach) and
  // whose aggregated costs have another disparity (more than one away)
  // within NccConfig::flat_uniqueness of the best: decided by nothing (255).
  // All 0 where the aggregation did not run.
  cv::Mat undecided;
};

// Per-pixel search: for pixel (x, y) of the reference image, disparities in
// [lo(y, x), hi(y, x)] (CV_32S, may be negative) are tried. Writes disparity
// (CV_32F) and score (CV_32F; the NCC at the chosen disparity). Invalid pixels
// have score -1 (and disparity -1, which with negative ranges is ambiguous: use
// the score).
// Windows reaching beyond either image are not used.
void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo, const cv::Mat& hi,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score, NccScratch& scratch);
void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo, const cv::Mat& hi,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score);

// Both directions in one sweep: the correlation of left pixel x with right
// pixel x - d is one number whether the left pixel searches (disparity d) or
// the right one does (disparity d), so one sweep over the disparities serves
// both searches, each with its own ranges. ncc_match is this with the other
// direction's ranges empty.
void ncc_match_both(const cv::Mat& left, const cv::Mat& right, const cv::Mat& lo_lr, const cv::Mat& hi_lr,
                    const cv::Mat& lo_rl, const cv::Mat& hi_rl, const NccConfig& config, cv::Mat& disparity_lr,
                    cv::Mat& score_lr, cv::Mat& disparity_rl, cv::Mat& score_rl, NccScratch& scratch);

// Left->right over per-pixel ranges and right->left over exactly the pairs
// the left pixels search: each right pixel takes its best among the left
// pixels whose search reached it. A left pixel's match is then always among
// its right pixel's candidates, so the left-right check compares like with
// like, and the sweep computes nothing for the right side alone.
void ncc_match_cross(const cv::Mat& left, const cv::Mat& right, const cv::Mat& lo, const cv::Mat& hi,
                     const NccConfig& config, cv::Mat& disparity_lr, cv::Mat& score_lr, cv::Mat& disparity_rl,
                     cv::Mat& score_rl, NccScratch& scratch);

// The same, plainly: every window summed pixel by pixel in double precision.
// The reference ncc_match is tested against. ncc_match itself sweeps the
// disparities, summing the products of each in sliding windows (box sums), so
// a candidate costs a few operations instead of a window's worth.
void ncc_match_reference(const cv::Mat& left, const cv::Mat& right, Direction direction, const cv::Mat& lo,
                         const cv::Mat& hi, const NccConfig& config, cv::Mat& disparity, cv::Mat& score,
                         NccScratch& scratch);

// The same over a fixed range [d_min, d_max] for every pixel.
void ncc_match(const cv::Mat& left, const cv::Mat& right, Direction direction, int d_min, int d_max,
               const NccConfig& config, cv::Mat& disparity, cv::Mat& score);

// Clears `valid` (CV_8U) where the left->right match (score > -1) has no
// right->left match, read at the matched pixel, within `tolerance` (signed
// disparities allowed). Returns the share of matched pixels kept. Only the
// left pixels inside `region` (default: all) are checked; their matches may
// be read anywhere on the row.
double left_right_check(const cv::Mat& lr, const cv::Mat& lr_score, const cv::Mat& rl, const cv::Mat& rl_score,
                        float tolerance, cv::Mat& valid, cv::Rect region = {});

// Whether the matcher may use AVX-512 (its sweep, pick and left-right check)
// where the CPU has it (it does by default, unless SACCADE_AVX512=0 is in the
// environment); off, the AVX2 or baseline code runs, which gives the same
// results to the bit (tests compare them). Returns whether the AVX-512 code
// can run here (the CPU has it and the environment does not say no). Not for
// use while another thread matches.
bool allow_avx512(bool allowed);

// Correlation coefficient of two w x w windows centred at (x0, y0) and (x1, y1)
// (the plain definition, for tests).
double ncc_reference(const cv::Mat& a, int x0, int y0, const cv::Mat& b, int x1, int y1, int window);

}  // namespace saccade::stereo
