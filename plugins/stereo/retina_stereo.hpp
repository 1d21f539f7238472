#pragma once
// Stereo on a pair of retinas, coarse to fine: the outer level is searched over
// the whole range; every inner level searches only around what the level
// outside it found (mapped through the levels' geometry).
#include <vector>

#include <opencv2/core.hpp>

#include "ncc.hpp"
#include "saccade/message.hpp"

namespace saccade::stereo {

struct RetinaStereoConfig {
  NccConfig ncc;
  double max_disparity = 256;  // source pixels
  bool coarse_to_fine = true;
  int search_radius = 2;       // pixels of the outer level around its prediction
  bool left_right_check = true;
  float lr_tolerance = 1.0f;   // level pixels
  // Software vergence: each inner level looks at the right frame where the outer
  // level predicts the left level's scene to be (needs the right retina's frame).
  // Experimental: right on synthetic pairs, wrong on Aloe's fovea level so far.
  bool vergence = false;
};

struct LevelDisparity {
  cv::Mat disparity;  // CV_32F, source pixels, -1 invalid (left -> right)
  cv::Mat reverse;    // CV_32F, source pixels, -1 invalid (right -> left)
  cv::Mat score;      // CV_32F, NCC at the chosen disparity, -1 invalid
  double density = 0; // share of valid pixels
  double vergence = 0; // source pixels the right level was moved by (0: not moved)
  double right_x0 = 0;  // left edge of the right level's region as matched, source pixels
};

// Both retinas must have the same level size and steps; the right retina's
// regions may be shifted horizontally from the left's by whole level pixels
// (software vergence), or equal. Levels are 8-bit gray.
class RetinaStereo {
 public:
  explicit RetinaStereo(RetinaStereoConfig config) : config_(config) {}
  // Fills one LevelDisparity per level; returns "" or what is wrong with the pair.
  std::string run(const Retina& left, const Retina& right, std::vector<LevelDisparity>& out);

 private:
  // Search ranges for level k of one side, whose region starts at source x `x0`.
  void predict(const std::vector<LevelDisparity>& out, const Retina& left, std::size_t k, bool reverse, double x0,
               int full_lo, int full_hi, int offset);
  // Median disparity (source pixels) the outer level found inside level k's region; < 0 if none.
  double predicted_disparity(const std::vector<LevelDisparity>& out, const Retina& left, std::size_t k);
  RetinaStereoConfig config_;
  std::vector<float> samples_;
  cv::Mat right_level_, right_gray_;
  cv::Mat lo_, hi_, level_lr_, level_rl_, score_rl_, valid_lr_;
  NccScratch scratch_;
};

}  // namespace saccade::stereo
