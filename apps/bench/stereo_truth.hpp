#pragma once
// What a stereo pair's ground truth says about the right camera's view, for
// the stereo benchmark and the accuracy tests to score matchers alike.
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

}  // namespace saccade::bench
