// The verging head's stereo benchmark (make bench-verge): capture.sim_head's
// cameras fixate a target at 0.5-3 m (vergence joints up to +-20 degrees,
// the neck and tilt following it), and the retina stereo runs on
//   rectified  retinas sampled along the pair's rectified geometry for the joints,
//   plain      retinas sampled on the frames as they are (the switch off),
//   parallel   the same target seen with both vergence joints at zero, rectified
//              (the reference the verging pair is held to).
// Scored against the sim's exact geometry: the fixation depth (metres along
// the rectified left axis) and, per fovea pixel and per outermost-level pixel,
// the correspondence error: where the matcher put the pixel in the right
// image against where the right camera truly sees that point (both in the
// images the matcher compared: rectified or source pixels), so that vertical
// disparity, which a matcher along rows cannot find, counts as error.
//
//   saccade_verge_bench [--data DIR] [--markdown FILE]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "head_rectification.hpp"
#include "rectified.hpp"
#include "retina.hpp"
#include "retina_stereo.hpp"
#include "sim_head.hpp"

namespace {

using namespace saccade;
using kinematics::HeadJoints;

enum class Mode { kRectified, kPlain, kParallel };
const char* name(Mode m) { return m == Mode::kRectified ? "rectified" : m == Mode::kPlain ? "plain" : "parallel"; }

struct Score {
  int fovea_pixels = 0, fovea_matched = 0, fovea_bad2 = 0;
  int outer_pixels = 0, outer_matched = 0, outer_bad2 = 0;
  double depth_error = 0;      // relative; 1 when no fixation was found
  double disparity_error = 0;  // the fixation's, pixels (when found)
  bool fixation_found = false;
  bool fixation_confirmed = false;  // its right window matched back to it (what the head verges on)
  double microseconds = 0;          // retinas (both cameras) and stereo
  void add(const Score& s) {
    fovea_pixels += s.fovea_pixels, fovea_matched += s.fovea_matched, fovea_bad2 += s.fovea_bad2;
    outer_pixels += s.outer_pixels, outer_matched += s.outer_matched, outer_bad2 += s.outer_bad2;
  }
};

// One view of the scene: the sim's frames and what it knows about them.
struct Views {
  capture::SimHeadConfig config;
  HeadJoints joints;
  cv::Mat left, right;  // gray
  capture::TargetView left_target, right_target;
  Eigen::Vector3d target;
};

Eigen::Isometry3d camera_pose(const capture::SimHeadConfig& c, int camera, const HeadJoints& q) {
  return kinematics::optical_frame(camera == 0 ? kinematics::left_camera(c.geometry, q)
                                               : kinematics::right_camera(c.geometry, q));
}

// World point -> the sim's source pixel (the retina's convention: pixel k spans [k, k + 1)).
bool project(const capture::SimHeadConfig& c, const Eigen::Isometry3d& pose, const Eigen::Vector3d& p,
             cv::Point2d& out) {
  const Eigen::Vector3d x = pose.inverse() * p;
  if (x.z() <= 0.05) return false;
  out = {c.size.width / 2.0 + c.focal_px * x.x() / x.z() + 0.5, c.size.height / 2.0 + c.focal_px * x.y() / x.z() + 0.5};
  return true;
}

// Where the right camera truly sees what the left source pixel `pl` shows
// (source pixels); false where the right camera cannot see it (hidden by the
// target, off its image) or the pixel is on the target's rim.
bool true_right(const Views& v, cv::Point2d pl, cv::Point2d& pr) {
  const capture::SimHeadConfig& c = v.config;
  const double rim = 1.5;
  const cv::Point2d lc(v.left_target.center.x + 0.5, v.left_target.center.y + 0.5);
  const cv::Point2d rc(v.right_target.center.x + 0.5, v.right_target.center.y + 0.5);
  const double dl = cv::norm(pl - lc);
  if (std::abs(dl - v.left_target.radius) < rim) return false;
  if (dl < v.left_target.radius) {
    // The target is drawn facing each camera at its own scale.
    pr = rc + (pl - lc) * (v.right_target.radius / v.left_target.radius);
    return true;
  }
  const Eigen::Isometry3d left = camera_pose(c, 0, v.joints);
  const Eigen::Vector3d ray = left.linear() * Eigen::Vector3d((pl.x - 0.5 - c.size.width / 2.0) / c.focal_px,
                                                              (pl.y - 0.5 - c.size.height / 2.0) / c.focal_px, 1.0);
  if (ray.y() <= 1e-9) return false;
  const Eigen::Vector3d wall = left.translation() + ray * ((c.wall_distance - left.translation().y()) / ray.y());
  if (!project(c, camera_pose(c, 1, v.joints), wall, pr)) return false;
  if (cv::norm(pr - rc) < v.right_target.radius + rim) return false;
  return pr.x >= 0 && pr.y >= 0 && pr.x < c.size.width && pr.y < c.size.height;
}

// The retina of `frame` at `fovea`, or why it cannot be sampled through `map`.
Result<Retina> make_retina(const cv::Mat& frame, int camera, const retina::RectifiedMap* map, cv::Point2d fovea) {
  Retina out;
  if (map) {
    if (Status s = retina::sample_rectified(retina::RetinaConfig{}, frame, *map, fovea, out); !s.ok()) return s;
  } else {
    retina::RetinaSampler(retina::RetinaConfig{}).sample(frame, fovea, out);
  }
  auto image = std::make_shared<Image>();
  image->mat = frame;
  image->camera_id = camera;
  out.source = image;
  out.camera_id = camera;
  return out;
}

// Counts one level's pixels: matched, and matched more than 2 level pixels
// from where the right camera truly sees them.
void score_level(const Views& v, const Retina& left, std::size_t k, const stereo::LevelDisparity& level,
                 const retina::RectifiedMap* left_map, const retina::RectifiedMap* right_map, int& pixels, int& matched,
                 int& bad) {
  const LevelGeometry& g = left.geometry[k];
  for (int j = 0; j < level.disparity.rows; ++j) {
    for (int i = 0; i < level.disparity.cols; ++i) {
      const cv::Point2d at = g.to_source(i, j);  // rectified pixels when rectified
      cv::Point2d source = at;
      if (left_map && !left_map->to_source(at, source)) continue;
      cv::Point2d truth;
      if (!true_right(v, source, truth)) continue;
      if (right_map) truth = right_map->to_rectified(truth);
      ++pixels;
      const float d = level.disparity.at<float>(j, i);
      if (d < 0) continue;
      ++matched;
      const cv::Point2d found(at.x - d, at.y);
      if (cv::norm(found - truth) / g.step_x > 2.0) ++bad;
    }
  }
}

// One mode on one view, or the error that stopped the rectification, the
// sampling or the matcher.
Result<Score> run(const Views& v, Mode mode, const stereo::RetinaStereoConfig& config) {
  Score s;
  const kinematics::HeadCalibration calibration =
      retina::model_calibration(v.config.size, v.config.focal_px, v.config.geometry);
  Result<retina::PairRectification> rectified_pair = retina::rectify_pair(calibration, v.config.geometry, v.joints);
  if (!rectified_pair.ok()) return rectified_pair.status();
  const retina::PairRectification& pair = *rectified_pair;
  const cv::Point2d lc(v.left_target.center.x + 0.5, v.left_target.center.y + 0.5);
  const cv::Point2d rc(v.right_target.center.x + 0.5, v.right_target.center.y + 0.5);
  const bool rectified = mode != Mode::kPlain;
  std::optional<retina::RectifiedMap> left_map, right_map;
  if (rectified) left_map.emplace(pair.left), right_map.emplace(pair.right);
  // Plain retinas must share their rows (the stereo's rule for unrectified
  // pairs): the right one takes the left's fovea, as a plain pair does.
  const cv::Point2d right_fovea = rectified ? rc : lc;
  Result<Retina> left_retina = make_retina(v.left, 0, rectified ? &*left_map : nullptr, lc);
  if (!left_retina.ok()) return left_retina.status();
  Result<Retina> right_retina = make_retina(v.right, 1, rectified ? &*right_map : nullptr, right_fovea);
  if (!right_retina.ok()) return right_retina.status();
  Retina& left = *left_retina;
  Retina& right = *right_retina;
  stereo::RetinaStereo matcher(config);
  std::vector<stereo::LevelDisparity> levels;
  if (Status matched = matcher.run(left, right, levels); !matched.ok()) return matched;
  // Time in steady state (buffers made): both retinas sampled again and matched, median of 5.
  std::vector<double> times;
  retina::RetinaSampler sampler(retina::RetinaConfig{});
  for (int i = 0; i < 5; ++i) {
    const auto start = std::chrono::steady_clock::now();
    if (rectified) {
      (void)retina::sample_rectified(retina::RetinaConfig{}, v.left, *left_map, lc, left);
      (void)retina::sample_rectified(retina::RetinaConfig{}, v.right, *right_map, right_fovea, right);
    } else {
      sampler.sample(v.left, lc, left);
      sampler.sample(v.right, right_fovea, right);
    }
    (void)matcher.run(left, right, levels);
    times.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count());
  }
  std::nth_element(times.begin(), times.begin() + 2, times.end());
  s.microseconds = times[2];
  score_level(v, left, levels.size() - 1, levels.back(), rectified ? &*left_map : nullptr,
              rectified ? &*right_map : nullptr, s.fovea_pixels, s.fovea_matched, s.fovea_bad2);
  score_level(v, left, 0, levels.front(), rectified ? &*left_map : nullptr, rectified ? &*right_map : nullptr,
              s.outer_pixels, s.outer_matched, s.outer_bad2);
  // The truth: the target's depth along the rectified left axis.
  const Eigen::Vector3d p = camera_pose(v.config, 0, v.joints).inverse() * v.target;
  const cv::Vec3d in_rectified = cv::Matx33d(pair.left.rotation.val) * cv::Vec3d(p.x(), p.y(), p.z());
  const double disparity = matcher.fixation().disparity;
  s.fixation_found = disparity > 0;
  s.fixation_confirmed = s.fixation_found && matcher.fixation().confirmed;
  // Without rectification the depth is what the parallel-camera formula makes of the disparity.
  const double depth = disparity > 0 ? pair.left.rectified[0] * pair.left.baseline / disparity : 0;
  s.depth_error = s.fixation_found ? std::abs(depth - in_rectified[2]) / in_rectified[2] : 1.0;
  s.disparity_error = s.fixation_found ? disparity - pair.left.rectified[0] * pair.left.baseline / in_rectified[2] : 0;
  return s;
}

// The head's views of the target, or why the head cannot look at it.
Result<Views> look(const cv::Mat& wall, double distance, double lateral, double height, bool parallel) {
  Views v;
  v.config.wall_distance = 4.0;  // behind every target
  v.config.wall_width = 8.0;
  v.config.target_distance = distance;
  v.config.target_start = lateral;
  v.config.target_height = height;
  v.config.target_speed = 0;
  capture::SimHead head(wall, v.config);
  v.target = head.target_at(0);
  const Result<kinematics::HeadJoints> gaze =
      kinematics::gaze_at(v.target, v.config.geometry, kinematics::HeadLimits{});
  if (!gaze.ok()) return Status::error("target not reachable: " + gaze.error());
  v.joints = *gaze;
  if (parallel) v.joints.vergence_left = v.joints.vergence_right = 0;
  cv::Mat l, r;
  v.left_target = head.render(0, v.joints, 0, l);
  v.right_target = head.render(1, v.joints, 0, r);
  cv::cvtColor(l, v.left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(r, v.right, cv::COLOR_BGR2GRAY);
  return v;
}

std::string ratio(int a, int b) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", b > 0 ? static_cast<double>(a) / b : 0.0);
  return buf;
}

constexpr Mode kModes[] = {Mode::kRectified, Mode::kPlain, Mode::kParallel};

// One mode's results over a distance's views, or over every distance.
struct Tally {
  Score score;
  double depth_sum = 0, depth_max = 0;
  double us = 0;  // a distance's only
  int found = 0, confirmed = 0, count = 0;
};

// Every view of the target at one distance (each wall, lateral offset and
// height) in every mode, into `tally` per mode; the squared fixation
// disparity errors straight into the all-distance sums, view by view. An
// error when a wall's image cannot be read or a view cannot be measured.
Status measure_distance(const std::string& data, double distance, const stereo::RetinaStereoConfig& config,
                        Tally (&tally)[3], double (&all_disparity_sq)[3], double& vergence) {
  const std::vector<std::string> walls = {"aloeL.jpg", "graf1.png", "building.jpg"};
  const std::vector<double> laterals = {-0.3, 0.0, 0.3};  // times the distance: the neck turns about +-17 degrees
  int count = 0;
  for (const std::string& w : walls) {
    const cv::Mat wall = cv::imread(data + "/" + w, cv::IMREAD_COLOR);
    if (wall.empty()) return Status::error("cannot read " + data + "/" + w + " (install opencv-doc)");
    for (double lateral : laterals) {
      for (double height : {0.0, 0.15}) {
        const Result<Views> verged = look(wall, distance, lateral * distance, height * distance, false);
        if (!verged.ok()) return verged.status();
        const Result<Views> parallel = look(wall, distance, lateral * distance, height * distance, true);
        if (!parallel.ok()) return parallel.status();
        vergence = std::max(vergence, std::abs(verged->joints.vergence_left) * 180 / CV_PI);
        ++count;
        for (Mode m : kModes) {
          const int i = static_cast<int>(m);
          const Result<Score> measured = run(m == Mode::kParallel ? *parallel : *verged, m, config);
          if (!measured.ok()) return measured.status();
          const Score& s = *measured;
          tally[i].score.add(s);
          tally[i].depth_sum += s.depth_error;
          all_disparity_sq[i] += s.disparity_error * s.disparity_error;
          tally[i].depth_max = std::max(tally[i].depth_max, s.depth_error);
          tally[i].found += s.fixation_found;
          tally[i].confirmed += s.fixation_confirmed;
          tally[i].us += s.microseconds;
        }
      }
    }
  }
  for (Tally& t : tally) t.count = count;
  return {};
}

std::string distance_row(double distance, double vergence, Mode m, const Tally& t) {
  char line[512];
  std::snprintf(line, sizeof line,
                "| %.2f m | %.1f | %s | %.2f%% / %.2f%% | %d / %d (%d) | %s | %s | %s | %s | %.0f |\n", distance,
                vergence, name(m), 100 * t.depth_sum / t.count, 100 * t.depth_max, t.found, t.count, t.confirmed,
                ratio(t.score.fovea_matched, t.score.fovea_pixels).c_str(),
                ratio(t.score.fovea_bad2, t.score.fovea_matched).c_str(),
                ratio(t.score.outer_matched, t.score.outer_pixels).c_str(),
                ratio(t.score.outer_bad2, t.score.outer_matched).c_str(), t.us / t.count);
  return line;
}

void add_distance(Tally& all, const Tally& t) {
  all.score.add(t.score);
  all.depth_sum += t.depth_sum;
  all.depth_max = std::max(all.depth_max, t.depth_max);
  all.count += t.count;
  all.found += t.found;
  all.confirmed += t.confirmed;
}

std::string all_row(Mode m, const Tally& t) {
  char line[512];
  std::snprintf(line, sizeof line, "| **all** | | %s | %.2f%% / %.2f%% | %d / %d (%d) | %s | %s | %s | %s | |\n",
                name(m), 100 * t.depth_sum / t.count, 100 * t.depth_max, t.found, t.count, t.confirmed,
                ratio(t.score.fovea_matched, t.score.fovea_pixels).c_str(),
                ratio(t.score.fovea_bad2, t.score.fovea_matched).c_str(),
                ratio(t.score.outer_matched, t.score.outer_pixels).c_str(),
                ratio(t.score.outer_bad2, t.score.outer_matched).c_str());
  return line;
}

// The fixation disparity's RMS, and whether the floors are met: depth within
// 1% with rectification, fovea bad-2 within 1.2x of parallel cameras'.
std::string floors(const Tally (&all)[3], const double (&all_disparity_sq)[3]) {
  std::ostringstream out;
  char rms[160];
  std::snprintf(rms, sizeof rms, "\nThe rectified fixation disparity's RMS error: %.3f px over %d fixations.\n",
                std::sqrt(all_disparity_sq[0] / std::max(1, all[0].found)), all[0].found);
  out << rms;
  const Score& rectified = all[0].score;
  const Score& parallel = all[2].score;
  const double rectified_bad =
      rectified.fovea_matched ? static_cast<double>(rectified.fovea_bad2) / rectified.fovea_matched : 1;
  const double parallel_bad =
      parallel.fovea_matched ? static_cast<double>(parallel.fovea_bad2) / parallel.fovea_matched : 1;
  out << "\nFloors: fixation depth error <= 1% (rectified, max " << 100 * all[0].depth_max
      << "%): " << (all[0].depth_max <= 0.01 ? "met" : "NOT met") << "; fovea bad-2 within 1.2x of parallel cameras ("
      << rectified_bad << " against " << parallel_bad
      << "): " << (rectified_bad <= 1.2 * parallel_bad ? "met" : "NOT met") << "\n";
  return out.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("The verging head's stereo: rectified against plain retinas, and against parallel cameras");
  std::string data = SACCADE_SAMPLE_DATA, markdown;
  app.add_option("--data", data, "opencv-doc's examples/data folder (the walls' images)");
  app.add_option("--markdown", markdown, "also write the tables to this file");
  CLI11_PARSE(app, argc, argv);
  cv::setNumThreads(1);

  const std::vector<double> distances = {0.5, 0.75, 1.0, 1.5, 2.0, 3.0};
  stereo::RetinaStereoConfig config;
  config.vergence = true;
  config.max_disparity = 256;  // a 0.5 m target: ~200 px on the rectified pair

  std::ostringstream out;
  out << "| distance | vergence (deg) | mode | fixation depth error (mean / max) | fixations found (confirmed) | "
         "fovea density "
         "| fovea bad-2 | outer level density | outer bad-2 | us per pair "
         "|\n|---|---|---|---|---|---|---|---|---|---|\n";
  Tally all[3];
  double all_disparity_sq[3] = {};
  for (double distance : distances) {
    Tally tally[3];
    double vergence = 0;
    if (Status s = measure_distance(data, distance, config, tally, all_disparity_sq, vergence); !s.ok()) {
      std::cerr << "saccade_verge_bench: " << s.message() << "\n";
      return 1;
    }
    for (Mode m : kModes) {
      const int i = static_cast<int>(m);
      out << distance_row(distance, vergence, m, tally[i]);
      add_distance(all[i], tally[i]);
    }
  }
  for (Mode m : kModes) out << all_row(m, all[static_cast<int>(m)]);
  out << floors(all, all_disparity_sq);
  std::cout << out.str();
  if (!markdown.empty()) std::ofstream(markdown) << out.str();
  return 0;
}
