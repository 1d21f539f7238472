#include "channel.hpp"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>

#include "ros2.hpp"
#include "saccade/cdr.hpp"
#include "saccade/schema.hpp"
#include "wire.hpp"

namespace saccade::dds {

namespace {

namespace ros = sensor_msgs::msg::dds_;

std::string ros2_image_schema() {
  return ros2_schema_with_header(R"(std_msgs/Header header
uint32 height
uint32 width
string encoding
uint8 is_bigendian
uint32 step
uint8[] data
)");
}

std::string ros2_joint_state_schema() {
  return ros2_schema_with_header(R"(std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
)");
}

template <class... M>
std::vector<ChannelEncoding> idl_encodings_of(TypeList<M...>) {
  return {ChannelEncoding{M::kTypeName, cdr::idl_type_name(M::kTypeName), "omgidl", cdr::idl(), "cdr"}...};
}

const std::vector<ChannelEncoding>& idl_encodings() {
  static const std::vector<ChannelEncoding> all = idl_encodings_of(MessageTypes{});
  return all;
}

const std::vector<ChannelEncoding>& ros2_encodings() {
  static const std::vector<ChannelEncoding> all = {
      {Image::kTypeName, "sensor_msgs/msg/Image", "ros2msg", ros2_image_schema(), "cdr"},
      {JointState::kTypeName, "sensor_msgs/msg/JointState", "ros2msg", ros2_joint_state_schema(), "cdr"},
  };
  return all;
}

// CDR with its encapsulation (little endian), into `out`.
template <class W>
void serialize(W& wire, std::vector<uint8_t>& out) {
  out.resize(W::getCdrSerializedSize(wire) + 4);
  eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(out.data()), out.size());
  eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
  cdr.serialize_encapsulation();
  wire.serialize(cdr);
  out.resize(cdr.getSerializedDataLength());
}

// `wire` from CDR with its encapsulation; Fast CDR's exception for bytes
// that do not decode becomes the error.
template <class W>
Status deserialize(const uint8_t* data, std::size_t size, W& wire) {
  try {
    eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(const_cast<uint8_t*>(data)), size);
    eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
    cdr.read_encapsulation();
    wire.deserialize(cdr);
    return {};
  } catch (const eprosima::fastcdr::exception::Exception& e) {
    return Status::error(std::string("does not decode as ") + typeid(W).name() + ": " + e.what());
  }
}

Status wrong_type(const Message& m, std::string_view expected) {
  return Status::error("a " + std::string(m.type_name()) + " on a channel of " + std::string(expected));
}

// saccade's own IDL form (saccade/cdr.hpp).
template <class M>
class IdlEncoder final : public MessageEncoder {
 public:
  Status encode(const Message& message, std::vector<uint8_t>& out) override {
    if (message.type_name() != M::kTypeName) return wrong_type(message, M::kTypeName);
    cdr::write(static_cast<const M&>(message), cdr::Envelope{}, out);
    return {};
  }
};

template <class M>
class IdlDecoder final : public MessageDecoder {
 public:
  Result<MessagePtr> decode(const uint8_t* data, std::size_t size) override {
    auto out = std::make_shared<M>();
    cdr::Envelope envelope;
    if (Status s = cdr::read(data, size, *out, envelope); !s.ok()) return s;
    return MessagePtr(std::move(out));
  }
};

// ROS 2's sensor_msgs forms.
template <class M, class R>
class Ros2Encoder final : public MessageEncoder {
 public:
  Status encode(const Message& message, std::vector<uint8_t>& out) override {
    if (message.type_name() != M::kTypeName) return wrong_type(message, M::kTypeName);
    to_ros2(static_cast<const M&>(message), options_, wire_);
    serialize(wire_, out);
    return {};
  }

 private:
  WireOptions options_;
  R wire_;
};

template <class M, class R>
class Ros2Decoder final : public MessageDecoder {
 public:
  Result<MessagePtr> decode(const uint8_t* data, std::size_t size) override {
    if (Status s = deserialize(data, size, wire_); !s.ok()) return s;
    auto out = std::make_shared<M>();
    Status read;
    if constexpr (std::is_same_v<M, Image>)
      read = from_ros2(wire_, *out);
    else
      read = from_ros2(wire_, options_, *out);
    if (!read.ok()) return read;
    return MessagePtr(std::move(out));
  }

 private:
  WireOptions options_;
  R wire_;
};

// Calls `f` with a null M* for saccade's type named `type`.
template <class F, class... M>
bool with_idl_type(std::string_view type, F&& f, TypeList<M...>) {
  auto one = [&](auto* m) {
    if (type != std::remove_pointer_t<decltype(m)>::kTypeName) return false;
    f(m);
    return true;
  };
  return (one(static_cast<M*>(nullptr)) || ...);
}

}  // namespace

std::string ros2_schema_with_header(std::string_view fields) {
  // ros2msg: the type, then each type it uses after a line of '=' and "MSG: name".
  return std::string(fields) + R"(================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
)";
}

MessageEncoder::~MessageEncoder() = default;
MessageDecoder::~MessageDecoder() = default;

const ChannelEncoding* channel_encoding(std::string_view type, bool ros2) {
  if (ros2)
    for (const auto& e : ros2_encodings())
      if (e.type == type) return &e;
  for (const auto& e : idl_encodings())
    if (e.type == type) return &e;
  return nullptr;
}

const ChannelEncoding* written_encoding(std::string_view type) {
  return channel_encoding(type, type == Image::kTypeName);
}

std::vector<std::string_view> channel_types() {
  std::vector<std::string_view> out;
  for (const auto& e : idl_encodings()) out.push_back(e.type);
  return out;
}

std::unique_ptr<MessageEncoder> make_encoder(const ChannelEncoding& encoding) {
  if (encoding.schema_encoding == "ros2msg") {
    if (encoding.type == Image::kTypeName) return std::make_unique<Ros2Encoder<Image, ros::Image_>>();
    if (encoding.type == JointState::kTypeName) return std::make_unique<Ros2Encoder<JointState, ros::JointState_>>();
    return nullptr;
  }
  std::unique_ptr<MessageEncoder> out;
  with_idl_type(
      encoding.type, [&](auto* m) { out = std::make_unique<IdlEncoder<std::remove_pointer_t<decltype(m)>>>(); },
      MessageTypes{});
  return out;
}

std::unique_ptr<MessageDecoder> make_decoder(const ChannelEncoding& encoding) {
  if (encoding.schema_encoding == "ros2msg") {
    if (encoding.type == Image::kTypeName) return std::make_unique<Ros2Decoder<Image, ros::Image_>>();
    if (encoding.type == JointState::kTypeName) return std::make_unique<Ros2Decoder<JointState, ros::JointState_>>();
    return nullptr;
  }
  std::unique_ptr<MessageDecoder> out;
  with_idl_type(
      encoding.type, [&](auto* m) { out = std::make_unique<IdlDecoder<std::remove_pointer_t<decltype(m)>>>(); },
      MessageTypes{});
  return out;
}

}  // namespace saccade::dds
