#include "retina_stereo.hpp"

#include <opencv2/imgproc.hpp>

#include "retina.hpp"

#include <cmath>
#include <string>

#include "saccade/fill.hpp"

namespace saccade::stereo {

// Search ranges for level k of the reference image: around the disparity the
// level outside found at the same source point, or the whole range where it
// found none. `offset` is how far left of the left region the right one lies, in
// level pixels: level disparity = source disparity / step - offset, both ways.
void RetinaStereo::predict(const std::vector<LevelDisparity>& out, const Retina& left, std::size_t k, bool reverse,
                           double x0, int full_lo, int full_hi, int offset) {
  const cv::Size size = left.levels[k].size();
  fill(lo_, full_lo);
  fill(hi_, full_hi);
  if (!config_.coarse_to_fine || k == 0) return;
  // Both sides share steps and rows; only the regions' left edges differ.
  const LevelGeometry& g = left.geometry[k];
  const LevelGeometry& outer = left.geometry[k - 1];
  const double outer_x0 = reverse ? out[k - 1].right_x0 : outer.region.x;
  const cv::Mat& prev = reverse ? out[k - 1].reverse : out[k - 1].disparity;
  // The outer level knows the disparity to about one of its own pixels, which is
  // outer.step / g.step of this level's: the radius is counted in outer pixels.
  const int radius = static_cast<int>(std::ceil(config_.search_radius * outer.step_x / g.step_x));
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const double sx = x0 + (x + 0.5) * g.step_x, sy = g.region.y + (y + 0.5) * g.step_y;
      const int px = static_cast<int>(std::lround((sx - outer_x0) / outer.step_x - 0.5));
      const int py = static_cast<int>(std::lround((sy - outer.region.y) / outer.step_y - 0.5));
      if (px < 0 || py < 0 || px >= prev.cols || py >= prev.rows) continue;
      const float d = prev.at<float>(py, px);
      if (d < 0) continue;
      const int centre = static_cast<int>(std::lround(d / g.step_x)) - offset;
      lo_.at<int>(y, x) = std::max(full_lo, centre - radius);
      hi_.at<int>(y, x) = std::min(full_hi, centre + radius);
    }
}

double RetinaStereo::predicted_disparity(const std::vector<LevelDisparity>& out, const Retina& left, std::size_t k) {
  const LevelGeometry& outer = left.geometry[k - 1];
  const cv::Rect inner = left.geometry[k].region;
  const cv::Mat& d = out[k - 1].disparity;
  samples_.clear();
  for (int y = 0; y < d.rows; ++y)
    for (int x = 0; x < d.cols; ++x) {
      const float v = d.at<float>(y, x);
      if (v < 0) continue;
      cv::Point2d p = outer.to_source(x, y);
      if (p.x >= inner.x && p.x < inner.x + inner.width && p.y >= inner.y && p.y < inner.y + inner.height)
        samples_.push_back(v);
    }
  if (samples_.empty()) return -1;
  auto mid = samples_.begin() + static_cast<std::ptrdiff_t>(samples_.size() / 2);
  std::nth_element(samples_.begin(), mid, samples_.end());
  return *mid;
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
    int offset = static_cast<int>(std::lround(shift));
    if (std::abs(shift - offset) > 1e-6)
      return "level " + std::to_string(k) + ": the right region is shifted by a fraction of a level pixel";
    const cv::Mat* right_level = &right.levels[k];
    LevelDisparity& level = out[k];
    level.vergence = 0;
    if (config_.vergence && k > 0 && right.source && !right.source->mat.empty()) {
      const double predicted = predicted_disparity(out, left, k);
      if (predicted > 0) {
        // Sample the right frame where the left level's scene should be: the
        // left region moved left by the prediction, in whole level pixels.
        offset = static_cast<int>(std::lround(predicted / gl.step_x));
        const cv::Mat* frame = &right.source->mat;
        if (frame->channels() == 3) {
          cv::cvtColor(*frame, right_gray_, cv::COLOR_BGR2GRAY);
          frame = &right_gray_;
        }
        retina::sample_level(*frame, gl.region.x - offset * gl.step_x, gl.region.y, gl.step_x, gl.step_y,
                             left.levels[k].size(), k + 1 == n, right_level_);
        right_level = &right_level_;
        level.vergence = offset * gl.step_x;
      }
    }
    // A left level pixel x matches right x - d with d = D / step - offset, D the
    // disparity in source pixels (0 .. max_disparity).
    const int cols = left.levels[k].cols;
    const int full_lo = std::clamp(-offset, -(cols - 1), cols - 1);
    const int full_hi = std::clamp(static_cast<int>(std::floor(config_.max_disparity / gl.step_x)) - offset, -(cols - 1), cols - 1);
    level.right_x0 = gl.region.x - offset * gl.step_x;
    lo_.create(left.levels[k].size(), CV_32S);
    hi_.create(left.levels[k].size(), CV_32S);
    predict(out, left, k, false, gl.region.x, full_lo, full_hi, offset);
    ncc_match(left.levels[k], *right_level, Direction::kLeftToRight, lo_, hi_, config_.ncc, level_lr_, level.score, scratch_);
    predict(out, left, k, true, level.right_x0, full_lo, full_hi, offset);
    ncc_match(left.levels[k], *right_level, Direction::kRightToLeft, lo_, hi_, config_.ncc, level_rl_, score_rl_, scratch_);
    // Validity comes from the scores: with vergence a level disparity may be negative.
    valid_lr_.create(level_lr_.size(), CV_8U);
    fill(valid_lr_, 255);
    if (config_.left_right_check) left_right_check(level_lr_, level.score, level_rl_, score_rl_, config_.lr_tolerance, valid_lr_);
    // Back to source pixels.
    level.disparity.create(level_lr_.size(), CV_32F);
    level.reverse.create(level_rl_.size(), CV_32F);
    int valid = 0;
    for (int y = 0; y < level_lr_.rows; ++y)
      for (int x = 0; x < level_lr_.cols; ++x) {
        const float d = level_lr_.at<float>(y, x), r = level_rl_.at<float>(y, x);
        const bool dv = level.score.at<float>(y, x) > -1.0f && valid_lr_.at<uint8_t>(y, x);
        const bool rv = score_rl_.at<float>(y, x) > -1.0f;
        level.disparity.at<float>(y, x) = dv ? static_cast<float>((d + offset) * gl.step_x) : -1.0f;
        level.reverse.at<float>(y, x) = rv ? static_cast<float>((r + offset) * gl.step_x) : -1.0f;
        if (!dv) level.score.at<float>(y, x) = -1.0f;
        valid += dv;
      }
    level.density = static_cast<double>(valid) / static_cast<double>(level_lr_.total());
  }
  return {};
}

}  // namespace saccade::stereo
