#pragma once
// Pictures of retinas and feature maps, like the paper's figures.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/message.hpp"

namespace saccade::snapshot {

// Any 1- or 3-channel image as 8-bit BGR; float maps are stretched to 0..255
// (signed maps around mid-gray).
cv::Mat to_display(const cv::Mat& image);

// A disparity map (CV_32F, negative = invalid) colour-mapped: near red, far
// blue, invalid black. `max_disparity` <= 0 takes the map's own maximum.
cv::Mat disparity_color(const cv::Mat& disparity, double max_disparity = 0);

// A disparity map (CV_32F, negative or not finite = invalid) as 16-bit
// integers for outside evaluation: value = round(disparity x 64) + 1, 0 =
// invalid, so a valid 0 is 1 and disparities up to 1023.98 px fit (larger
// ones are clamped to 65535); read back as (value - 1) / 64, to 1/64 px.
constexpr double kDisparityPng16Scale = 64.0;
cv::Mat disparity_png16(const cv::Mat& disparity);
// Its inverse: CV_32F, -1 where the value is 0.
cv::Mat disparity_from_png16(const cv::Mat& png16);

// PFM (the stereo benchmarks' float format: "Pf", width height, -1 for
// little-endian floats, rows bottom to top), one channel, exact floats;
// invalid pixels (negative or not finite) written as +infinity, as the
// Middlebury benchmark marks unknown disparities. Returns false when the file
// cannot be written.
bool write_pfm(const std::string& path, const cv::Mat& disparity);
// Reads a one-channel PFM (either byte order) as CV_32F, empty on failure.
cv::Mat read_pfm(const std::string& path);

// The source frame with each level's region drawn (outermost blue to fovea red)
// and the fovea's centre marked.
cv::Mat retina_overlay(const Retina& retina);

// One step of a fovea track, as the snapshot remembers it.
struct TrackPoint {
  cv::Point2d fovea;
  cv::Point2d target;
  bool target_valid = false;
  FoveaState::State state = FoveaState::State::kSearching;
  bool gaze_request = false;
};

// The retina overlay plus the fovea's track: the path of the fovea (colour by
// state: green tracking, yellow searching, red lost), the target's path, gaze
// requests as circles, and the current state as text.
cv::Mat track_overlay(const FoveaState& state, const std::vector<TrackPoint>& track);

// Levels side by side, each enlarged `scale` times (nearest neighbour), labelled.
// Maps named disparity* are colour-mapped.
cv::Mat level_strip(const std::vector<cv::Mat>& levels, int scale, const std::string& title);

// The frame as the retina sees it: each level painted back over its region,
// outermost first, so resolution rises towards the fovea.
cv::Mat foveated_view(const Retina& retina);

// One strip per feature, stacked.
cv::Mat feature_grid(const FeatureMaps& maps, int scale);

}  // namespace saccade::snapshot
