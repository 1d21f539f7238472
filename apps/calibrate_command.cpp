#include "calibrate_command.hpp"

#include <cstdio>
#include <iostream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "camera_calibration.hpp"

namespace saccade {
namespace {

using kinematics::BoardSpec;

std::string join(const std::vector<double>& values) {
  std::string out;
  for (double v : values) out += (out.empty() ? "" : " ") + cv::format("%.6g", v);
  return out;
}

// The board the options describe, or what is wrong with them.
Result<BoardSpec> board_of(const CalibrateArgs& args) {
  BoardSpec board;
  if (!kinematics::parse_board_size(args.board, board.size))
    return Status::error("--board: expected WxH (e.g. 9x6), got '" + args.board + "'");
  board.square = args.square;
  if (!args.charuco.empty()) {
    board.kind = BoardSpec::Kind::kCharuco;
    board.dictionary = args.charuco;
    board.marker = args.marker;
  } else if (args.marker != 0) {
    return Status::error("--marker is for ChArUco boards (give --charuco DICTIONARY too)");
  }
  if (Status s = board.check(); !s.ok()) return s;
  return board;
}

// Each pair; a used pair whose error is over twice the whole calibration's
// (and over half a pixel) is marked: a swapped pair, a board that moved
// between the two shots, a blurred image.
void print_pairs(const kinematics::CalibrationResult& result) {
  const double rms = result.calibration.rms;
  for (const auto& pair : result.pairs) {
    std::printf("  %s  %s: ", pair.left.c_str(), pair.right.c_str());
    if (!pair.used) {
      std::printf("skipped: %s\n", pair.problem.c_str());
      continue;
    }
    std::printf("board found in both (%d corners)", pair.corners);
    if (rms > 0) std::printf(", RMS %.3f px%s", pair.rms, pair.rms > 2 * rms && pair.rms > 0.5 ? "  <- high" : "");
    std::printf("\n");
  }
}

}  // namespace

CLI::App* add_calibrate_command(CLI::App& app, CalibrateArgs& args) {
  auto* cmd = app.add_subcommand(
      "calibrate", "stereo calibration of the head's cameras (at the joints' zero) from board image pairs");
  cmd->add_option("--list", args.lists,
                  "OpenCV image-list file (as stereo_calib.xml): left, right, left, right ...; names relative to it")
      ->expected(1);
  cmd->add_option("--left", args.left, "left images, in pair order (e.g. left*.jpg)");
  cmd->add_option("--right", args.right, "right images, in the same order");
  cmd->add_option("--board", args.board,
                  "board size WxH: a chessboard's inner corners (9x6), a ChArUco board's squares")
      ->required();
  cmd->add_option("--square", args.square, "side of a square, metres (sets the unit of the baseline)")->required();
  cmd->add_option("--charuco", args.charuco, "a ChArUco board with markers of this dictionary (e.g. DICT_4X4_50)");
  cmd->add_option("--marker", args.marker, "ChArUco: side of a marker, metres");
  cmd->add_option("--min-pairs", args.min_pairs, "pairs with the board in both images needed")
      ->check(CLI::Range(1, 100000));
  cmd->add_flag("--sample-start", args.sample_start,
                "start the stereo calibration from initCameraMatrix2D as OpenCV's stereo_calib does, not from each "
                "camera calibrated alone");
  cmd->add_option("-o,--out", args.out, "calibration file to write (YAML; XML when it ends in .xml)");
  cmd->add_option("--draw-board", args.draw_board, "ChArUco: write an image of the board to this file, to print");
  cmd->add_option("--pixels", args.draw_pixels, "--draw-board: pixels per square")->check(CLI::Range(20, 2000));
  return cmd;
}

int calibrate_command(const CalibrateArgs& args) {
  auto fail = [](const std::string& message) {
    std::cerr << "saccade calibrate: " << message << "\n";
    return 2;
  };
  const Result<BoardSpec> described = board_of(args);
  if (!described.ok()) return fail(described.error());
  const BoardSpec& board = *described;
  if (!args.draw_board.empty()) {
    if (board.kind != BoardSpec::Kind::kCharuco) return fail("--draw-board draws ChArUco boards (give --charuco)");
    bool written = false;
    try {
      written = cv::imwrite(args.draw_board, kinematics::draw_charuco_board(board, args.draw_pixels));
    } catch (const cv::Exception& e) { return fail("cannot write '" + args.draw_board + "': " + e.err); }
    if (!written) return fail("cannot write '" + args.draw_board + "'");
    std::printf("wrote %s: %s\n", args.draw_board.c_str(), board.describe().c_str());
    return 0;
  }
  if (args.out.empty()) return fail("give the calibration file to write with -o FILE");
  std::vector<kinematics::ImagePair> pairs;
  for (const auto& list : args.lists) {
    auto listed = kinematics::read_image_list(list);
    if (!listed.ok()) return fail(listed.error());
    pairs.insert(pairs.end(), listed->begin(), listed->end());
  }
  if (args.left.size() != args.right.size())
    return fail("--left has " + std::to_string(args.left.size()) + " images but --right has " +
                std::to_string(args.right.size()) + "; give them in pairs");
  for (std::size_t i = 0; i < args.left.size(); ++i) pairs.push_back({args.left[i], args.right[i], {}, {}});
  if (pairs.empty()) return fail("no image pairs: give --list FILE or --left ... --right ...");

  kinematics::CalibrationOptions options;
  options.board = board;
  options.min_pairs = args.min_pairs;
  options.per_camera_first = !args.sample_start;
  std::printf("%s, %zu pairs\n", board.describe().c_str(), pairs.size());
  const kinematics::CalibrationResult result = kinematics::calibrate_head(pairs, options);
  print_pairs(result);
  if (!result.status.ok()) {
    std::istringstream lines(result.status.message());
    for (std::string line; std::getline(lines, line);) std::cerr << "saccade calibrate: " << line << "\n";
    return 2;
  }
  const auto& c = result.calibration;
  std::printf("%d of %zu pairs used, images %dx%d\n", result.used_pairs, pairs.size(), c.image_size.width,
              c.image_size.height);
  if (options.per_camera_first)
    std::printf("each camera alone: RMS %.4f px (left), %.4f px (right)\n", result.left_rms, result.right_rms);
  std::printf("stereo calibration: RMS %.4f px, average epipolar error %.4f px\n", c.rms, c.epipolar_error);
  if (c.rms > 1.0)
    std::printf(
        "warning: an RMS over 1 px is poor: are the left and right images in the same order, and the board "
        "still during each pair?\n");
  std::printf("left:  fx %.2f fy %.2f cx %.2f cy %.2f  distortion %s\n", c.left_matrix(0, 0), c.left_matrix(1, 1),
              c.left_matrix(0, 2), c.left_matrix(1, 2), join(c.left_distortion).c_str());
  std::printf("right: fx %.2f fy %.2f cx %.2f cy %.2f  distortion %s\n", c.right_matrix(0, 0), c.right_matrix(1, 1),
              c.right_matrix(0, 2), c.right_matrix(1, 2), join(c.right_distortion).c_str());
  std::printf("right camera from the left: T = [%.5f %.5f %.5f] m, baseline %.5f m\n", c.translation[0],
              c.translation[1], c.translation[2], c.baseline());
  if (Status s = kinematics::write_head_calibration(args.out, c); !s.ok()) return fail(s.message());
  std::printf("wrote %s\n", args.out.c_str());
  return 0;
}

}  // namespace saccade
