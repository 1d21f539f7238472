#pragma once
// Stereo pairs with ground truth read from files, as the public stereo
// benchmarks give them, so that the stereo benchmark scores any of them
// beside its own: Middlebury's folders (each year's layout) and any three
// files (KITTI's, a user's own). And the other way: a pair written in
// Middlebury's 2014 layout, for other tools to score.
#include <string>

#include <opencv2/core.hpp>

#include "saccade/status.hpp"

namespace saccade::bench {

// A rectified pair's files: the left and right images and the left image's
// ground-truth disparity. The truth's pixel value is `scale` times the
// disparity in pixels; 0 for a float truth (PFM) means its values are pixels.
struct StereoPairFiles {
  std::string name;  // what the benchmark's tables call it
  std::string left, right, truth;
  double scale = 0;
  std::string note;  // what was assumed in finding the files (an inferred scale), for the user to check; or empty
};

// "LEFT,RIGHT,TRUTH[,SCALE]" (the benchmark's --stereo-pair; file names
// without commas). An integer
// truth (8- or 16-bit PNG, PGM) needs its SCALE (KITTI: 256; Middlebury 2001
// Tsukuba 16, Venus 8; 2003 Teddy and Cones 4); a PFM's is 1 unless given.
// Named after the left image's folder and file ("image_2/000000_10").
Result<StereoPairFiles> parse_stereo_pair(const std::string& spec);

// A Middlebury scene's folder, "DIR" or "DIR:SCALE" (the benchmark's
// --middlebury), its files found by the layout of the year that made it:
// - 2014 and 2021: im0.png, im1.png, disp0.pfm (or disp0GT.pfm); scale 1;
// - 2005 and 2006: view1.png, view5.png, disp1.png; the scale is that of the
//   size the folder holds (full 1, half 2, third 3: the truth is the full
//   size's disparity), taken from the width unless given (1000 px or more
//   full, 600 or more half, else third), with a note saying so;
// - 2001 and 2003: im2 and im6 (.ppm or .png), disp2 (.pgm or .png); SCALE
//   must be given (Teddy and Cones 4; Venus, Sawtooth, Bull, Poster, Barn 8).
// Named after the folder. An error names the folder and the files looked for.
Result<StereoPairFiles> find_middlebury_pair(const std::string& spec);

// A pair read: both images 8-bit gray, the truth CV_32F in pixels with -1
// where unknown (a float truth's infinities and NaNs, an integer truth's 0s,
// negative values).
struct StereoPairImages {
  cv::Mat left, right, truth;
};

// Reads the three files. An error names the file at fault: one that cannot be
// read, an image of more than 8 bits, images of another size than the left
// one, a truth of more than one channel, an integer truth without a scale, a
// truth with no known pixel or with one as wide as the image (a wrong scale,
// a PFM of the other byte order).
Result<StereoPairImages> read_stereo_pair(const StereoPairFiles& files);

// Writes a pair in Middlebury's 2014 layout into `dir` (made if missing):
// im0.png, im1.png, disp0.pfm (unknown = infinity) and calib.txt with the
// width, height and ndisp (the multiple of 16 above the truth's largest
// disparity, as the benchmark gives OpenCV's matchers).
// find_middlebury_pair and read_stereo_pair read it back exactly.
Status write_middlebury_pair(const std::string& dir, const StereoPairImages& pair);

}  // namespace saccade::bench
