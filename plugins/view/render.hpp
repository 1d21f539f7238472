#pragma once
// What the live view draws and sends besides each message's own encoding:
// images, retinas and feature maps as one picture (JPEG), wrapped as ROS 2's
// sensor_msgs/msg/CompressedImage in CDR.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/message.hpp"

namespace saccade::view {

// True for the types render_picture draws (Image, Retina, FeatureMaps).
bool has_picture(std::string_view type);

// The message as one 8-bit picture: an image as it is (other depths scaled
// to 0..255), a retina's levels side by side (outermost first, each enlarged
// to at least 96 rows), feature maps as one row per feature and one column
// per level, each scaled to its own range. Empty when there is nothing to
// draw. `out` keeps its buffer.
void render_picture(const Message& message, cv::Mat& out);

// sensor_msgs/msg/CompressedImage's ros2msg schema text.
const std::string& compressed_image_schema();

// A CompressedImage (header stamp from `timestamp_ns`, `frame_id`, format
// "jpeg") around `jpeg`, as CDR with its encapsulation header, into `out`.
void encode_compressed_image(int64_t timestamp_ns, std::string_view frame_id, const std::vector<uint8_t>& jpeg,
                             std::vector<uint8_t>& out);

}  // namespace saccade::view
