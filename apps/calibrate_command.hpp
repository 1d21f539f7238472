#pragma once
// `saccade calibrate`: stereo calibration of the head's cameras from image
// pairs of a chessboard or ChArUco board, written to one calibration file.
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace saccade {

struct CalibrateArgs {
  std::vector<std::string> lists;        // OpenCV image-list files: left, right, left, right ...
  std::vector<std::string> left, right;  // or the images, in pair order
  std::string board;                     // WxH
  double square = 0;
  std::string charuco;  // dictionary name: a ChArUco board
  double marker = 0;
  int min_pairs = 3;
  bool sample_start = false;
  std::string out;
  std::string draw_board;  // write an image of the ChArUco board and stop
  int draw_pixels = 100;
};

CLI::App* add_calibrate_command(CLI::App& app, CalibrateArgs& args);
// 0 written, 2 bad input (each problem printed, naming the file and value).
int calibrate_command(const CalibrateArgs& args);

}  // namespace saccade
