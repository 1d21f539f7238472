// The ROS 2 forms of saccade's images and joint states (idl/ros2.idl): an edge
// published this way is a topic ROS 2 tools read without a bridge, and a
// dds.subscribe in this form reads a ROS 2 camera driver or joint publisher.
#include "ros2.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <opencv2/imgproc.hpp>

#include "ros2PubSubTypes.h"

namespace saccade::dds {

namespace ros = sensor_msgs::msg::dds_;

namespace {

// ROS 2 messages have no end of stream: saccade's is a message with this
// frame_id and nothing else (ROS 2 tools see one empty message at the end).
constexpr std::string_view kEndOfStreamFrame = "saccade/end_of_stream";
constexpr int64_t kNsPerSecond = 1'000'000'000;

void stamp_to_ros2(int64_t timestamp_ns, const std::string& frame_id, std_msgs::msg::dds_::Header_& out) {
  // ROS 2 time is seconds (int32) and nanoseconds [0, 1e9): floor division keeps a negative stamp valid.
  int64_t sec = timestamp_ns / kNsPerSecond, nsec = timestamp_ns % kNsPerSecond;
  if (nsec < 0) {
    nsec += kNsPerSecond;
    --sec;
  }
  out.stamp().sec(static_cast<int32_t>(sec));
  out.stamp().nanosec(static_cast<uint32_t>(nsec));
  out.frame_id(frame_id);
}

int64_t stamp_from_ros2(const std_msgs::msg::dds_::Header_& in) {
  return static_cast<int64_t>(in.stamp().sec()) * kNsPerSecond + static_cast<int64_t>(in.stamp().nanosec());
}

struct NamedEncoding {
  std::string_view name;
  int cv_type;
  bool rgb;  // channels in RGB(A) order: swapped to saccade's BGR(A)
};
constexpr std::array kNamedEncodings = {
    NamedEncoding{"mono8", CV_8UC1, false},  NamedEncoding{"bgr8", CV_8UC3, false},
    NamedEncoding{"bgra8", CV_8UC4, false},  NamedEncoding{"mono16", CV_16UC1, false},
    NamedEncoding{"bgr16", CV_16UC3, false}, NamedEncoding{"bgra16", CV_16UC4, false},
    NamedEncoding{"rgb8", CV_8UC3, true},    NamedEncoding{"rgba8", CV_8UC4, true},
    NamedEncoding{"rgb16", CV_16UC3, true},  NamedEncoding{"rgba16", CV_16UC4, true},
};
constexpr std::array<std::string_view, 7> kDepthNames = {"8U", "8S", "16U", "16S", "32S", "32F", "64F"};

// "32FC1" and friends (image_encodings' TYPE_* names). -1 when it is not one.
int generic_encoding(std::string_view e) {
  for (int depth = 0; depth < static_cast<int>(kDepthNames.size()); ++depth) {
    std::string_view d = kDepthNames[static_cast<std::size_t>(depth)];
    if (e.size() == d.size() + 2 && e.substr(0, d.size()) == d && e[d.size()] == 'C' && e.back() >= '1' &&
        e.back() <= '4')
      return CV_MAKETYPE(depth, e.back() - '0');
  }
  return -1;
}

void swap_bytes(cv::Mat& m) {
  const std::size_t width = m.elemSize1();
  if (width == 1) return;
  for (int r = 0; r < m.rows; ++r) {
    uint8_t* p = m.ptr<uint8_t>(r);
    const std::size_t n = static_cast<std::size_t>(m.cols) * static_cast<std::size_t>(m.channels());
    for (std::size_t i = 0; i < n; ++i, p += width) std::reverse(p, p + width);
  }
}

int camera_of_frame(const std::string& frame_id) {
  constexpr std::string_view prefix = "camera_";
  int id = 0;
  if (frame_id.rfind(prefix, 0) != 0) return 0;
  const char* first = frame_id.data() + prefix.size();
  const char* last = frame_id.data() + frame_id.size();
  auto [end, ec] = std::from_chars(first, last, id);
  return ec == std::errc() && end == last ? id : 0;
}

// The ROS 2 form of message M: one wire message reused for every write and take.
template <class M, class W>
class Ros2Sample final : public WireSample {
 public:
  explicit Ros2Sample(WireOptions options) : options_(std::move(options)) {}

  Status write(eprosima::fastdds::dds::DataWriter& writer, const Message* message, bool& written) override {
    if (message != nullptr) {
      to_ros2(static_cast<const M&>(*message), options_, wire_);
    } else {
      wire_ = W();
      wire_.header().frame_id(std::string(kEndOfStreamFrame));
    }
    written = writer.write(&wire_);
    return {};
  }

  Taken take(eprosima::fastdds::dds::DataReader& reader, ProcessContext* ctx, int output, MessagePtr& slot) override {
    eprosima::fastdds::dds::SampleInfo info;
    if (reader.take_next_sample(&wire_, &info) != ReturnCode_t::RETCODE_OK) return Taken::kNothing;
    if (!info.valid_data) return Taken::kUnreadable;
    if (wire_.header().frame_id() == kEndOfStreamFrame) return Taken::kEnd;
    std::shared_ptr<M> m = fresh<M>(ctx, output, slot);
    if (Status s = read(*m); !s.ok()) {
      why_ = s.message();
      return Taken::kUnreadable;
    }
    // ROS 2 messages carry neither a frame count nor saccade's steady-clock
    // origin: frames are numbered as they arrive, latency counts from arrival.
    m->frame_id = next_frame_++;
    m->origin_ns = steady_now_ns();
    slot = std::move(m);
    return Taken::kMessage;
  }

 private:
  Status read(M& out) {
    if constexpr (std::is_same_v<M, Image>)
      return from_ros2(wire_, out);
    else
      return from_ros2(wire_, options_, out);
  }

  WireOptions options_;
  W wire_;
  int64_t next_frame_ = 0;
};

template <class M, class W, class P>
Codec ros2_codec() {
  return Codec{
      M::kTypeName, Codec::Form::kRos2, 0,
      +[]() -> std::unique_ptr<eprosima::fastdds::dds::TopicDataType> { return std::make_unique<P>(); },
      +[](const WireOptions& o) -> std::unique_ptr<WireSample> { return std::make_unique<Ros2Sample<M, W>>(o); }};
}

}  // namespace

const std::vector<Codec>& ros2_codecs() {
  static const std::vector<Codec> all = {
      ros2_codec<Image, ros::Image_, ros::Image_PubSubType>(),
      ros2_codec<JointState, ros::JointState_, ros::JointState_PubSubType>(),
  };
  return all;
}

const Codec* find_ros2_codec(std::string_view type) {
  for (const auto& c : ros2_codecs())
    if (c.type == type) return &c;
  return nullptr;
}

std::string ros2_topic(std::string_view ros_topic) {
  while (!ros_topic.empty() && ros_topic.front() == '/') ros_topic.remove_prefix(1);
  return "rt/" + std::string(ros_topic);
}

std::string ros2_encoding(int cv_type) {
  for (const auto& e : kNamedEncodings)
    if (e.cv_type == cv_type && !e.rgb) return std::string(e.name);
  return std::string(kDepthNames[static_cast<std::size_t>(CV_MAT_DEPTH(cv_type))]) + "C" +
         std::to_string(CV_MAT_CN(cv_type));
}

void to_ros2(const Image& in, const WireOptions& options, ros::Image_& out) {
  stamp_to_ros2(in.timestamp_ns, options.frame_id.empty() ? "camera_" + std::to_string(in.camera_id) : options.frame_id,
                out.header());
  const cv::Mat& m = in.mat;
  const std::size_t row_bytes = static_cast<std::size_t>(m.cols) * m.elemSize();
  out.height(static_cast<uint32_t>(m.rows));
  out.width(static_cast<uint32_t>(m.cols));
  out.encoding(ros2_encoding(m.type()));
  out.is_bigendian(0);
  out.step(static_cast<uint32_t>(row_bytes));
  out.data().resize(row_bytes * static_cast<std::size_t>(m.rows));
  for (int r = 0; r < m.rows; ++r)
    std::memcpy(out.data().data() + row_bytes * static_cast<std::size_t>(r), m.ptr(r), row_bytes);
}

Status from_ros2(const ros::Image_& in, Image& out) {
  const std::string& encoding = in.encoding();
  int cv_type = generic_encoding(encoding);
  bool rgb = false;
  for (const auto& e : kNamedEncodings)
    if (e.name == encoding) {
      cv_type = e.cv_type;
      rgb = e.rgb;
    }
  if (cv_type < 0)
    return Status::error("image encoding '" + encoding +
                         "' is not one saccade reads (mono8, bgr8, rgb8, mono16, 32FC1, ...)");
  const std::size_t rows = in.height(), cols = in.width(), step = in.step();
  const std::size_t row_bytes = cols * static_cast<std::size_t>(CV_ELEM_SIZE(cv_type));
  if (rows > (1u << 16) || cols > (1u << 16) || step < row_bytes || in.data().size() < step * rows)
    return Status::error("a " + std::to_string(cols) + "x" + std::to_string(rows) + " " + encoding +
                         " image with step " + std::to_string(step) + " needs " + std::to_string(step * rows) +
                         " bytes of data, it has " + std::to_string(in.data().size()));
  out.timestamp_ns = stamp_from_ros2(in.header());
  out.origin_ns = 0;
  out.frame_id = 0;
  out.camera_id = camera_of_frame(in.header().frame_id());
  if (rows == 0 || cols == 0) {  // no pixels (fuzz_channel found memcpy into the null data of such a Mat)
    out.mat.release();
    return {};
  }
  out.mat.create(static_cast<int>(rows), static_cast<int>(cols), cv_type);
  for (std::size_t r = 0; r < rows; ++r)
    std::memcpy(out.mat.ptr(static_cast<int>(r)), in.data().data() + r * step, row_bytes);
  if (in.is_bigendian() != 0) swap_bytes(out.mat);
  if (rgb) cv::cvtColor(out.mat, out.mat, out.mat.channels() == 3 ? cv::COLOR_RGB2BGR : cv::COLOR_RGBA2BGRA);
  return {};
}

void to_ros2(const JointState& in, const WireOptions& options, ros::JointState_& out) {
  stamp_to_ros2(in.timestamp_ns, options.frame_id, out.header());
  out.name().resize(in.position.size());
  for (std::size_t i = 0; i < in.position.size(); ++i)
    out.name()[i] = i < options.joint_names.size() ? options.joint_names[i] : "joint_" + std::to_string(i);
  out.position() = in.position;
  out.velocity() = in.velocity;
  out.effort().clear();
}

Status from_ros2(const ros::JointState_& in, const WireOptions& options, JointState& out) {
  const std::size_t n = in.position().size();
  if ((!in.name().empty() && in.name().size() != n) || (!in.velocity().empty() && in.velocity().size() != n))
    return Status::error("a joint state with " + std::to_string(in.name().size()) + " names, " + std::to_string(n) +
                         " positions and " + std::to_string(in.velocity().size()) + " velocities");
  out.timestamp_ns = stamp_from_ros2(in.header());
  out.origin_ns = 0;
  out.frame_id = 0;
  out.cycle = 0;
  out.detail.clear();
  const bool by_name = !options.joint_names.empty() && !in.name().empty();
  const std::size_t joints = by_name ? options.joint_names.size() : n;
  out.position.assign(joints, std::numeric_limits<double>::quiet_NaN());
  out.velocity.assign(joints, 0.0);
  out.health.assign(joints, JointState::Health::kReady);
  out.updated_ns.assign(joints, out.timestamp_ns);
  out.error_code.assign(joints, 0);
  for (std::size_t j = 0; j < joints; ++j) {
    std::size_t k = j;
    if (by_name) {
      auto it = std::find(in.name().begin(), in.name().end(), options.joint_names[j]);
      if (it == in.name().end()) {
        out.health[j] = JointState::Health::kSilent;
        if (out.detail.empty()) out.detail = "joint " + options.joint_names[j] + " is not in the message";
        continue;
      }
      k = static_cast<std::size_t>(it - in.name().begin());
    }
    out.position[j] = in.position()[k];
    if (!in.velocity().empty()) out.velocity[j] = in.velocity()[k];
  }
  return {};
}

}  // namespace saccade::dds
