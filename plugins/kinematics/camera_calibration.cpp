#include "camera_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace saccade::kinematics {
namespace {

std::string size_text(cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

std::string number_text(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

bool finite(const cv::Mat& m) { return cv::checkRange(m, true, nullptr, -1e300, 1e300); }

// In the order of cv::aruco::PREDEFINED_DICTIONARY_NAME.
const std::vector<std::string>& dictionary_names() {
  static const std::vector<std::string> names = {
      "DICT_4X4_50",        "DICT_4X4_100",        "DICT_4X4_250",       "DICT_4X4_1000",      "DICT_5X5_50",
      "DICT_5X5_100",       "DICT_5X5_250",        "DICT_5X5_1000",      "DICT_6X6_50",        "DICT_6X6_100",
      "DICT_6X6_250",       "DICT_6X6_1000",       "DICT_7X7_50",        "DICT_7X7_100",       "DICT_7X7_250",
      "DICT_7X7_1000",      "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10",
      "DICT_APRILTAG_36h11"};
  return names;
}

int dictionary_id(const std::string& name) {
  const auto& names = dictionary_names();
  auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

cv::Ptr<cv::aruco::CharucoBoard> charuco_board(const BoardSpec& board) {
  auto dictionary = cv::aruco::getPredefinedDictionary(dictionary_id(board.dictionary));
  return cv::aruco::CharucoBoard::create(board.size.width, board.size.height, static_cast<float>(board.square),
                                         static_cast<float>(board.marker), dictionary);
}

cv::Mat gray_of(const cv::Mat& image) {
  if (image.empty() || image.type() == CV_8UC1) return image;
  cv::Mat gray, eight;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4)
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  else
    gray = image;
  if (gray.depth() != CV_8U)
    gray.convertTo(eight, CV_8U);
  else
    eight = gray;
  return eight;
}

// Reads keys of a calibration file; the first key that is missing or bad
// sets `status`, and every read after it returns a default.
struct KeyReader {
  const cv::FileStorage& fs;
  const std::string& path;
  Status status;

  bool failed() const { return !status.ok(); }
  void fail(const std::string& key, const std::string& why) { status = Status::error(where(key) + why); }

  std::string where(const std::string& key) const { return "calibration file '" + path + "': key '" + key + "'"; }

  cv::Mat matrix(const std::string& key) {
    if (failed()) return {};
    cv::FileNode node = fs[key];
    if (node.empty() || node.isNone()) {
      fail(key, " is missing");
      return {};
    }
    cv::Mat m;
    try {
      node >> m;
    } catch (const cv::Exception&) { m.release(); }
    if (m.empty() || m.channels() != 1) {
      fail(key, " is not a matrix");
      return {};
    }
    m.convertTo(m, CV_64F);
    if (!finite(m)) fail(key, " holds a value that is not a finite number");
    return m;
  }

  cv::Matx33d camera(const std::string& key) {
    cv::Mat m = matrix(key);
    if (failed()) return cv::Matx33d::eye();
    if (m.rows != 3 || m.cols != 3) {
      fail(key, " must be a 3x3 camera matrix, got " + std::to_string(m.rows) + "x" + std::to_string(m.cols));
      return cv::Matx33d::eye();
    }
    cv::Matx33d k(m);
    if (k(0, 0) <= 0 || k(1, 1) <= 0 || k(2, 2) != 1 || k(1, 0) != 0 || k(2, 0) != 0 || k(2, 1) != 0)
      fail(key, " is not a camera matrix (fx, fy > 0, last row 0 0 1)");
    return k;
  }

  std::vector<double> distortion(const std::string& key) {
    cv::Mat m = matrix(key);
    if (failed()) return {};
    const std::size_t n = m.total();
    if ((m.rows != 1 && m.cols != 1) || (n != 4 && n != 5 && n != 8 && n != 12 && n != 14)) {
      fail(key, " must hold 4, 5, 8, 12 or 14 distortion coefficients in one row, got " + std::to_string(m.rows) + "x" +
                    std::to_string(m.cols));
      return {};
    }
    m = m.reshape(1, 1);
    return std::vector<double>(m.begin<double>(), m.end<double>());
  }

  int positive_int(const std::string& key) {
    if (failed()) return 0;
    cv::FileNode node = fs[key];
    if (node.empty() || node.isNone()) {
      fail(key, " is missing (the size of the images the cameras were calibrated at)");
      return 0;
    }
    if (!node.isInt() || static_cast<int>(node) <= 0) {
      fail(key, " must be a positive integer");
      return 0;
    }
    return static_cast<int>(node);
  }

  double optional_number(const std::string& key) {
    cv::FileNode node = fs[key];
    if (failed() || node.empty() || node.isNone()) return 0;
    if (!node.isReal() && !node.isInt()) {
      fail(key, " must be a number");
      return 0;
    }
    const double v = static_cast<double>(node);
    if (!std::isfinite(v) || v < 0) fail(key, " must be a number >= 0, got " + number_text(v));
    return v;
  }
};

}  // namespace

Result<HeadCalibration> read_head_calibration(const std::string& path) {
  cv::FileStorage fs;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return Status::error("cannot open calibration file '" + path + "'");
  try {
    if (!fs.open(path, cv::FileStorage::READ)) return Status::error("cannot open calibration file '" + path + "'");
  } catch (const cv::Exception& e) {
    return Status::error("calibration file '" + path + "' cannot be parsed: " + e.err);
  }
  KeyReader keys{fs, path, {}};
  HeadCalibration c;
  c.path = path;
  c.left_matrix = keys.camera("M1");
  c.left_distortion = keys.distortion("D1");
  c.right_matrix = keys.camera("M2");
  c.right_distortion = keys.distortion("D2");
  cv::Mat r = keys.matrix("R");
  if (!keys.failed()) {
    if (r.total() == 3 && (r.rows == 1 || r.cols == 1)) {
      cv::Mat rotation;
      cv::Rodrigues(r, rotation);  // a rotation vector, as cv::stereoCalibrate's older callers wrote
      r = rotation;
    }
    if (r.rows != 3 || r.cols != 3) {
      keys.fail("R", " must be a 3x3 rotation matrix, got " + std::to_string(r.rows) + "x" + std::to_string(r.cols));
    } else {
      c.rotation = cv::Matx33d(r);
      const double off = cv::norm(c.rotation * c.rotation.t() - cv::Matx33d::eye());
      if (off > 1e-3 || cv::determinant(c.rotation) <= 0)
        keys.fail("R", " is not a rotation (R R^T differs from I by " + number_text(off) + ")");
    }
  }
  cv::Mat t = keys.matrix("T");
  if (!keys.failed()) {
    if (t.total() != 3 || (t.rows != 1 && t.cols != 1))
      keys.fail("T",
                " must be a translation of 3 values, got " + std::to_string(t.rows) + "x" + std::to_string(t.cols));
    else
      c.translation = cv::Vec3d(t.reshape(1, 3));
  }
  const int width = keys.positive_int("image_width");
  const int height = keys.positive_int("image_height");
  c.image_size = cv::Size(width, height);
  c.rms = keys.optional_number("rms");
  c.epipolar_error = keys.optional_number("epipolar_error");
  if (keys.failed()) return keys.status;
  if (cv::FileNode board = fs["board"]; board.isString()) c.board = static_cast<std::string>(board);
  for (const cv::FileNode& pair : fs["pairs"]) {
    HeadCalibration::PairError e;
    if (pair["left"].isString()) e.left = static_cast<std::string>(pair["left"]);
    if (pair["right"].isString()) e.right = static_cast<std::string>(pair["right"]);
    if (pair["rms"].isReal() || pair["rms"].isInt()) e.rms = static_cast<double>(pair["rms"]);
    c.pairs.push_back(e);
  }
  return c;
}

Status write_head_calibration(const std::string& path, const HeadCalibration& c) {
  if (c.image_size.width <= 0 || c.image_size.height <= 0)
    return Status::error("cannot write calibration file '" + path + "': no image size");
  cv::Mat d1(c.left_distortion, true), d2(c.right_distortion, true);
  d1 = d1.reshape(1, 1);
  d2 = d2.reshape(1, 1);
  cv::Mat r1, r2, p1, p2, q;
  try {
    // As stereo_calib writes them: rectification at the joints' zero, principal
    // points made equal, every source pixel kept (alpha 1).
    cv::stereoRectify(cv::Mat(c.left_matrix), d1, cv::Mat(c.right_matrix), d2, c.image_size, cv::Mat(c.rotation),
                      cv::Mat(c.translation), r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 1, c.image_size);
  } catch (const cv::Exception& e) {
    return Status::error("cannot write calibration file '" + path + "': stereoRectify failed: " + e.err);
  }
  cv::FileStorage fs;
  try {
    if (!fs.open(path, cv::FileStorage::WRITE)) return Status::error("cannot write calibration file '" + path + "'");
    fs.writeComment(
        "saccade calibrate: a stereo head at its joints' zero. Keys as OpenCV's stereo_calib sample:\n"
        "M1 D1 / M2 D2 each camera's matrix and distortion, x_right = R x_left + T (metres),\n"
        "R1 R2 P1 P2 Q from stereoRectify at the joints' zero; rms and epipolar_error in pixels.");
    fs << "image_width" << c.image_size.width << "image_height" << c.image_size.height;
    fs << "M1" << cv::Mat(c.left_matrix) << "D1" << d1 << "M2" << cv::Mat(c.right_matrix) << "D2" << d2;
    fs << "R" << cv::Mat(c.rotation) << "T" << cv::Mat(c.translation);
    fs << "R1" << r1 << "R2" << r2 << "P1" << p1 << "P2" << p2 << "Q" << q;
    fs << "baseline" << c.baseline() << "rms" << c.rms << "epipolar_error" << c.epipolar_error;
    if (!c.board.empty()) fs << "board" << c.board;
    fs << "pairs"
       << "[";
    for (const auto& pair : c.pairs)
      fs << "{"
         << "left" << pair.left << "right" << pair.right << "rms" << pair.rms << "}";
    fs << "]";
    fs.release();
  } catch (const cv::Exception& e) { return Status::error("cannot write calibration file '" + path + "': " + e.err); }
  return {};
}

Status check_frame_size(const HeadCalibration& calibration, cv::Size frame) {
  if (calibration.image_size == frame) return {};
  const std::string file = calibration.path.empty() ? "the calibration" : "calibration file '" + calibration.path + "'";
  return Status::error(file + " is for " + size_text(calibration.image_size) + " images, but the frames are " +
                       size_text(frame) + " (calibrate at the frame size the cameras deliver)");
}

Status BoardSpec::check() const {
  const bool charuco = kind == Kind::kCharuco;
  const int least = charuco ? 3 : 2;
  if (size.width < least || size.height < least)
    return Status::error(
        std::string("board ") + size_text(size) + ": " +
        (charuco ? "a ChArUco board needs at least 3x3 squares" : "a chessboard needs at least 2x2 inner corners"));
  if (!std::isfinite(square) || square <= 0)
    return Status::error("board square size must be > 0 metres, got " + number_text(square));
  if (!charuco) return {};
  if (!std::isfinite(marker) || marker <= 0 || marker >= square)
    return Status::error("ChArUco marker size must be > 0 and smaller than the square (" + number_text(square) +
                         " m), got " + number_text(marker));
  const int id = dictionary_id(dictionary);
  if (id < 0)
    return Status::error("unknown ArUco dictionary '" + dictionary +
                         "' (e.g. DICT_4X4_50, DICT_5X5_100, DICT_6X6_250)");
  const int markers = size.width * size.height / 2;
  const int available = cv::aruco::getPredefinedDictionary(id)->bytesList.rows;
  if (markers > available)
    return Status::error("a " + size_text(size) + " ChArUco board needs " + std::to_string(markers) + " markers; " +
                         dictionary + " has " + std::to_string(available));
  return {};
}

std::string BoardSpec::describe() const {
  std::ostringstream out;
  if (kind == Kind::kChessboard)
    out << "chessboard " << size_text(size) << " inner corners, square " << square << " m";
  else
    out << "ChArUco " << size_text(size) << " squares, square " << square << " m, marker " << marker << " m, "
        << dictionary;
  return out.str();
}

std::vector<cv::Point3f> BoardSpec::corners() const {
  if (kind == Kind::kCharuco) return charuco_board(*this)->chessboardCorners;
  std::vector<cv::Point3f> out;
  for (int j = 0; j < size.height; ++j)
    for (int k = 0; k < size.width; ++k)
      out.emplace_back(static_cast<float>(k * square), static_cast<float>(j * square), 0.0f);
  return out;
}

bool parse_board_size(const std::string& text, cv::Size& out) {
  const auto x = text.find_first_of("xX");
  if (x == std::string::npos || x == 0 || x + 1 >= text.size()) return false;
  auto digits = [](const std::string& s) {
    return !s.empty() && s.size() < 6 &&
           std::all_of(s.begin(), s.end(), [](char ch) { return ch >= '0' && ch <= '9'; });
  };
  const std::string w = text.substr(0, x), h = text.substr(x + 1);
  if (!digits(w) || !digits(h)) return false;
  out = cv::Size(std::stoi(w), std::stoi(h));
  return out.width > 0 && out.height > 0;
}

std::vector<std::string> charuco_dictionaries() { return dictionary_names(); }

cv::Mat draw_charuco_board(const BoardSpec& board, int pixels_per_square) {
  cv::Mat image;
  const cv::Size size((board.size.width + 1) * pixels_per_square, (board.size.height + 1) * pixels_per_square);
  charuco_board(board)->draw(size, image, pixels_per_square / 2, 1);
  return image;
}

BoardView find_board(const cv::Mat& image, const BoardSpec& board) {
  BoardView view;
  const cv::Mat gray = gray_of(image);
  if (gray.empty()) return view;
  if (board.kind == BoardSpec::Kind::kCharuco) {
    auto charuco = charuco_board(board);
    std::vector<std::vector<cv::Point2f>> markers;
    std::vector<int> marker_ids;
    cv::aruco::detectMarkers(gray, charuco->dictionary, markers, marker_ids);
    if (marker_ids.empty()) return view;
    cv::aruco::interpolateCornersCharuco(markers, marker_ids, gray, charuco, view.points, view.ids);
    if (view.points.size() < 6) view = {};
    return view;
  }
  // stereo_calib: the board at scale 1, then in the image enlarged twice.
  for (int scale = 1; scale <= 2; ++scale) {
    cv::Mat scaled = gray;
    if (scale > 1) cv::resize(gray, scaled, cv::Size(), scale, scale, cv::INTER_LINEAR_EXACT);
    if (cv::findChessboardCorners(scaled, board.size, view.points,
                                  cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      for (auto& p : view.points) p *= 1.0f / static_cast<float>(scale);
      cv::cornerSubPix(gray, view.points, cv::Size(11, 11), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
      return view;
    }
  }
  view.points.clear();
  return view;
}

int CalibrationOptions::sample_stereo_flags() {
  return cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_USE_INTRINSIC_GUESS |
         cv::CALIB_SAME_FOCAL_LENGTH | cv::CALIB_RATIONAL_MODEL | cv::CALIB_FIX_K3 | cv::CALIB_FIX_K4 |
         cv::CALIB_FIX_K5;
}

double epipolar_error(const HeadCalibration& c, const std::vector<std::vector<cv::Point2f>>& left,
                      const std::vector<std::vector<cv::Point2f>>& right) {
  // F of the undistorted pixel coordinates: K2^-T [T]x R K1^-1.
  const cv::Vec3d& t = c.translation;
  const cv::Matx33d tx(0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0);
  const cv::Matx33d f = c.right_matrix.inv().t() * tx * c.rotation * c.left_matrix.inv();
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < left.size() && i < right.size(); ++i) {
    if (left[i].empty() || left[i].size() != right[i].size()) continue;
    std::vector<cv::Point2f> lu, ru;
    std::vector<cv::Vec3f> lines_in_right, lines_in_left;
    cv::undistortPoints(left[i], lu, c.left_matrix, c.left_distortion, cv::noArray(), c.left_matrix);
    cv::undistortPoints(right[i], ru, c.right_matrix, c.right_distortion, cv::noArray(), c.right_matrix);
    cv::computeCorrespondEpilines(lu, 1, f, lines_in_right);
    cv::computeCorrespondEpilines(ru, 2, f, lines_in_left);
    for (std::size_t j = 0; j < lu.size(); ++j) {
      const cv::Vec3f& a = lines_in_right[j];
      const cv::Vec3f& b = lines_in_left[j];
      sum += std::abs(ru[j].x * a[0] + ru[j].y * a[1] + a[2]) + std::abs(lu[j].x * b[0] + lu[j].y * b[1] + b[2]);
    }
    count += lu.size();
  }
  return count ? sum / static_cast<double>(count) : 0.0;
}

namespace {

// What the pairs gave calibrate_head: the corners seen in both images of each
// usable pair, and the problems that stop it before any solving.
struct Observations {
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> left_points, right_points;
  std::vector<std::size_t> used_reports;  // each usable pair's index in CalibrationResult::pairs
  std::vector<std::string> errors;        // unreadable images, sizes that disagree
  cv::Size size;                          // the first readable pair's, which every other must have
  std::string size_from;
};

cv::Mat load_gray(const cv::Mat& given, const std::string& file, std::vector<std::string>& errors) {
  cv::Mat image;
  std::error_code ec;
  if (!given.empty())
    image = gray_of(given);
  else if (std::filesystem::is_regular_file(file, ec))
    image = cv::imread(file, cv::IMREAD_GRAYSCALE);
  if (image.empty()) errors.push_back("cannot read image '" + file + "'");
  return image;
}

// Ok when a pair's images can be used, else why not (the pair's problem).
// Unlike a board not found, a size that disagrees is also an error of the
// whole calibration (in obs.errors): the pairs are not of one camera set-up.
Status image_problem(const ImagePair& pair, const cv::Mat& left, const cv::Mat& right, Observations& obs) {
  if (left.empty() || right.empty())
    return Status::error("cannot read " + std::string(left.empty() ? pair.left : pair.right));
  if (left.size() != right.size()) {
    obs.errors.push_back("pair '" + pair.left + "' (" + size_text(left.size()) + ") and '" + pair.right + "' (" +
                         size_text(right.size()) + "): the two images differ in size");
    return Status::error("the images differ in size");
  }
  if (obs.size.empty()) {
    obs.size = left.size();
    obs.size_from = pair.left;
  } else if (left.size() != obs.size) {
    obs.errors.push_back("'" + pair.left + "' is " + size_text(left.size()) + " but '" + obs.size_from + "' is " +
                         size_text(obs.size) + ": every image must have one size");
    return Status::error("another image size");
  }
  return {};
}

// The board corners seen in both images: every corner of a chessboard, the
// ChArUco corners whose id both images found (each sees a different subset).
void common_corners(const BoardView& lv, const BoardView& rv, bool charuco,
                    const std::vector<cv::Point3f>& board_corners, std::vector<cv::Point3f>& obj,
                    std::vector<cv::Point2f>& lp, std::vector<cv::Point2f>& rp) {
  if (!charuco) {
    obj = board_corners;
    lp = lv.points;
    rp = rv.points;
    return;
  }
  std::map<int, cv::Point2f> right_by_id;
  for (std::size_t i = 0; i < rv.ids.size(); ++i) right_by_id[rv.ids[i]] = rv.points[i];
  for (std::size_t i = 0; i < lv.ids.size(); ++i) {
    auto it = right_by_id.find(lv.ids[i]);
    if (it == right_by_id.end()) continue;
    obj.push_back(board_corners[static_cast<std::size_t>(lv.ids[i])]);
    lp.push_back(lv.points[i]);
    rp.push_back(it->second);
  }
}

// One pair's report, and its corners in `obs` when it is usable.
void observe_pair(const ImagePair& pair, const BoardSpec& board, const std::vector<cv::Point3f>& board_corners,
                  Observations& obs, CalibrationResult& result) {
  PairReport report;
  report.left = pair.left;
  report.right = pair.right;
  const cv::Mat left = load_gray(pair.left_image, pair.left, obs.errors);
  const cv::Mat right = load_gray(pair.right_image, pair.right, obs.errors);
  if (Status usable = image_problem(pair, left, right, obs); !usable.ok()) {
    report.problem = usable.message();
    result.pairs.push_back(report);
    return;
  }
  BoardView lv = find_board(left, board), rv = find_board(right, board);
  report.left_found = lv.found();
  report.right_found = rv.found();
  std::vector<cv::Point3f> obj;
  std::vector<cv::Point2f> lp, rp;
  if (report.left_found && report.right_found)
    common_corners(lv, rv, board.kind == BoardSpec::Kind::kCharuco, board_corners, obj, lp, rp);
  report.corners = static_cast<int>(obj.size());
  if (!report.left_found || !report.right_found)
    report.problem = !report.left_found && !report.right_found ? "no board in either image"
                     : !report.left_found                      ? "no board in the left image"
                                                               : "no board in the right image";
  else if (obj.size() < 6)
    report.problem = "only " + std::to_string(obj.size()) + " corners seen in both images";
  if (report.problem.empty()) {
    report.used = true;
    obs.used_reports.push_back(result.pairs.size());
    obs.object.push_back(std::move(obj));
    obs.left_points.push_back(std::move(lp));
    obs.right_points.push_back(std::move(rp));
  }
  result.pairs.push_back(report);
}

// The camera matrices (and with per_camera_first, distortions) the stereo step
// refines when its flags include CALIB_USE_INTRINSIC_GUESS, as the sample's do.
void initial_intrinsics(const Observations& obs, const CalibrationOptions& options, int flags, cv::Mat& k1, cv::Mat& d1,
                        cv::Mat& k2, cv::Mat& d2, CalibrationResult& result) {
  if (options.per_camera_first) {
    // Each camera alone with the distortion model of the stereo step.
    const int mono = flags & (cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_RATIONAL_MODEL |
                              cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_FIX_K4 |
                              cv::CALIB_FIX_K5 | cv::CALIB_FIX_K6 | cv::CALIB_FIX_PRINCIPAL_POINT);
    k1 = cv::Mat::eye(3, 3, CV_64F);
    k2 = cv::Mat::eye(3, 3, CV_64F);
    std::vector<cv::Mat> rv, tv;
    result.left_rms = cv::calibrateCamera(obs.object, obs.left_points, obs.size, k1, d1, rv, tv, mono);
    result.right_rms = cv::calibrateCamera(obs.object, obs.right_points, obs.size, k2, d2, rv, tv, mono);
  } else {
    k1 = cv::initCameraMatrix2D(obs.object, obs.left_points, obs.size, 0);
    k2 = cv::initCameraMatrix2D(obs.object, obs.right_points, obs.size, 0);
  }
}

// Both cameras together from the usable pairs, into result.calibration, with
// each used pair's own error; result.status an error when OpenCV fails or diverges.
void solve_stereo(const Observations& obs, const CalibrationOptions& options, CalibrationResult& result) {
  const int flags = options.stereo_flags >= 0 ? options.stereo_flags : CalibrationOptions::sample_stereo_flags();
  HeadCalibration& c = result.calibration;
  c.image_size = obs.size;
  c.board = options.board.describe();
  try {
    cv::Mat k1, d1, k2, d2;
    initial_intrinsics(obs, options, flags, k1, d1, k2, d2, result);
    cv::Mat r, t, e, f, per_view;
    c.rms = cv::stereoCalibrate(obs.object, obs.left_points, obs.right_points, k1, d1, k2, d2, obs.size, r, t, e, f,
                                per_view, flags,
                                cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-5));
    if (!std::isfinite(c.rms) || !finite(k1) || !finite(k2) || !finite(d1) || !finite(d2) || !finite(r) || !finite(t)) {
      result.status = Status::error("the stereo calibration did not converge (RMS " + number_text(c.rms) + ")");
      return;
    }
    c.left_matrix = cv::Matx33d(k1);
    c.right_matrix = cv::Matx33d(k2);
    d1 = d1.reshape(1, 1);
    d2 = d2.reshape(1, 1);
    c.left_distortion.assign(d1.begin<double>(), d1.end<double>());
    c.right_distortion.assign(d2.begin<double>(), d2.end<double>());
    c.rotation = cv::Matx33d(r);
    c.translation = cv::Vec3d(t.reshape(1, 3));
    for (std::size_t i = 0; i < obs.used_reports.size(); ++i) {
      const double a = per_view.at<double>(static_cast<int>(i), 0), b = per_view.at<double>(static_cast<int>(i), 1);
      PairReport& report = result.pairs[obs.used_reports[i]];
      report.rms = std::sqrt((a * a + b * b) / 2);
      c.pairs.push_back({report.left, report.right, report.rms});
    }
    c.epipolar_error = epipolar_error(c, obs.left_points, obs.right_points);
  } catch (const cv::Exception& e) { result.status = Status::error("calibration failed: " + e.err); }
}

}  // namespace

CalibrationResult calibrate_head(const std::vector<ImagePair>& pairs, const CalibrationOptions& options) {
  CalibrationResult result;
  const BoardSpec& board = options.board;
  if (Status valid = board.check(); !valid.ok()) {
    result.status = valid;
    return result;
  }
  const std::vector<cv::Point3f> board_corners = board.corners();
  Observations obs;
  for (const ImagePair& pair : pairs) observe_pair(pair, board, board_corners, obs, result);
  if (!obs.errors.empty()) {
    std::string lines;
    for (std::size_t i = 0; i < obs.errors.size(); ++i) lines += (i ? "\n" : "") + obs.errors[i];
    result.status = Status::error(lines);
    return result;
  }
  result.used_pairs = static_cast<int>(obs.object.size());
  if (result.used_pairs < std::max(options.min_pairs, 1)) {
    result.status = Status::error("the board (" + board.describe() + ") was found in both images of " +
                                  std::to_string(result.used_pairs) + " of " + std::to_string(pairs.size()) +
                                  " pairs; at least " + std::to_string(std::max(options.min_pairs, 1)) + " are needed");
    return result;
  }
  solve_stereo(obs, options, result);
  return result;
}

Result<std::vector<ImagePair>> read_image_list(const std::string& path) {
  cv::FileStorage fs;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return Status::error("cannot open image list '" + path + "'");
  try {
    if (!fs.open(path, cv::FileStorage::READ)) return Status::error("cannot open image list '" + path + "'");
  } catch (const cv::Exception& e) { return Status::error("image list '" + path + "' cannot be parsed: " + e.err); }
  cv::FileNode list = fs.getFirstTopLevelNode();
  if (list.type() != cv::FileNode::SEQ)
    return Status::error("image list '" + path +
                         "': expected a sequence of image names (as OpenCV's stereo_calib.xml)");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::vector<std::string> names;
  for (const cv::FileNode& item : list) {
    if (!item.isString())
      return Status::error("image list '" + path + "': item " + std::to_string(names.size() + 1) + " is not a name");
    std::filesystem::path name = static_cast<std::string>(item);
    names.push_back(name.is_relative() && !folder.empty() ? (folder / name).string() : name.string());
  }
  if (names.empty()) return Status::error("image list '" + path + "' is empty");
  if (names.size() % 2 != 0)
    return Status::error("image list '" + path + "' has " + std::to_string(names.size()) +
                         " names; expected left, right, left, right ... (an even number)");
  std::vector<ImagePair> pairs;
  for (std::size_t i = 0; i < names.size(); i += 2) pairs.push_back({names[i], names[i + 1], {}, {}});
  return pairs;
}

}  // namespace saccade::kinematics
