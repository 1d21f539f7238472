#pragma once
// What a stereo pair's ground truth says about the right camera's view, for
// the stereo benchmark and the accuracy tests to score matchers alike.
#include <vector>

#include <opencv2/core.hpp>

namespace saccade::bench {

// The left pixels the right camera cannot see, from the left ground truth
// alone (CV_32F disparities in pixels, < 0 or NaN unknown): 255 where a
// nearer surface covers the place the pixel lands on in the right image, or
// that place is off the right image; 0 elsewhere (unknown pixels too).
//
// Each row is z-buffered along the right image's x: a left pixel covers its
// own footprint (half a pixel either side of x - d), and two neighbours on one
// surface (disparities within a pixel) cover the span between their right
// places too, so a slanted surface stretched in the right view leaves no gaps
// and a thin structure hides only what lies behind it. A pixel is hidden when
// what covers its place is nearer by more than a pixel (the truth's own
// rounding).
cv::Mat hidden_from_right_camera(const cv::Mat& truth);

// The disparity range OpenCV's matchers are given to cover a truth (CV_32F,
// < 0 unknown): the multiple of 16 above its largest disparity (their range
// is numDisparities values from 0, so a truth of 32 px needs 48).
int disparities_over(const cv::Mat& truth);

// A chessboard seen by a rectified pair, as truth: its inner corners
// (`corners` columns x rows, row by row, as OpenCV finds them) in the left and
// right rectified images, in OpenCV's pixel convention (pixel (x, y) centred on
// x, y). The disparity at a left point is the corners' disparities (left x -
// right x) interpolated across the board's square under it, extrapolated over
// the outer squares, so a board that is not quite flat is followed too.
class BoardDisparity {
 public:
  BoardDisparity(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right, cv::Size corners);
  double at(cv::Point2d left_point) const;
  // The left image point at board coordinates (u, v): corner column u, row v.
  cv::Point2d on_board(double u, double v) const;
  // Per left pixel of an image of `size`: at() over the board's squares (the
  // corners' grid extended by one square each way), -1 elsewhere (CV_32F).
  cv::Mat truth(cv::Size size) const;
  // The corners' |left y - right y|: how far rectification left them off one row.
  double row_error_max() const { return row_error_max_; }
  double row_error_mean() const { return row_error_mean_; }

 private:
  cv::Size corners_;
  std::vector<double> disparity_;  // per corner
  cv::Matx33d to_image_, to_board_;
  double row_error_max_ = 0, row_error_mean_ = 0;
};

}  // namespace saccade::bench
