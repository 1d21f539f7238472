// The stereo benchmark (make bench-stereo): the retina stereo matcher against
// OpenCV's StereoBM and StereoSGBM on the same pairs, one thread, scored over
// whole images and over the fovea against exact or published ground truth.
//
// Pairs: Middlebury's Aloe from Debian's opencv-doc (at full size and at a
// third of it), and scenes rendered here with exact per-pixel disparity
// (textured planes, fronto-parallel and slanted, at several depths over a
// slanted background, the textures real photographs from opencv-doc; the
// right view is each plane's exact affine image, so occlusions come out as
// they would; a little sensor noise, seeded). Each pair is looked at on a grid
// of 3 x 3 fixations (the fovea centred at a quarter, a half and three
// quarters of the width and height).
// And real cameras: opencv-doc's 13 chessboard pairs (its stereo_calib.xml,
// 640x480), calibrated as `saccade calibrate` does and rectified with that
// calibration; the truth is the disparities of the board's 54 corners found
// in both images, interpolated across each square (extrapolated over the
// outer ones; elsewhere unknown), and the fixations lie on the board (its
// middle and four points half way to its corners). The 13 pairs are scored
// as one set.
// And any pair given as files (--middlebury: a Middlebury scene's folder in
// any year's layout; --stereo-pair: a left and right image and the left
// truth, KITTI's or a user's own), scored on the 3 x 3 grid as the others.
//
// Scores (counts summed over the fixations): density = pixels given a
// disparity / pixels with a known truth; bad-1 and bad-2 = given pixels wrong
// by more than 1 and 2 pixels / given pixels.
// - fovea: the fovea's region (step 1), our fovea level against BM's and
//   SGBM's full-image maps over the same pixels, in source pixels;
// - whole image: BM and SGBM over every pixel with a known truth, in source
//   pixels; ours over the same pixels from the finest level that covers each
//   one (what the retina sees), its error counted in that level's pixels
//   (|d - truth| / step: an outer level cannot resolve a source pixel).
// Time: per full pair on one thread (cv::setNumThreads(1)), the median of
// repeated runs: ours is both retinas sampled from the frames plus the stereo
// node's work; BM and SGBM are their compute() on the whole pair.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera_calibration.hpp"
#include "head_rectification.hpp"
#include "retina.hpp"
#include "retina_stereo.hpp"
#include "stereo_files.hpp"
#include "stereo_params.hpp"
#include "stereo_truth.hpp"
#include "unique_names.hpp"

namespace {

using namespace saccade;
using bench::hidden_from_right_camera;
using Clock = std::chrono::steady_clock;
bool verbose = false;     // per fixation, on stderr
bool error_maps = false;  // with verbose: each fovea's errors pixel by pixel

// A rectified pair, its left ground truth (source pixels, < 0 unknown), and
// the disparity range OpenCV's matchers are given (a multiple of 16 over the
// truth's largest): the range is known to them, not guessed.
struct Pair {
  std::string name, what;
  cv::Mat left, right;  // 8-bit gray
  cv::Mat truth;        // CV_32F
  cv::Mat hidden;       // CV_8U, 255 where the right camera cannot see the left pixel (from the truth)
  int num_disparities = 16;
  std::vector<cv::Point2d> fixations;  // where the fovea looks (empty: the 3 x 3 grid)
  std::string set;                     // pairs of one set are scored together, under the set's name
};

// ---------------------------------------------------------------- rendering

// A plane in the left camera's image: disparity a + b x + c y over a support
// (a rectangle or an ellipse; the background covers everything), textured by
// a photograph placed in the left image's coordinates.
struct Plane {
  double a = 0, b = 0, c = 0;
  enum class Shape { kAll, kRect, kEllipse } shape = Shape::kAll;
  cv::Rect2d box;              // the rectangle, or the ellipse's bounding box
  cv::Mat texture;             // CV_32F
  double texture_scale = 1.0;  // texture pixels per image pixel
  cv::Point2d texture_origin;

  double disparity(double x, double y) const { return a + b * x + c * y; }
  bool covers(double x, double y) const {
    switch (shape) {
      case Shape::kAll: return true;
      case Shape::kRect: return x >= box.x && x < box.x + box.width && y >= box.y && y < box.y + box.height;
      case Shape::kEllipse: {
        const double u = (x - (box.x + box.width / 2)) / (box.width / 2),
                     v = (y - (box.y + box.height / 2)) / (box.height / 2);
        return u * u + v * v <= 1.0;
      }
    }
    return false;
  }
  // Bilinear, the texture mirrored at its edges.
  float value(double x, double y) const {
    const double tx = texture_origin.x + x * texture_scale, ty = texture_origin.y + y * texture_scale;
    const int x0 = static_cast<int>(std::floor(tx)), y0 = static_cast<int>(std::floor(ty));
    const double fx = tx - x0, fy = ty - y0;
    const auto at = [&](int u, int v) {
      u = cv::borderInterpolate(u, texture.cols, cv::BORDER_REFLECT_101);
      v = cv::borderInterpolate(v, texture.rows, cv::BORDER_REFLECT_101);
      return static_cast<double>(texture.at<float>(v, u));
    };
    return static_cast<float>((1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
                              fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1)));
  }
};

cv::Mat texture(const std::string& data, const std::string& file) {
  cv::Mat m = cv::imread(data + "/" + file, cv::IMREAD_GRAYSCALE);
  if (m.empty()) {
    std::fprintf(stderr, "saccade_stereo_bench: %s/%s is missing: install opencv-doc\n", data.c_str(), file.c_str());
    std::exit(2);
  }
  cv::Mat f;
  m.convertTo(f, CV_32F);
  return f;
}

// Left: at each pixel the nearest plane covering it. Right: at right pixel
// (xr, y) plane p is seen where its left pixel x satisfies x - d_p(x, y) = xr,
// i.e. x = (xr + a + c y) / (1 - b), if p covers that point; the nearest such
// plane wins. The truth is the left's visible plane's disparity. Both views
// get Gaussian noise (sigma 1.5 gray levels) from a fixed seed.
Pair render(const std::string& name, const std::string& what, cv::Size size, const std::vector<Plane>& planes,
            uint64_t seed) {
  Pair p;
  p.name = name;
  p.what = what;
  cv::Mat left(size, CV_32F), right(size, CV_32F);
  p.truth.create(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const Plane* best = nullptr;
      double best_d = -1e9;
      for (const Plane& s : planes)
        if (s.covers(x, y) && s.disparity(x, y) > best_d) best = &s, best_d = s.disparity(x, y);
      left.at<float>(y, x) = best->value(x, y);
      p.truth.at<float>(y, x) = static_cast<float>(best_d);
      const Plane* seen = nullptr;
      double seen_d = -1e9, seen_x = 0;
      for (const Plane& s : planes) {
        const double xl = (x + s.a + s.c * y) / (1 - s.b);
        if (s.covers(xl, y) && s.disparity(xl, y) > seen_d) seen = &s, seen_d = s.disparity(xl, y), seen_x = xl;
      }
      right.at<float>(y, x) = seen->value(seen_x, y);
    }
  cv::RNG rng(seed);
  for (cv::Mat* m : {&left, &right}) {
    cv::Mat noise(size, CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.5);
    *m += noise;
  }
  left.convertTo(p.left, CV_8U);
  right.convertTo(p.right, CV_8U);
  p.num_disparities = bench::disparities_over(p.truth);
  return p;
}

Plane plane(double a, double b, double c, Plane::Shape shape, cv::Rect2d box, const cv::Mat& tex, double scale,
            cv::Point2d origin) {
  Plane s;
  s.a = a, s.b = b, s.c = c, s.shape = shape, s.box = box, s.texture = tex, s.texture_scale = scale;
  s.texture_origin = origin;
  return s;
}

std::vector<Pair> rendered_pairs(const std::string& data) {
  using S = Plane::Shape;
  const cv::Mat building = texture(data, "building.jpg"), home = texture(data, "home.jpg"),
                fruits = texture(data, "fruits.jpg"), baboon = texture(data, "baboon.jpg"),
                graf = texture(data, "graf1.png"), starry = texture(data, "starry_night.jpg"),
                board = texture(data, "board.jpg");
  std::vector<Pair> pairs;
  // 640x480: a slanted background (12 .. 33 px), two fronto-parallel boxes, a
  // slanted one and a disc in front of it.
  pairs.push_back(render("planes_640", "rendered 640x480, 5 planes, disparity 12-98 px", {640, 480},
                         {plane(12, 0.025, 0.01, S::kAll, {}, building, 0.9, {20, 10}),
                          plane(48, 0, 0, S::kRect, {80, 60, 200, 160}, fruits, 0.8, {10, 20}),
                          plane(70, 0.05, 0, S::kRect, {360, 200, 200, 200}, baboon, 0.85, {5, 5}),
                          plane(96, 0, 0, S::kRect, {200, 300, 120, 120}, graf, 0.75, {100, 80}),
                          plane(60, 0, -0.02, S::kEllipse, {470, 40, 130, 120}, starry, 0.9, {200, 100})},
                         24));
  // 450x375 (the size of small published pairs): a floor-like background
  // (6 .. 25 px, nearer downwards), a box, a slanted box and an ellipse.
  pairs.push_back(render("planes_450", "rendered 450x375, 4 planes, disparity 6-55 px", {450, 375},
                         {plane(6, 0, 0.05, S::kAll, {}, home, 0.85, {30, 40}),
                          plane(32, 0, 0, S::kRect, {40, 40, 150, 120}, baboon, 0.9, {60, 30}),
                          plane(40, 0.06, 0, S::kRect, {250, 150, 140, 160}, board, 0.8, {40, 60}),
                          plane(55, 0, 0, S::kEllipse, {80, 220, 140, 100}, fruits, 0.95, {150, 120})},
                         45));
  return pairs;
}

// The range OpenCV's matchers are given and the pair's description, from its
// truth; that truth's largest disparity.
double describe_truth(Pair& p, const std::string& label) {
  double largest = 0;
  cv::minMaxLoc(p.truth, nullptr, &largest);
  p.num_disparities = bench::disparities_over(p.truth);
  char what[160];
  std::snprintf(what, sizeof what, ", %dx%d, truth up to %.0f px (%.1f%% unknown)", p.left.cols, p.left.rows, largest,
                100.0 * cv::countNonZero(p.truth < 0) / static_cast<double>(p.truth.total()));
  p.what = label + what;
  return largest;
}

// Aloe, at `divisor` times smaller (area-averaged images, the truth divided;
// 0 = unknown becomes -1, and a pixel whose block has an unknown is unknown).
Pair aloe(const std::string& data, int divisor) {
  Pair p;
  cv::Mat l = cv::imread(data + "/aloeL.jpg", cv::IMREAD_GRAYSCALE),
          r = cv::imread(data + "/aloeR.jpg", cv::IMREAD_GRAYSCALE),
          t = cv::imread(data + "/aloeGT.png", cv::IMREAD_GRAYSCALE);
  if (l.empty() || r.empty() || t.empty()) {
    std::fprintf(stderr, "saccade_stereo_bench: the Aloe pair is missing under %s: install opencv-doc\n", data.c_str());
    std::exit(2);
  }
  cv::Mat truth;
  t.convertTo(truth, CV_32F);
  truth.setTo(-1e6, t == 0);
  if (divisor == 1) {
    p.left = l, p.right = r, p.truth = truth;
  } else {
    const cv::Size size(l.cols / divisor, l.rows / divisor);
    cv::resize(l, p.left, size, 0, 0, cv::INTER_AREA);
    cv::resize(r, p.right, size, 0, 0, cv::INTER_AREA);
    cv::resize(truth(cv::Rect(0, 0, size.width * divisor, size.height * divisor)), p.truth, size, 0, 0, cv::INTER_AREA);
    p.truth /= divisor;
  }
  p.truth.setTo(-1, p.truth < 0);
  p.name = divisor == 1 ? "aloe" : "aloe_third";
  describe_truth(p, divisor == 1 ? "Middlebury Aloe" : "Middlebury Aloe at a third");
  return p;
}

// A pair read from files (--middlebury, --stereo-pair); a file that cannot be
// read as the pair it should be is an error naming it.
Pair pair_from_files(const bench::StereoPairFiles& files) {
  Result<bench::StereoPairImages> read = bench::read_stereo_pair(files);
  if (!read.ok()) {
    std::fprintf(stderr, "saccade_stereo_bench: %s\n", read.error().c_str());
    std::exit(2);
  }
  // The retina the benchmark runs (its defaults) must fit the frames, as the
  // retina node checks them.
  if (const Status fits = retina::RetinaSampler(retina::RetinaConfig{}).check(read->left); !fits.ok()) {
    std::fprintf(stderr, "saccade_stereo_bench: %s: %s\n", files.left.c_str(), fits.message().c_str());
    std::exit(2);
  }
  Pair p;
  p.left = read->left, p.right = read->right, p.truth = read->truth;
  p.name = files.name;
  const double largest = describe_truth(p, files.left);
  if (!files.note.empty()) std::fprintf(stderr, "note: %s: %s\n", files.name.c_str(), files.note.c_str());
  if (const stereo::RetinaStereoConfig defaults; largest > defaults.max_disparity)
    std::fprintf(stderr,
                 "note: %s: its truth reaches beyond the defaults' max_disparity %d, which the floor's row "
                 "keeps; --set max_disparity=%d adds a row with the range\n",
                 files.name.c_str(), static_cast<int>(defaults.max_disparity), p.num_disparities);
  return p;
}

// opencv-doc's chessboard pairs (a real stereo rig, listed in its
// stereo_calib.xml; the gray images read once), calibrated as `saccade
// calibrate` does, and the maps that rectify them.
struct ChessboardRig {
  kinematics::CalibrationOptions options;
  std::vector<kinematics::ImagePair> pairs;
  double rms = 0;
  retina::PairRectification rectification;
  cv::Mat left_x, left_y, right_x, right_y;  // cv::remap's maps
};

ChessboardRig chessboard_rig(const std::string& data) {
  ChessboardRig rig;
  rig.options.board.size = cv::Size(9, 6);
  rig.options.board.square = 1.0;
  Result<std::vector<kinematics::ImagePair>> listed = kinematics::read_image_list(data + "/stereo_calib.xml");
  if (listed.ok()) rig.pairs = std::move(listed).value();
  for (kinematics::ImagePair& pair : rig.pairs) {
    pair.left_image = cv::imread(pair.left, cv::IMREAD_GRAYSCALE);
    pair.right_image = cv::imread(pair.right, cv::IMREAD_GRAYSCALE);
  }
  const kinematics::CalibrationResult calibrated =
      listed.ok() ? kinematics::calibrate_head(rig.pairs, rig.options) : kinematics::CalibrationResult{};
  const Result<retina::PairRectification> rectified =
      !listed.ok() ? Result<retina::PairRectification>(listed.status())
      : calibrated.status.ok()
          ? retina::rectify_pair(calibrated.calibration, kinematics::HeadGeometry{}, kinematics::HeadJoints{})
          : Result<retina::PairRectification>(calibrated.status);
  if (!rectified.ok()) {
    std::fprintf(stderr, "saccade_stereo_bench: the chessboard pairs under %s: %s\n", data.c_str(),
                 rectified.error().c_str());
    std::exit(2);
  }
  rig.rms = calibrated.calibration.rms;
  rig.rectification = *rectified;
  const cv::Size size = calibrated.calibration.image_size;
  const auto maps = [&](const Rectification& r, cv::Mat& x, cv::Mat& y) {
    cv::initUndistortRectifyMap(cv::Matx33d(r.camera.val), r.distortion, cv::Matx33d(r.rotation.val),
                                cv::Matx33d(r.rectified.val), size, CV_32FC1, x, y);
  };
  maps(rig.rectification.left, rig.left_x, rig.left_y);
  maps(rig.rectification.right, rig.right_x, rig.right_y);
  return rig;
}

// The board's inner corners in the rectified image (none where it is not found).
std::vector<cv::Point2f> rectified_corners(const cv::Mat& gray, const kinematics::BoardSpec& board,
                                           const Rectification& r) {
  const kinematics::BoardView view = kinematics::find_board(gray, board);
  std::vector<cv::Point2f> out;
  if (view.found())
    cv::undistortPoints(view.points, out, cv::Matx33d(r.camera.val), r.distortion, cv::Matx33d(r.rotation.val),
                        cv::Matx33d(r.rectified.val));
  return out;
}

// The pair's truth from the board's corners in both rectified images
// (bench::BoardDisparity: over the board's squares only), and five fixations
// on the board: its middle and half way to each of its corners.
void board_truth(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right, cv::Size corners,
                 cv::Size size, const std::string& name, Pair& p) {
  const bench::BoardDisparity board(left, right, corners);
  if (verbose)
    std::fprintf(stderr, "  %s: corners' rows within %.2f px after rectification\n", name.c_str(),
                 board.row_error_max());
  p.truth = board.truth(size);
  p.num_disparities = bench::disparities_over(p.truth);
  const double u = (corners.width - 1) / 4.0, v = (corners.height - 1) / 4.0;
  for (const cv::Point2d c : {board.on_board(2 * u, 2 * v), board.on_board(u, v), board.on_board(3 * u, v),
                              board.on_board(u, 3 * v), board.on_board(3 * u, 3 * v)})
    p.fixations.push_back(c);
}

// The chessboard pairs, rectified with their calibration, as one set; an
// error names what failed.
std::vector<Pair> chessboard_pairs(const std::string& data) {
  const ChessboardRig rig = chessboard_rig(data);
  std::vector<Pair> pairs;
  for (const kinematics::ImagePair& f : rig.pairs) {
    const cv::Mat &l = f.left_image, &r = f.right_image;
    const std::vector<cv::Point2f> lc = rectified_corners(l, rig.options.board, rig.rectification.left);
    const std::vector<cv::Point2f> rc = rectified_corners(r, rig.options.board, rig.rectification.right);
    const auto corner_count = static_cast<std::size_t>(rig.options.board.size.area());
    if (lc.size() != corner_count || rc.size() != corner_count) {
      std::fprintf(stderr, "saccade_stereo_bench: %s: the board is not found in both images\n", f.left.c_str());
      std::exit(2);
    }
    Pair p;
    cv::remap(l, p.left, rig.left_x, rig.left_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    cv::remap(r, p.right, rig.right_x, rig.right_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    board_truth(lc, rc, rig.options.board.size, l.size(), f.left, p);
    p.name = "chessboard_" + std::string(f.left.end() - 6, f.left.end() - 4);
    p.set = "chessboards";
    char what[200];
    std::snprintf(
        what, sizeof what,
        "opencv-doc's 13 chessboard pairs (a real stereo rig, 640x480), rectified with their calibration "
        "(RMS %.2f px); truth: the corners' disparities across the board's squares, 5 fixations on each board",
        rig.rms);
    p.what = what;
    pairs.push_back(std::move(p));
  }
  return pairs;
}

// ---------------------------------------------------------------- scoring

struct Score {
  double known = 0, given = 0, bad1 = 0, bad2 = 0;
  void add(double truth, double d, double step) {
    if (truth < 0) return;
    ++known;
    if (d < 0 || !std::isfinite(d)) return;
    ++given;
    const double e = std::abs(d - truth) / step;
    bad1 += e > 1;
    bad2 += e > 2;
  }
  void subtract(const Score& o) { known -= o.known, given -= o.given, bad1 -= o.bad1, bad2 -= o.bad2; }
  double density() const { return known > 0 ? given / known : 0; }
  double bad1_rate() const { return given > 0 ? bad1 / given : 0; }
  double bad2_rate() const { return given > 0 ? bad2 / given : 0; }
};

struct MatcherResult {
  std::string matcher;
  Score fovea, whole;
  Score fovea_seen, fovea_hidden;  // the fovea's pixels the right camera sees, and the others
  void add_fovea(const Pair& p, int x, int y, double d) {
    const float truth = p.truth.at<float>(y, x);
    fovea.add(truth, d, 1.0);
    (p.hidden.at<uint8_t>(y, x) ? fovea_hidden : fovea_seen).add(truth, d, 1.0);
  }
  double ms = 0;             // per full pair, median
  int fixations_right = -1;  // ours: fixation disparity within 2 px of the truth
  int fixations = 0;
  // Ours: fixations the matcher confirmed (Fixation::confirmed: what the
  // head verges on), and how many of those are within 2 px.
  int confirmed = 0, confirmed_right = 0;
  std::string note;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

std::vector<cv::Point2d> fixations(cv::Size size) {
  std::vector<cv::Point2d> out;
  for (double fy : {0.25, 0.5, 0.75})
    for (double fx : {0.25, 0.5, 0.75}) out.emplace_back(fx * size.width, fy * size.height);
  return out;
}

// StereoSGBM as the benchmark runs it (OpenCV's stereo_match sample's
// settings, gray images, 5x5 blocks), over `count` disparities from `first`.
cv::Ptr<cv::StereoSGBM> benchmark_sgbm(int first, int count) {
  return cv::StereoSGBM::create(first, count, 5, 8 * 25, 32 * 25, 1, 63, 10, 100, 32, cv::StereoSGBM::MODE_SGBM);
}

// `m` on the pair `left`, `right` `reps` times, its last map in `raw`; the
// median time, ms.
double median_compute_ms(const cv::Ptr<cv::StereoMatcher>& m, const cv::Mat& left, const cv::Mat& right, cv::Mat& raw,
                         int reps) {
  std::vector<double> ms;
  for (int i = 0; i < reps; ++i) {
    const auto t0 = Clock::now();
    m->compute(left, right, raw);
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  return median(ms);
}

// OpenCV's matchers: on the whole pair, CV_16S x 16, invalid below 0.
MatcherResult opencv_matcher(const std::string& name, const cv::Ptr<cv::StereoMatcher>& m, const Pair& p,
                             const std::vector<cv::Rect>& foveas, int reps) {
  MatcherResult r;
  r.matcher = name;
  cv::Mat raw;
  r.ms = median_compute_ms(m, p.left, p.right, raw, reps);
  cv::Mat d;
  raw.convertTo(d, CV_32F, 1.0 / 16);
  d.setTo(-1, raw < 0);
  for (int y = 0; y < d.rows; ++y)
    for (int x = 0; x < d.cols; ++x) r.whole.add(p.truth.at<float>(y, x), d.at<float>(y, x), 1.0);
  for (const cv::Rect& f : foveas)
    for (int y = f.y; y < f.br().y; ++y)
      for (int x = f.x; x < f.br().x; ++x) r.add_fovea(p, x, y, d.at<float>(y, x));
  r.fixations = static_cast<int>(foveas.size());
  r.note = "numDisparities " + std::to_string(p.num_disparities) + " (from the truth)";
  return r;
}

// StereoSGBM (benchmark_sgbm) on each fovea's neighbourhood
// alone: the fovea widened by `margin` pixels on every side, and to its left
// by the disparities searched, since SGBM leaves its first numDisparities
// columns empty. With `truths_range` the disparities searched are the truth's
// over that neighbourhood, 4 px wider each way (a best case: no matcher knows
// them beforehand), else the pair's. Scored on the foveas only; the time is
// the median per fovea. It tells how much of SGBM's accuracy on the fovea it
// owes to the rest of the image, and what seeing only that much costs it.
MatcherResult sgbm_around_foveas(const Pair& p, const std::vector<cv::Rect>& foveas, int margin, bool truths_range,
                                 int reps) {
  MatcherResult r;
  r.matcher = "OpenCV StereoSGBM, the fovea +-" + std::to_string(margin) + " px, " +
              (truths_range ? "the truth's range there" : "the pair's range");
  const cv::Rect image(0, 0, p.left.cols, p.left.rows);
  std::vector<double> ms;
  cv::Mat raw;
  for (const cv::Rect& f : foveas) {
    const cv::Rect around = cv::Rect(f.x - margin, f.y - margin, f.width + 2 * margin, f.height + 2 * margin) & image;
    int first = 0, count = p.num_disparities;
    if (truths_range) {
      const cv::Mat known = p.truth(around) >= 0;
      double low = 0, high = 0;  // (no known truth there: 0)
      if (cv::countNonZero(known) > 0) cv::minMaxLoc(p.truth(around), &low, &high, nullptr, nullptr, known);
      first = std::max(0, static_cast<int>(std::floor(low)) - 4);
      count = std::max(16, (static_cast<int>(std::ceil(high)) + 4 - first + 15) / 16 * 16);
    }
    const cv::Rect seen =
        cv::Rect(around.x - first - count, around.y, around.width + first + count, around.height) & image;
    ms.push_back(median_compute_ms(benchmark_sgbm(first, count), p.left(seen), p.right(seen), raw, reps));
    for (int y = f.y; y < f.br().y; ++y)
      for (int x = f.x; x < f.br().x; ++x) {
        const short d = raw.at<short>(y - seen.y, x - seen.x);
        r.add_fovea(p, x, y, d < first * 16 ? -1.0 : d / 16.0);
      }
  }
  r.ms = median(ms);
  r.fixations = static_cast<int>(foveas.size());
  r.note = "fovea only; per fovea";
  return r;
}

std::shared_ptr<Retina> make_retina(retina::RetinaSampler& sampler, const std::shared_ptr<Image>& frame,
                                    cv::Point2d fovea, std::shared_ptr<Retina> r) {
  if (!r) r = std::make_shared<Retina>();
  sampler.sample(frame->mat, fovea, *r);
  r->source = frame;
  return r;
}

// The fixation disparity against the truth's median over the central 5x5
// pixels around `c` (returned; -1 where unknown), counted in `r`.
double score_fixation(const Pair& p, cv::Point c, const stereo::Fixation& fixation, MatcherResult& r) {
  std::vector<double> around;
  for (int y = c.y - 2; y <= c.y + 2; ++y)
    for (int x = c.x - 2; x <= c.x + 2; ++x)
      if (p.truth.at<float>(y, x) >= 0) around.push_back(p.truth.at<float>(y, x));
  const double truth = around.empty() ? -1.0 : median(around);
  const bool right = truth >= 0 && fixation.disparity >= 0 && std::abs(fixation.disparity - truth) <= 2;
  r.fixations_right += right;
  r.confirmed += fixation.confirmed;
  r.confirmed_right += fixation.confirmed && right;
  return truth;
}

// A fovea's disparity against the truth, a character per pixel: o within 2 px,
// + nearer (larger) than the truth, - farther, . none given, ? no truth; and
// the truth (rounded) every other column beside it.
void print_error_map(const cv::Mat& truth, const cv::Mat& disparity) {
  for (int y = 0; y < truth.rows; ++y) {
    std::fprintf(stderr, "    ");
    for (int x = 0; x < truth.cols; ++x) {
      const float t = truth.at<float>(y, x), d = disparity.at<float>(y, x);
      std::fputc(d < 0 ? '.' : t < 0 ? '?' : std::abs(d - t) <= 2 ? 'o' : d > t ? '+' : '-', stderr);
    }
    std::fprintf(stderr, "   ");
    for (int x = 0; x < truth.cols; x += 2) std::fprintf(stderr, "%4.0f", truth.at<float>(y, x));
    std::fputc('\n', stderr);
  }
}

// Our matcher with one configuration on every fixation of the pair.
MatcherResult ours(const std::string& name, const stereo::RetinaStereoConfig& config,
                   const retina::RetinaConfig& retina_config, const Pair& p, int reps,
                   std::vector<cv::Rect>* foveas_out) {
  MatcherResult r;
  r.matcher = name;
  auto left_frame = std::make_shared<Image>(), right_frame = std::make_shared<Image>();
  left_frame->mat = p.left;
  right_frame->mat = p.right;
  retina::RetinaSampler left_sampler(retina_config), right_sampler(retina_config);
  stereo::RetinaStereo matcher(config);
  std::vector<stereo::LevelDisparity> out;
  std::shared_ptr<Retina> left, right;
  std::vector<double> ms;
  r.fixations_right = 0;
  for (const cv::Point2d& f : p.fixations.empty() ? fixations(p.left.size()) : p.fixations) {
    for (int i = 0; i < reps; ++i) {
      const auto t0 = Clock::now();
      left = make_retina(left_sampler, left_frame, f, left);
      right = make_retina(right_sampler, right_frame, f, right);
      const Status matched = matcher.run(*left, *right, out);
      ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (!matched.ok()) {
        std::fprintf(stderr, "saccade_stereo_bench: %s on %s: %s\n", name.c_str(), p.name.c_str(),
                     matched.message().c_str());
        std::exit(1);
      }
    }
    ++r.fixations;
    const std::size_t n = out.size();
    const LevelGeometry& fovea = left->geometry.back();
    if (foveas_out != nullptr) foveas_out->push_back(fovea.region);
    const Score fovea_before = r.fovea, seen_before = r.fovea_seen, hidden_before = r.fovea_hidden;
    for (int y = 0; y < fovea.region.height; ++y)
      for (int x = 0; x < fovea.region.width; ++x)
        r.add_fovea(p, fovea.region.x + x, fovea.region.y + y, out[n - 1].disparity.at<float>(y, x));
    // Whole image: each pixel from the finest level whose region holds it.
    for (int y = 0; y < p.left.rows; ++y)
      for (int x = 0; x < p.left.cols; ++x) {
        for (std::size_t k = n; k-- > 0;) {
          const LevelGeometry& g = left->geometry[k];
          if (!g.region.contains(cv::Point(x, y))) continue;
          const int lx = std::min(out[k].disparity.cols - 1, static_cast<int>((x - g.region.x) / g.step_x));
          const int ly = std::min(out[k].disparity.rows - 1, static_cast<int>((y - g.region.y) / g.step_y));
          r.whole.add(p.truth.at<float>(y, x), out[k].disparity.at<float>(ly, lx), g.step_x);
          break;
        }
      }
    const cv::Point c(static_cast<int>(fovea.region.x + fovea.region.width / 2),
                      static_cast<int>(fovea.region.y + fovea.region.height / 2));
    const double truth = score_fixation(p, c, matcher.fixation(), r);
    const double fixation = matcher.fixation().disparity;
    if (verbose) {
      std::fprintf(
          stderr,
          "  %-32s (%4.0f, %4.0f): fixation %6.1f truth %6.1f (%s; the centre %s); fovea so far %.3f / %.3f; per level",
          name.c_str(), f.x, f.y, fixation, truth, matcher.fixation().confirmed ? "confirmed" : "unconfirmed",
          p.hidden.at<uint8_t>(c) ? "hidden from the right camera" : "seen", r.fovea.density(), r.fovea.bad2_rate());
      for (double d : matcher.fixation().per_level) std::fprintf(stderr, " %.1f", d);
      Score mine = r.fovea;
      mine.subtract(fovea_before);
      Score seen = r.fovea_seen, hidden = r.fovea_hidden;
      seen.subtract(seen_before);
      hidden.subtract(hidden_before);
      std::fprintf(stderr, "; this fovea %.3f / %.3f (seen %.0f: %.3f / %.3f, hidden %.0f: %.3f / %.3f)",
                   mine.density(), mine.bad2_rate(), seen.known, seen.density(), seen.bad2_rate(), hidden.known,
                   hidden.density(), hidden.bad2_rate());
      std::fprintf(stderr, "\n");
      if (error_maps) print_error_map(p.truth(fovea.region), out[n - 1].disparity);
    }
  }
  r.ms = median(ms);
  char note[96];
  std::snprintf(
      note, sizeof note, "max_disparity %s",
      config.max_disparity > 0 ? std::to_string(static_cast<int>(config.max_disparity)).c_str() : "automatic");
  r.note = note;
  return r;
}

// ---------------------------------------------------------------- configurations

// docs/accuracy.md's densest configuration, spelled out.
stereo::RetinaStereoConfig densest() {
  stereo::RetinaStereoConfig c;
  c.ncc.semi_global = true;
  c.ncc.paths = 8;
  c.fill_gaps = 2;
  c.fill_occlusions = true;
  c.fovea_prediction = true;
  return c;
}

// docs/accuracy.md's precise configuration: the defaults with the fovea's
// hidden pixels and small regions dropped (fewer wrong disparities, a lower density).
stereo::RetinaStereoConfig precise() {
  stereo::RetinaStereoConfig c;
  c.occlusion_check = true;
  c.fovea_speckle_size = 50;
  return c;
}

std::string fmt(const char* f, double v) {
  char b[32];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// Which of our matcher's configurations run, beside the defaults, and how often.
struct Matchers {
  int reps = 5, cv_reps = 3;
  std::vector<int> sgbm_margins;  // --sgbm-context: SGBM on the foveas' neighbourhoods alone
  bool all_variants = false;
  bool custom_set = false;  // --set given: `custom` runs too
  stereo::RetinaStereoConfig custom;
  std::string custom_name;
};

// The defaults changed by --set key=value (the stereo node's parameters,
// checked as in a graph); false (with the reason printed) on one that is not.
bool parse_sets(const std::vector<std::string>& sets, Matchers& m) {
  m.custom_set = !sets.empty();
  for (const std::string& s : sets) m.custom_name += (m.custom_name.empty() ? "" : ", ") + s;
  const auto settings = split_settings(sets);
  const Result<stereo::StereoNodeConfig> configured =
      settings.ok() ? configure(&stereo::bind_stereo_params, *settings) : settings.status();
  const Status checked = configured.ok() ? stereo::check_stereo_params(*configured) : configured.status();
  if (!checked.ok()) {
    std::fprintf(stderr, "saccade_stereo_bench: --set: %s\n", checked.message().c_str());
    return false;
  }
  m.custom = configured->stereo;
  return true;
}

// Where the pairs come from: the built-in ones --pair names (all of them
// without it, none with --no-builtin), then those read from files.
struct PairSources {
  std::vector<std::string> only, middlebury, files;
  bool no_builtin = false;
  std::string export_dir;  // --export: the pairs are written there instead of scored
};

// The files --middlebury and --stereo-pair name; an error names the one at fault.
std::vector<bench::StereoPairFiles> given_pairs(const PairSources& from) {
  std::vector<bench::StereoPairFiles> out;
  const auto take = [&](const char* option, const Result<bench::StereoPairFiles>& found) {
    if (!found.ok()) {
      std::fprintf(stderr, "saccade_stereo_bench: %s %s\n", option, found.error().c_str());
      std::exit(2);
    }
    out.push_back(*found);
  };
  for (const std::string& spec : from.middlebury) take("--middlebury", bench::find_middlebury_pair(spec));
  for (const std::string& spec : from.files) take("--stereo-pair", bench::parse_stereo_pair(spec));
  return out;
}

// The pairs, in the tables' order.
std::vector<Pair> select_pairs(const std::string& data, const PairSources& from) {
  // Their names and layouts checked before the built-ins' work; their images read after.
  const std::vector<bench::StereoPairFiles> given = given_pairs(from);
  std::vector<Pair> pairs;
  const std::vector<std::string>& only = from.only;
  const auto wanted = [&](const std::string& name) {
    return !from.no_builtin && (only.empty() || std::find(only.begin(), only.end(), name) != only.end());
  };
  if (wanted("aloe")) pairs.push_back(aloe(data, 1));
  if (wanted("aloe_third")) pairs.push_back(aloe(data, 3));
  for (Pair& p : rendered_pairs(data))
    if (wanted(p.name)) pairs.push_back(std::move(p));
  if (wanted("chessboards"))
    for (Pair& p : chessboard_pairs(data)) pairs.push_back(std::move(p));
  for (const bench::StereoPairFiles& files : given) pairs.push_back(pair_from_files(files));
  bench::make_names_unique(pairs, [](Pair& p) -> std::string& { return p.name; });
  for (Pair& p : pairs) p.hidden = hidden_from_right_camera(p.truth);
  return pairs;
}

// --export: each pair in Middlebury's 2014 layout under DIR/<its name>.
int export_pairs(const std::vector<Pair>& pairs, const std::string& dir) {
  for (const Pair& p : pairs) {
    const std::string to = dir + "/" + p.name;
    if (const Status written = bench::write_middlebury_pair(to, {p.left, p.right, p.truth}); !written.ok()) {
      std::fprintf(stderr, "saccade_stereo_bench: --export %s\n", written.message().c_str());
      return 1;
    }
    std::printf("%s: %s\n", to.c_str(), p.what.c_str());
  }
  return 0;
}

// Every matcher on one pair: ours with the defaults first (its foveas are where
// the others' fovea scores are taken), then the variants asked for, then BM and
// SGBM last (the floor compares the first with the last).
std::vector<MatcherResult> run_matchers(const Pair& p, const retina::RetinaConfig& retina_config, const Matchers& m) {
  std::vector<MatcherResult> results;
  std::vector<cv::Rect> foveas;
  results.push_back(ours("saccade, defaults", stereo::RetinaStereoConfig{}, retina_config, p, m.reps, &foveas));
  if (m.all_variants) {
    results.push_back(ours("saccade, plain NCC", stereo::plain_matcher_config(), retina_config, p, m.reps, nullptr));
    results.push_back(ours("saccade, densest (accuracy.md)", densest(), retina_config, p, m.reps, nullptr));
    results.push_back(ours("saccade, precise (accuracy.md)", precise(), retina_config, p, m.reps, nullptr));
  }
  if (m.custom_set) results.push_back(ours("saccade, " + m.custom_name, m.custom, retina_config, p, m.reps, nullptr));
  auto bm = cv::StereoBM::create(p.num_disparities, 9);
  bm->setTextureThreshold(10);
  bm->setUniquenessRatio(15);
  bm->setSpeckleWindowSize(100);
  bm->setSpeckleRange(32);
  bm->setDisp12MaxDiff(1);
  for (int margin : m.sgbm_margins)
    for (bool truths_range : {false, true})
      results.push_back(sgbm_around_foveas(p, foveas, margin, truths_range, m.cv_reps));
  results.push_back(opencv_matcher("OpenCV StereoBM (9x9)", bm, p, foveas, m.cv_reps));
  results.push_back(
      opencv_matcher("OpenCV StereoSGBM (5x5)", benchmark_sgbm(0, p.num_disparities), p, foveas, m.cv_reps));
  return results;
}

void write_results_table(std::ostringstream& md, const std::string& name, const std::string& what,
                         const std::vector<MatcherResult>& results) {
  md << "\n### " << name << ": " << what << "\n\n"
     << "| matcher | fovea density | fovea bad-1 | fovea bad-2 | image density | image bad-1 | image bad-2 | ms per "
        "pair "
        "| fixation within 2 px: all; confirmed | notes |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const MatcherResult& r : results) {
    const auto whole = [&](const char* f, double v) { return r.whole.known > 0 ? fmt(f, v) : std::string("-"); };
    md << "| " << r.matcher << " | " << fmt("%.3f", r.fovea.density()) << " | " << fmt("%.3f", r.fovea.bad1_rate())
       << " | " << fmt("%.3f", r.fovea.bad2_rate()) << " | " << whole("%.3f", r.whole.density()) << " | "
       << whole("%.3f", r.whole.bad1_rate()) << " | " << whole("%.3f", r.whole.bad2_rate()) << " | "
       << fmt(r.ms < 10 ? "%.3f" : "%.1f", r.ms) << " | "
       << (r.fixations_right >= 0 ? std::to_string(r.fixations_right) + "/" + std::to_string(r.fixations) + "; " +
                                        std::to_string(r.confirmed_right) + "/" + std::to_string(r.confirmed)
                                  : "")
       << " | " << r.note << " |\n";
  }
  const MatcherResult& any = results.front();
  md << "\nThe foveas' pixels the right camera sees (" << fmt("%.0f", any.fovea_seen.known)
     << ") and those a nearer surface hides from it (" << fmt("%.0f", any.fovea_hidden.known) << ", "
     << fmt("%.0f", 100.0 * any.fovea_hidden.known / std::max(1.0, any.fovea.known))
     << "%: their truth is the hidden surface's)\n\n"
     << "| matcher | seen: density | seen: bad-2 | hidden: density | hidden: bad-2 |\n|---|---|---|---|---|\n";
  for (const MatcherResult& r : results)
    md << "| " << r.matcher << " | " << fmt("%.3f", r.fovea_seen.density()) << " | "
       << fmt("%.3f", r.fovea_seen.bad2_rate()) << " | " << fmt("%.3f", r.fovea_hidden.density()) << " | "
       << fmt("%.3f", r.fovea_hidden.bad2_rate()) << " |\n";
}

// One set's pairs scored together: counts summed, times averaged over the pairs.
void merge(std::vector<MatcherResult>& into, const std::vector<MatcherResult>& results, int pairs_before) {
  if (into.empty()) {
    into = results;
    return;
  }
  for (std::size_t i = 0; i < into.size() && i < results.size(); ++i) {
    MatcherResult& a = into[i];
    const MatcherResult& b = results[i];
    for (auto [x, y] : {std::pair{&a.fovea, &b.fovea}, std::pair{&a.whole, &b.whole},
                        std::pair{&a.fovea_seen, &b.fovea_seen}, std::pair{&a.fovea_hidden, &b.fovea_hidden}}) {
      x->known += y->known, x->given += y->given, x->bad1 += y->bad1, x->bad2 += y->bad2;
    }
    a.ms = (a.ms * pairs_before + b.ms) / (pairs_before + 1);
    if (a.fixations_right >= 0) a.fixations_right += b.fixations_right;
    a.fixations += b.fixations, a.confirmed += b.confirmed, a.confirmed_right += b.confirmed_right;
    if (a.note.rfind("numDisparities", 0) == 0) a.note = "numDisparities from each pair's truth";
  }
}

struct Floor {
  std::string pair;
  MatcherResult ours, sgbm;
};

// The floor: the defaults' fovea against SGBM's, at <= 1/20 of its time.
std::string floor_table(const std::vector<Floor>& floors) {
  std::ostringstream summary;
  summary
      << "\n### The floor: defaults against StereoSGBM, fovea\n\n"
      << "| pair | density (ours / SGBM) | bad-2 (ours / SGBM) | time (ours / SGBM) | met |\n|---|---|---|---|---|\n";
  for (const Floor& f : floors) {
    const bool dense = f.ours.fovea.density() >= f.sgbm.fovea.density();
    const bool right = f.ours.fovea.bad2_rate() <= f.sgbm.fovea.bad2_rate();
    const bool fast = f.ours.ms * 20 <= f.sgbm.ms;
    summary << "| " << f.pair << " | " << fmt("%.3f", f.ours.fovea.density()) << " / "
            << fmt("%.3f", f.sgbm.fovea.density()) << " | " << fmt("%.3f", f.ours.fovea.bad2_rate()) << " / "
            << fmt("%.3f", f.sgbm.fovea.bad2_rate()) << " | 1/"
            << fmt(f.sgbm.ms >= 10 * f.ours.ms ? "%.0f" : "%.2g", f.sgbm.ms / std::max(1e-9, f.ours.ms)) << " | "
            << (dense && right && fast
                    ? "yes"
                    : std::string("no:") + (dense ? "" : " density") + (right ? "" : " bad-2") + (fast ? "" : " time"))
            << " |\n";
  }
  return summary.str();
}

// Every pair scored, each table printed as soon as it is measured (a full run
// takes minutes), then the floor's; the whole report.
std::string score_pairs(const std::vector<Pair>& pairs, const Matchers& matchers) {
  const retina::RetinaConfig retina_config;  // the retina's defaults: 5 levels of 32x24
  std::string report;
  std::ostringstream md;
  md << "\nRetina: " << retina_config.levels << " levels of " << retina_config.size.width << "x"
     << retina_config.size.height << "; fixations: 3 x 3 grid; one thread; times are medians of " << matchers.reps
     << " runs per fixation (ours) and " << matchers.cv_reps << " per pair (OpenCV).\n";
  std::vector<Floor> floors;
  std::vector<MatcherResult> set_results;
  int set_pairs = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const Pair& p = pairs[i];
    std::fprintf(stderr, "%s: %s\n", p.name.c_str(), p.what.c_str());
    std::vector<MatcherResult> results = run_matchers(p, retina_config, matchers);
    if (!p.set.empty()) {
      merge(set_results, results, set_pairs++);
      if (i + 1 < pairs.size() && pairs[i + 1].set == p.set) continue;
      results = std::move(set_results);
      set_results.clear();
      set_pairs = 0;
    }
    const std::string name = p.set.empty() ? p.name : p.set;
    floors.push_back({name, results.front(), results.back()});
    write_results_table(md, name, p.what, results);
    // Each pair's table as soon as it is measured: a full run takes minutes.
    std::fputs(md.str().c_str(), stdout);
    std::fflush(stdout);
    report += md.str();
    md.str("");
  }
  const std::string summary = floor_table(floors);
  std::fputs(summary.c_str(), stdout);
  return report + summary;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Stereo benchmark: the retina matcher against OpenCV's StereoBM and StereoSGBM, one thread"};
  std::string data = SACCADE_SAMPLE_DATA, markdown;
  Matchers matchers;
  std::vector<std::string> sets;
  PairSources sources;
  app.add_option("--data", data, "opencv-doc's examples/data folder");
  app.add_option("--markdown", markdown, "write the tables to this file");
  app.add_option("--reps", matchers.reps, "runs of our matcher per fixation (the time is their median)");
  app.add_option("--cv-reps", matchers.cv_reps, "runs of BM and SGBM per pair (the time is their median)");
  app.add_option("--set", sets,
                 "key=value: also run our matcher with the defaults changed so (repeatable; "
                 "the stereo node's parameter names)");
  app.add_option("--pair", sources.only, "only these built-in pairs (repeatable, or comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"aloe", "aloe_third", "planes_640", "planes_450", "chessboards"}));
  app.add_option("--middlebury", sources.middlebury,
                 "DIR[:SCALE]: also a Middlebury scene's folder (the 2014/2021, 2005/2006 or 2001/2003 layout; "
                 "SCALE: the truth's value of one pixel of disparity, needed for 2001/2003; repeatable)");
  app.add_option("--stereo-pair", sources.files,
                 "LEFT,RIGHT,TRUTH[,SCALE]: also a rectified pair and its left truth (PFM, or an 8- or 16-bit image "
                 "with its SCALE, 0 unknown: KITTI's is 256; repeatable)");
  app.add_flag("--no-builtin", sources.no_builtin, "only the pairs --middlebury and --stereo-pair give");
  app.add_option("--export", sources.export_dir,
                 "DIR: write the pairs in Middlebury's 2014 layout (DIR/<pair>/im0.png, im1.png, disp0.pfm, "
                 "calib.txt) instead of scoring them");
  app.add_option("--sgbm-context", matchers.sgbm_margins,
                 "M[,M...]: also StereoSGBM on each fovea widened by M px on every side (and to its left by the "
                 "disparities searched) alone, with the pair's range and with the truth's range there")
      ->delimiter(',')
      ->check(CLI::Range(0, 100000));
  app.add_flag("--verbose", verbose, "each fixation's disparity and the fovea's running score, on stderr");
  app.add_flag("--error-maps", error_maps,
               "with --verbose, each fovea's pixels: o within 2 px of the truth, + nearer, - farther, . none, "
               "? no truth; the truth beside");
  app.add_flag("--variants", matchers.all_variants,
               "also run the plain matcher and docs/accuracy.md's densest and precise configurations");
  // A value given twice is the last one: make's STEREO_ARGS can change what a target gives.
  for (const char* single : {"--data", "--markdown", "--reps", "--cv-reps", "--export"})
    app.get_option(single)->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  CLI11_PARSE(app, argc, argv);
  cv::setNumThreads(1);
  if (!parse_sets(sets, matchers)) return 2;
  const std::vector<Pair> pairs = select_pairs(data, sources);
  if (pairs.empty()) {
    std::fprintf(stderr, "saccade_stereo_bench: no pairs: --no-builtin without --middlebury or --stereo-pair\n");
    return 2;
  }
  if (!sources.export_dir.empty()) return export_pairs(pairs, sources.export_dir);

  const std::string report = score_pairs(pairs, matchers);
  if (!markdown.empty()) {
    std::ofstream file(markdown);
    file << "# Stereo benchmark (make bench-stereo)\n\nWhat is measured: apps/bench/stereo_bench.cpp.\n" << report;
    if (!file) {
      std::fprintf(stderr, "saccade_stereo_bench: cannot write %s\n", markdown.c_str());
      return 1;
    }
  }
  return 0;
}
