#pragma once
// Keeps a target in view: normalised cross-correlation of a small template
// with the fovea (or a window of the frame around it), peak refined to
// sub-pixel.
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/message.hpp"

namespace saccade::fovea {

struct TrackerConfig {
  cv::Size template_size{12, 12};
  // Window of the source frame, centred on the fovea, that is searched: a wider
  // crop than the fovea, so that a target that moved faster than predicted is
  // still found. 0x0, or a retina without its source frame: the fovea level.
  cv::Size search_size{40, 32};
  double min_score = 0.6;          // a match below this is no match
  double update_rate = 0.0;        // template <- (1 - a) template + a patch
  double update_min_score = 0.85;  // only confident matches update the template
  double min_contrast = 4.0;       // a template whose standard deviation is below this is refused
};

// cv::matchTemplate(window, templ, result, TM_CCOEFF_NORMED) for small CV_32F
// images, computed directly: OpenCV 4.6 takes the DFT path even for a 12x12
// template in a 40x32 window, which allocates on every call and costs several
// times more. Same definition, and the same rule for flat windows (their
// score is 0); a flat template scores 0 everywhere (OpenCV's: 1). A window
// whose standard deviation is under `min_relative_contrast` times the
// template's scores 0 too: the normalisation magnifies a nearly flat window's
// faint shading or noise into any score. `scratch` keeps the buffers between
// calls.
struct CorrelationScratch {
  std::vector<float> centered, cross;
  std::vector<double> column_sum, column_sq, block_sum, block_sq, row_sum, row_sq;
};
void match_template_normed(const cv::Mat& window, const cv::Mat& templ, cv::Mat& result, CorrelationScratch& scratch,
                           double min_relative_contrast = 0);

class TemplateTracker {
 public:
  explicit TemplateTracker(TrackerConfig config);

  // Cuts the template centred on `point` (source pixels) from the retina's
  // fovea level. Near the level's edge the template is kept inside and the
  // point's offset from its centre remembered. False when the level is smaller
  // than the template or the patch is flat.
  bool acquire(const Retina& retina, cv::Point2d point);
  // A template given from outside (top-down): 8-bit gray or BGR.
  bool set_template(const cv::Mat& image);
  void reset();
  // Moves the tracked point relative to the template (where on the object the
  // target's centre is), e.g. once the object is fully in view.
  void move_point(cv::Point2d delta) { offset_ += delta; }
  bool has_template() const { return !template_.empty(); }

  struct Match {
    bool found = false;
    cv::Point2d point{-1, -1};  // the target's centre, source pixels
    double score = -1.0;
  };
  Match match(const Retina& retina);
  const TrackerConfig& config() const { return config_; }

 private:
  // The gray CV_32F image searched and the source position of its pixel (0, 0).
  cv::Point search_window(const Retina& retina);
  TrackerConfig config_;
  cv::Mat template_;  // CV_32F
  cv::Point2d offset_;
  cv::Mat window_gray_, window_f_, result_, patch_;
  CorrelationScratch correlation_;
};

}  // namespace saccade::fovea
