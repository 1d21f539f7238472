#pragma once
// Stereo calibration of the head's two cameras at the joints' zero, and the
// one file that holds it: each camera's intrinsics and distortion and the
// right camera's pose relative to the left, written with cv::FileStorage under
// the key names of OpenCV's stereo_calib sample (M1 D1 M2 D2 R T R1 R2 P1 P2
// Q) plus the image size, the RMS and the board. Plain code: `saccade
// calibrate` and the plugins call it, tests call it directly.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/status.hpp"

namespace saccade::kinematics {

// A calibrated stereo head at its joints' zero: each camera's intrinsics and
// distortion, and the right camera's pose relative to the left
// (x_right = rotation * x_left + translation, OpenCV's stereoCalibrate convention).
struct HeadCalibration {
  cv::Size image_size;
  cv::Matx33d left_matrix = cv::Matx33d::eye(), right_matrix = cv::Matx33d::eye();
  std::vector<double> left_distortion, right_distortion;  // OpenCV order: k1 k2 p1 p2 [k3 [k4 k5 k6 ...]]
  cv::Matx33d rotation = cv::Matx33d::eye();
  cv::Vec3d translation;  // metres (the board's square size sets the unit)
  double rms = 0;         // the calibration's RMS reprojection error, pixels (0: unknown)
  std::string path;       // where it was read from, for messages
  double baseline() const { return cv::norm(translation); }

  // Written to the file for the record; optional when reading.
  double epipolar_error = 0;  // stereo_calib's epipolar error, pixels (0: unknown); see epipolar_error()
  std::string board;          // the board, as BoardSpec::describe() gives it
  struct PairError {
    std::string left, right;  // the image files
    double rms = 0;           // RMS reprojection error over both images, pixels
  };
  std::vector<PairError> pairs;  // the pairs the calibration used
};

// The calibration, or an error naming the file and the missing/bad key.
Result<HeadCalibration> read_head_calibration(const std::string& path);
// YAML by default, XML when the name ends in .xml (.gz compresses either). An
// error names the file and why it could not be written.
Status write_head_calibration(const std::string& path, const HeadCalibration& calibration);
// Ok when the calibration is for frames of this size, else an error naming
// the file, its image size and the frame's size.
Status check_frame_size(const HeadCalibration& calibration, cv::Size frame);

// The calibration target.
struct BoardSpec {
  enum class Kind { kChessboard, kCharuco };
  Kind kind = Kind::kChessboard;
  // Chessboard: inner corners per row and column (OpenCV's pattern size, e.g.
  // 9x6). ChArUco: squares per row and column (its inner corners are one fewer).
  cv::Size size{9, 6};
  double square = 0;                       // side of a square, metres
  double marker = 0;                       // ChArUco: side of a marker, metres (< square)
  std::string dictionary = "DICT_4X4_50";  // ChArUco: cv::aruco's predefined dictionary
  // Ok, or an error saying what is wrong with the description.
  Status check() const;
  // e.g. "chessboard 9x6 inner corners, square 0.025 m".
  std::string describe() const;
  // The board's corner positions (z = 0), metres, in detection order /
  // indexed by ChArUco corner id.
  std::vector<cv::Point3f> corners() const;
};

// Parses "WxH" (e.g. "9x6"); false when it is not two positive integers.
bool parse_board_size(const std::string& text, cv::Size& out);

// The names of cv::aruco's predefined dictionaries (DICT_4X4_50 ...).
std::vector<std::string> charuco_dictionaries();

// An image of a ChArUco board, `pixels_per_square` per square with a margin
// of half a square, for printing and for tests.
cv::Mat draw_charuco_board(const BoardSpec& board, int pixels_per_square);

// The board's corners found in one image: image points and, for ChArUco, the
// ids of the corners (a chessboard gives all corners in order, ids empty).
struct BoardView {
  std::vector<cv::Point2f> points;
  std::vector<int> ids;
  bool found() const { return !points.empty(); }
};
// Finds the board in an 8-bit gray image. Chessboard: as OpenCV's
// stereo_calib sample (findChessboardCorners at scale 1, then 2, with adaptive
// threshold and normalisation; cornerSubPix 11x11). ChArUco: markers, then
// interpolated corners; a view with fewer than 6 corners is not found.
BoardView find_board(const cv::Mat& gray, const BoardSpec& board);

// One stereo pair: file names, and the images when the caller has them
// already (empty: read from the files).
struct ImagePair {
  std::string left, right;
  cv::Mat left_image, right_image;
};

struct CalibrationOptions {
  BoardSpec board;
  int min_pairs = 3;  // usable pairs required
  // Calibrate each camera alone (cv::calibrateCamera) and start the stereo
  // calibration from that; false: start from cv::initCameraMatrix2D, as the
  // stereo_calib sample does.
  bool per_camera_first = true;
  // cv::stereoCalibrate's flags; the default is the stereo_calib sample's.
  int stereo_flags = -1;
  static int sample_stereo_flags();
};

// What happened to one pair.
struct PairReport {
  std::string left, right;
  bool left_found = false, right_found = false;
  int corners = 0;      // corners used (seen in both images)
  bool used = false;    // in the calibration
  double rms = 0;       // its RMS reprojection error over both images, pixels (used pairs)
  std::string problem;  // why it was skipped, or an error (unreadable, size)
};

struct CalibrationResult {
  Status status;  // ok when `calibration` is valid, else the errors, one line each
  HeadCalibration calibration;
  std::vector<PairReport> pairs;
  int used_pairs = 0;
  double left_rms = 0, right_rms = 0;  // each camera alone (per_camera_first)
};

// Finds the board in every pair and calibrates the head. Errors (in `status`,
// one line each, naming the file and value): an unreadable image, a pair of
// two sizes or of another size than the first pair, fewer than min_pairs
// pairs with the board in both images (their count is given), a bad board.
// Pairs without the board are reported in `pairs` and skipped.
CalibrationResult calibrate_head(const std::vector<ImagePair>& pairs, const CalibrationOptions& options);

// stereo_calib's quality check: for each pair of matching corners, both
// undistorted, the distance of the left corner to the epipolar line of the
// right one plus that of the right corner to the line of the left one,
// pixels, averaged over the pairs of corners.
double epipolar_error(const HeadCalibration& calibration, const std::vector<std::vector<cv::Point2f>>& left,
                      const std::vector<std::vector<cv::Point2f>>& right);

// Reads an OpenCV image-list file (a sequence of names, as stereo_calib.xml)
// of left, right, left, right ... names; relative names are taken from the
// list's folder. The pairs in the list's order, or an error saying what is
// wrong with the list.
Result<std::vector<ImagePair>> read_image_list(const std::string& path);

}  // namespace saccade::kinematics
