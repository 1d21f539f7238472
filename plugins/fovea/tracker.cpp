#include "tracker.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace saccade::fovea {

namespace {

void to_gray(const cv::Mat& in, cv::Mat& out) {
  if (in.channels() == 3) cv::cvtColor(in, out, cv::COLOR_BGR2GRAY);
  else in.copyTo(out);
}

// Offset of a parabola's vertex through (-1, a), (0, b), (1, c), in [-0.5, 0.5].
double vertex(double a, double b, double c) {
  const double d = a - 2.0 * b + c;
  if (d >= 0) return 0.0;
  return std::clamp(0.5 * (a - c) / d, -0.5, 0.5);
}

}  // namespace

TemplateTracker::TemplateTracker(TrackerConfig config) : config_(config) {}

void TemplateTracker::reset() { template_.release(); }

bool TemplateTracker::acquire(const Retina& retina, cv::Point2d point) {
  if (retina.levels.empty()) return false;
  const cv::Mat& fovea = retina.levels.back();
  const LevelGeometry& g = retina.geometry.back();
  const cv::Size t = config_.template_size;
  if (fovea.cols < t.width || fovea.rows < t.height) return false;
  const int x = std::clamp(static_cast<int>(std::lround(point.x - t.width / 2.0)) - g.region.x, 0, fovea.cols - t.width);
  const int y = std::clamp(static_cast<int>(std::lround(point.y - t.height / 2.0)) - g.region.y, 0, fovea.rows - t.height);
  to_gray(fovea(cv::Rect(x, y, t.width, t.height)), window_gray_);
  cv::Scalar mean, stddev;
  cv::meanStdDev(window_gray_, mean, stddev);
  if (stddev[0] < config_.min_contrast) return false;
  window_gray_.convertTo(template_, CV_32F);
  offset_ = point - cv::Point2d(g.region.x + x + t.width / 2.0, g.region.y + y + t.height / 2.0);
  return true;
}

bool TemplateTracker::set_template(const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U) return false;
  to_gray(image, window_gray_);
  cv::Scalar mean, stddev;
  cv::meanStdDev(window_gray_, mean, stddev);
  if (stddev[0] < config_.min_contrast) return false;
  window_gray_.convertTo(template_, CV_32F);
  config_.template_size = template_.size();
  offset_ = {};
  return true;
}

cv::Point TemplateTracker::search_window(const Retina& retina) {
  const cv::Size s = config_.search_size;
  if (retina.source && s.width > 0 && s.height > 0) {
    const cv::Mat& frame = retina.source->mat;
    const int w = std::min(s.width, frame.cols), h = std::min(s.height, frame.rows);
    const int x = std::clamp(retina.fovea.x - w / 2, 0, frame.cols - w);
    const int y = std::clamp(retina.fovea.y - h / 2, 0, frame.rows - h);
    to_gray(frame(cv::Rect(x, y, w, h)), window_gray_);
    window_gray_.convertTo(window_f_, CV_32F);
    return {x, y};
  }
  to_gray(retina.levels.back(), window_gray_);
  window_gray_.convertTo(window_f_, CV_32F);
  return retina.geometry.back().region.tl();
}

TemplateTracker::Match TemplateTracker::match(const Retina& retina) {
  Match m;
  if (template_.empty() || retina.levels.empty()) return m;
  const cv::Point origin = search_window(retina);
  if (window_f_.cols < template_.cols || window_f_.rows < template_.rows) return m;
  cv::matchTemplate(window_f_, template_, result_, cv::TM_CCOEFF_NORMED);
  double best = 0;
  cv::Point at;
  cv::minMaxLoc(result_, nullptr, &best, nullptr, &at);
  m.score = best;
  if (!(best >= config_.min_score)) return m;
  double dx = 0, dy = 0;
  if (at.x > 0 && at.x + 1 < result_.cols) {
    const float* r = result_.ptr<float>(at.y);
    dx = vertex(r[at.x - 1], r[at.x], r[at.x + 1]);
  }
  if (at.y > 0 && at.y + 1 < result_.rows)
    dy = vertex(result_.at<float>(at.y - 1, at.x), result_.at<float>(at.y, at.x), result_.at<float>(at.y + 1, at.x));
  m.found = true;
  m.point = cv::Point2d(origin.x + at.x + dx + template_.cols / 2.0, origin.y + at.y + dy + template_.rows / 2.0) + offset_;
  if (config_.update_rate > 0 && best >= config_.update_min_score) {
    const cv::Mat patch = window_f_(cv::Rect(at, template_.size()));
    cv::addWeighted(template_, 1.0 - config_.update_rate, patch, config_.update_rate, 0.0, template_);
  }
  return m;
}

}  // namespace saccade::fovea
