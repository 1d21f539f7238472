#include "saliency.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "saccade/fill.hpp"

namespace saccade::fovea {

InhibitionOfReturn::InhibitionOfReturn(double radius, int frames) : radius_(radius), frames_(std::max(1, frames)) {}

void InhibitionOfReturn::add(cv::Point2d point, double strength) {
  places_[next_] = Place{point, std::clamp(strength, 0.0, 1.0), 0};
  next_ = (next_ + 1) % kCapacity;
  count_ = std::min(count_ + 1, kCapacity);
}

void InhibitionOfReturn::tick() {
  for (std::size_t i = 0; i < count_; ++i) ++places_[i].age;
}

void InhibitionOfReturn::shift(cv::Point2d offset) {
  for (std::size_t i = 0; i < count_; ++i) places_[i].point += offset;
}

void InhibitionOfReturn::clear() { count_ = next_ = 0; }

double InhibitionOfReturn::at(cv::Point2d point) const {
  double inhibition = 0.0;
  const double r2 = radius_ * radius_;
  for (std::size_t i = 0; i < count_; ++i) {
    const Place& p = places_[i];
    if (p.age >= frames_) continue;
    const cv::Point2d d = point - p.point;
    if (d.dot(d) > r2) continue;
    inhibition = std::max(inhibition, p.strength * (1.0 - static_cast<double>(p.age) / frames_));
  }
  return inhibition;
}

namespace {

filters::BankConfig edge_bank() {
  filters::BankConfig c;
  c.wanted[filters::kGradMag] = true;
  return c;
}

float max_of(const std::vector<cv::Mat>& maps) {
  double best = 0.0;
  for (const cv::Mat& m : maps) {
    if (m.empty()) continue;
    double lo = 0, hi = 0;
    cv::minMaxLoc(m, &lo, &hi);
    best = std::max(best, hi);
  }
  return static_cast<float>(best);
}

// Bilinear sample of a CV_32F image at (x, y) in pixel-centre coordinates,
// clamped to the image.
float bilinear(const cv::Mat& m, double x, double y) {
  x = std::clamp(x, 0.0, m.cols - 1.0);
  y = std::clamp(y, 0.0, m.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), m.cols - 2 < 0 ? 0 : m.cols - 2);
  const int y0 = std::min(static_cast<int>(y), m.rows - 2 < 0 ? 0 : m.rows - 2);
  const int x1 = std::min(x0 + 1, m.cols - 1), y1 = std::min(y0 + 1, m.rows - 1);
  const double fx = x - x0, fy = y - y0;
  const float* r0 = m.ptr<float>(y0);
  const float* r1 = m.ptr<float>(y1);
  return static_cast<float>((1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x1]));
}

}  // namespace

Saliency::Saliency(SaliencyConfig config) : config_(std::move(config)), edges_(edge_bank()) {}

void Saliency::bind(const Retina& retina) {
  const std::size_t n = retina.levels.size();
  const cv::Size size = n > 0 ? retina.levels[0].size() : cv::Size();
  if (maps_.size() == n && (n == 0 || maps_[0].size() == size)) return;
  for (auto* v : {&gray_, &blurred_, &contrast_, &edge_, &motion_, &color_, &maps_, &appearance_}) {
    v->assign(n, cv::Mat());
    for (cv::Mat& m : *v) m.create(size, CV_32F);
  }
  for (cv::Mat& m : gray_) m.create(size, CV_8U);
  surround_.create(size, CV_32F);
  visited_.create(size, CV_8U);
  stack_.reserve(static_cast<std::size_t>(size.area()));
}

void Saliency::compute(const Retina& retina, const std::vector<cv::Mat>* motion_dI) {
  bind(retina);
  geometry_.assign(retina.geometry.begin(), retina.geometry.end());
  const std::size_t n = retina.levels.size();
  const bool color = n > 0 && retina.levels[0].channels() == 3;
  const bool use_motion = motion_dI != nullptr && motion_dI->size() == n && config_.motion_weight > 0;
  has_motion_ = use_motion;
  const bool use_color = color && config_.color && config_.color_weight > 0;
  for (std::size_t k = 0; k < n; ++k)
    level_features(k, retina.levels[k], color, use_motion ? &(*motion_dI)[k] : nullptr, use_color);
  center_surround();
  combine(use_motion, use_color);
}

// Gray, blurred and edge maps of level k (BGR when `color`: the retina's first
// level decides for all), and where asked the magnitude of its temporal
// derivative and its closeness to the wanted colour.
void Saliency::level_features(std::size_t k, const cv::Mat& level, bool color, const cv::Mat* motion_dI,
                              bool use_color) {
  if (color)
    cv::cvtColor(level, gray_[k], cv::COLOR_BGR2GRAY);
  else
    level.copyTo(gray_[k]);
  gray_[k].convertTo(surround_, CV_32F);
  cv::GaussianBlur(surround_, blurred_[k], cv::Size(5, 5), 1.0, 1.0, cv::BORDER_REFLECT_101);
  edges_.run(gray_[k], bank_out_);
  bank_out_[filters::kGradMag].copyTo(edge_[k]);
  if (motion_dI != nullptr) {
    const cv::Mat& dI = *motion_dI;
    for (int y = 0; y < dI.rows; ++y) {
      const float* s = dI.ptr<float>(y);
      float* d = motion_[k].ptr<float>(y);
      for (int x = 0; x < dI.cols; ++x) d[x] = std::abs(s[x]);
    }
  }
  if (use_color) {
    const cv::Vec3d want = *config_.color;
    const double inv = 1.0 / (2.0 * config_.color_tolerance * config_.color_tolerance);
    for (int y = 0; y < level.rows; ++y) {
      const cv::Vec3b* s = level.ptr<cv::Vec3b>(y);
      float* d = color_[k].ptr<float>(y);
      for (int x = 0; x < level.cols; ++x) {
        const cv::Vec3d diff = cv::Vec3d(s[x][0], s[x][1], s[x][2]) - want;
        d[x] = static_cast<float>(std::exp(-diff.dot(diff) * inv));
      }
    }
  }
}

// Centre-surround across levels: each level against the next coarser one,
// sampled at the same scene points; the outermost against a wide blur of itself.
void Saliency::center_surround() {
  for (std::size_t k = 0; k < blurred_.size(); ++k) {
    const cv::Mat& center = blurred_[k];
    if (k == 0) {
      cv::GaussianBlur(center, surround_, cv::Size(0, 0), 4.0, 4.0, cv::BORDER_REFLECT_101);
      cv::absdiff(center, surround_, contrast_[k]);
      continue;
    }
    const LevelGeometry& fine = geometry_[k];
    const LevelGeometry& coarse = geometry_[k - 1];
    const cv::Mat& outer = blurred_[k - 1];
    for (int y = 0; y < center.rows; ++y) {
      const float* c = center.ptr<float>(y);
      float* d = contrast_[k].ptr<float>(y);
      for (int x = 0; x < center.cols; ++x) {
        const cv::Point2d q = coarse.from_source(fine.to_source(x, y));
        d[x] = std::abs(c[x] - bilinear(outer, q.x, q.y));
      }
    }
  }
}

// Each conspicuity map is scaled by its largest value over all levels (or
// its floor), or with `level_boost` b > 0 by at most 1 - b of that on a level
// whose own largest value is smaller: an object seen only on an outer level,
// where it is small and blurred, is then not drowned by the fovea's detail.
void Saliency::combine(bool use_motion, bool use_color) {
  const double contrast_max = std::max<double>(max_of(contrast_), config_.contrast_floor);
  const double edge_max = std::max<double>(max_of(edge_), config_.edge_floor);
  const double motion_max = use_motion ? std::max<double>(max_of(motion_), config_.motion_floor) : 1.0;
  double total = config_.contrast_weight + config_.edge_weight;
  if (use_motion) total += config_.motion_weight;
  if (use_color) total += config_.color_weight;
  auto scale = [&](const cv::Mat& m, double global) {
    double hi = 0;
    cv::minMaxLoc(m, nullptr, &hi);
    return static_cast<float>(1.0 / std::max(hi, global * (1.0 - config_.level_boost)));
  };
  for (std::size_t k = 0; k < maps_.size(); ++k) {
    const float wc = static_cast<float>(config_.contrast_weight / total) * scale(contrast_[k], contrast_max);
    const float we = static_cast<float>(config_.edge_weight / total) * scale(edge_[k], edge_max);
    const float wm =
        use_motion ? static_cast<float>(config_.motion_weight / total) * scale(motion_[k], motion_max) : 0.0f;
    const float wk = static_cast<float>(use_color ? config_.color_weight / total : 0.0);
    for (int y = 0; y < maps_[k].rows; ++y) {
      const float* c = contrast_[k].ptr<float>(y);
      const float* e = edge_[k].ptr<float>(y);
      const float* m = motion_[k].ptr<float>(y);
      const float* h = color_[k].ptr<float>(y);
      float* d = maps_[k].ptr<float>(y);
      float* a = appearance_[k].ptr<float>(y);
      for (int x = 0; x < maps_[k].cols; ++x) {
        float v = wc * c[x] + we * e[x];
        a[x] = v;
        if (use_motion) v += wm * m[x];
        if (use_color) v += wk * h[x];
        d[x] = v;
      }
    }
  }
}

Candidate Saliency::peak(const InhibitionOfReturn& ior, bool moving) const {
  Candidate best;
  if (moving && !has_motion_) return best;
  const int b = config_.border;
  // Inner levels first: on a tie the finer, better-localised place wins.
  for (int k = static_cast<int>(maps_.size()) - 1; k >= 0; --k) {
    const cv::Mat& m = maps_[static_cast<std::size_t>(k)];
    const LevelGeometry& g = geometry_[static_cast<std::size_t>(k)];
    for (int y = b; y < m.rows - b; ++y) {
      const float* row = m.ptr<float>(y);
      for (int x = b; x < m.cols - b; ++x) {
        if (row[x] <= best.value) continue;
        if (moving && motion_[static_cast<std::size_t>(k)].at<float>(y, x) < config_.motion_floor) continue;
        const cv::Point2d p = g.to_source(x, y);
        const double v = row[x] * (1.0 - ior.at(p));
        if (v > best.value) best = Candidate{p, v, k};
      }
    }
  }
  return best;
}

Candidate Saliency::peak_on_level(int level, int margin_x, int margin_y) const {
  Candidate best;
  if (level < 0 || level >= static_cast<int>(maps_.size())) return best;
  const cv::Mat& m = maps_[static_cast<std::size_t>(level)];
  const LevelGeometry& g = geometry_[static_cast<std::size_t>(level)];
  for (int y = margin_y; y < m.rows - margin_y; ++y) {
    const float* row = m.ptr<float>(y);
    for (int x = margin_x; x < m.cols - margin_x; ++x)
      if (row[x] > best.value) best = Candidate{g.to_source(x, y), row[x], level};
  }
  return best;
}

cv::Point2d Saliency::blob_center(int level, cv::Point2d seed, double fraction, bool* cut) {
  if (cut != nullptr) *cut = false;
  if (level < 0 || level >= static_cast<int>(maps_.size())) return seed;
  const cv::Mat& m = appearance_[static_cast<std::size_t>(level)];
  const LevelGeometry& g = geometry_[static_cast<std::size_t>(level)];
  const cv::Point2d q = g.from_source(seed);
  cv::Point start(std::clamp(static_cast<int>(std::lround(q.x)), 0, m.cols - 1),
                  std::clamp(static_cast<int>(std::lround(q.y)), 0, m.rows - 1));
  const cv::Point center = start;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const cv::Point n = center + cv::Point(dx, dy);
      if (n.x >= 0 && n.y >= 0 && n.x < m.cols && n.y < m.rows && m.at<float>(n) > m.at<float>(start)) start = n;
    }
  const float threshold = static_cast<float>(fraction) * m.at<float>(start);
  if (!(threshold > 0)) return seed;
  fill(visited_, 0);
  stack_.clear();
  stack_.push_back(start);
  visited_.at<uint8_t>(start) = 1;
  double sw = 0, sx = 0, sy = 0;
  while (!stack_.empty()) {
    const cv::Point p = stack_.back();
    stack_.pop_back();
    const double w = m.at<float>(p);
    sw += w;
    sx += w * p.x;
    sy += w * p.y;
    if (cut != nullptr && (p.x == 0 || p.y == 0 || p.x == m.cols - 1 || p.y == m.rows - 1)) *cut = true;
    for (const cv::Point d : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
      const cv::Point n = p + d;
      if (n.x < 0 || n.y < 0 || n.x >= m.cols || n.y >= m.rows) continue;
      uint8_t& seen = visited_.at<uint8_t>(n);
      if (seen || m.at<float>(n) < threshold) continue;
      seen = 1;
      stack_.push_back(n);
    }
  }
  return g.to_source(sx / sw, sy / sw);
}

}  // namespace saccade::fovea
