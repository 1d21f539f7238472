#pragma once
// One message type as a log channel or a live view carries it (MCAP files,
// the Foxglove WebSocket protocol): its schema (name, encoding, text) and its
// messages as CDR bytes: ROS 2's sensor_msgs for images and joint states (so
// Foxglove, rosbag2 and PlotJuggler show them as they are), saccade's own IDL
// type (idl/saccade.idl, the schema text itself) for every type, the same
// bytes a DDS edge sends. sensor_msgs/JointState has no health, feedback
// times, error codes or cycle, so a log keeps joint states in the IDL form
// too (written_encoding): a replayed head needs them to hold where it held.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::dds {

struct ChannelEncoding {
  std::string_view type;         // saccade's type name (Message::type_name())
  std::string schema_name;       // "sensor_msgs/msg/Image", "saccade_idl::Retina"
  std::string schema_encoding;   // "ros2msg" or "omgidl"
  std::string schema;            // the schema's text
  std::string message_encoding;  // "cdr"
};

// The encoding of `type`: ROS 2's for Image and JointState when `ros2` (a
// joint state's joints are then named joint_0, joint_1, ...), else
// saccade's IDL type. nullptr for a type with no wire form.
const ChannelEncoding* channel_encoding(std::string_view type, bool ros2);

// The encoding a log keeps `type` in: ROS 2's for Image, saccade's IDL type
// for every other type (a log adds a ROS 2 channel for joint states: MCAP's
// recording.hpp). nullptr for a type with no wire form.
const ChannelEncoding* written_encoding(std::string_view type);

// The types that have an encoding.
std::vector<std::string_view> channel_types();

// A ROS 2 message definition (ros2msg) whose fields start with
// `std_msgs/Header header`: `fields`, then the Header's and Time's own
// definitions after their separators, as rosbag2 writes them.
std::string ros2_schema_with_header(std::string_view fields);

// Writes one type's messages as CDR (with its 4-byte encapsulation header,
// as MCAP's and Foxglove's "cdr" encoding wants); keeps its buffers, so a
// channel's steady stream allocates nothing.
class MessageEncoder {
 public:
  virtual ~MessageEncoder();
  // The message's bytes into `out` (resized, its capacity reused), or what is
  // wrong (a message of another type).
  virtual Status encode(const Message& message, std::vector<uint8_t>& out) = 0;
};
std::unique_ptr<MessageEncoder> make_encoder(const ChannelEncoding& encoding);

// Reads one type's messages back.
class MessageDecoder {
 public:
  virtual ~MessageDecoder();
  // A new message from `size` bytes, or why they do not decode (truncated,
  // another type).
  virtual Result<MessagePtr> decode(const uint8_t* data, std::size_t size) = 0;
};
std::unique_ptr<MessageDecoder> make_decoder(const ChannelEncoding& encoding);

}  // namespace saccade::dds
