#include "retina_stereo.hpp"

#include <cmath>
#include <string>

#include "saccade/fill.hpp"

namespace saccade::stereo {

// Search ranges for level k of the reference image: around the disparity the
// level outside found at the same source point, or the whole range where it
// found none. `offset` is minus the right region's shift from the left's, in
// level pixels: level disparity = source disparity / step + offset, both ways.
void RetinaStereo::predict(const std::vector<LevelDisparity>& out, const Retina& ref, std::size_t k, bool reverse,
                           const LevelGeometry& g, int full_lo, int full_hi, int offset) {
  const cv::Size size = ref.levels[k].size();
  lo_.create(size, CV_32S);
  hi_.create(size, CV_32S);
  fill(lo_, full_lo);
  fill(hi_, full_hi);
  if (!config_.coarse_to_fine || k == 0) return;
  const LevelGeometry& outer = ref.geometry[k - 1];
  const cv::Mat& prev = reverse ? out[k - 1].reverse : out[k - 1].disparity;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      cv::Point2d p = outer.from_source(g.to_source(x, y));
      const int px = static_cast<int>(std::lround(p.x)), py = static_cast<int>(std::lround(p.y));
      if (px < 0 || py < 0 || px >= prev.cols || py >= prev.rows) continue;
      const float d = prev.at<float>(py, px);
      if (d < 0) continue;
      const int centre = static_cast<int>(std::lround(d / g.step_x)) + offset;
      lo_.at<int>(y, x) = std::max(full_lo, centre - config_.search_radius);
      hi_.at<int>(y, x) = std::min(full_hi, centre + config_.search_radius);
    }
}

std::string RetinaStereo::run(const Retina& left, const Retina& right, std::vector<LevelDisparity>& out) {
  if (left.levels.size() != right.levels.size() || left.levels.empty()) return "left and right retinas differ in levels";
  const std::size_t n = left.levels.size();
  out.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const LevelGeometry& gl = left.geometry[k];
    const LevelGeometry& gr = right.geometry[k];
    if (left.levels[k].size() != right.levels[k].size() || left.levels[k].type() != CV_8UC1 ||
        right.levels[k].type() != CV_8UC1)
      return "level " + std::to_string(k) + ": expected 8-bit gray levels of one size";
    if (std::abs(gl.step_x - gr.step_x) > 1e-9 || gl.region.y != gr.region.y || gl.region.height != gr.region.height)
      return "level " + std::to_string(k) + ": left and right regions differ in step or rows";
    const double shift = (gl.region.x - gr.region.x) / gl.step_x;
    const int offset = static_cast<int>(std::lround(shift));
    if (std::abs(shift - offset) > 1e-6)
      return "level " + std::to_string(k) + ": the right region is shifted by a fraction of a level pixel";
    // A left level pixel x matches right x - d with d = D / step + offset, D the
    // disparity in source pixels (0 .. max_disparity).
    const int cols = left.levels[k].cols;
    const int full_lo = std::clamp(offset, -(cols - 1), cols - 1);
    const int full_hi = std::clamp(static_cast<int>(std::floor(config_.max_disparity / gl.step_x)) + offset, -(cols - 1), cols - 1);
    LevelDisparity& level = out[k];
    predict(out, left, k, false, gl, full_lo, full_hi, offset);
    ncc_match(left.levels[k], right.levels[k], Direction::kLeftToRight, lo_, hi_, config_.ncc, level_lr_, level.score, scratch_);
    predict(out, right, k, true, gr, full_lo, full_hi, offset);
    ncc_match(left.levels[k], right.levels[k], Direction::kRightToLeft, lo_, hi_, config_.ncc, level_rl_, score_rl_, scratch_);
    // Validity comes from the scores: with vergence a level disparity may be negative.
    valid_lr_.create(level_lr_.size(), CV_8U);
    fill(valid_lr_, 255);
    if (config_.left_right_check) lr_consistent(level_lr_, level.score, level_rl_, score_rl_, config_.lr_tolerance, valid_lr_);
    // Back to source pixels.
    level.disparity.create(level_lr_.size(), CV_32F);
    level.reverse.create(level_rl_.size(), CV_32F);
    int valid = 0;
    for (int y = 0; y < level_lr_.rows; ++y)
      for (int x = 0; x < level_lr_.cols; ++x) {
        const float d = level_lr_.at<float>(y, x), r = level_rl_.at<float>(y, x);
        const bool dv = level.score.at<float>(y, x) > -1.0f && valid_lr_.at<uint8_t>(y, x);
        const bool rv = score_rl_.at<float>(y, x) > -1.0f;
        level.disparity.at<float>(y, x) = dv ? static_cast<float>((d - offset) * gl.step_x) : -1.0f;
        level.reverse.at<float>(y, x) = rv ? static_cast<float>((r - offset) * gl.step_x) : -1.0f;
        if (!dv) level.score.at<float>(y, x) = -1.0f;
        valid += dv;
      }
    level.density = static_cast<double>(valid) / static_cast<double>(level_lr_.total());
  }
  return {};
}

}  // namespace saccade::stereo
