// ROS 2 interop without ROS 2 (not installable here): a plain Fast DDS
// participant that knows only ROS 2's message definitions (idl/ros2.idl) and
// none of saccade's code reads what saccade publishes as ROS 2 topics, and
// writes what a saccade subscriber reads, the way ROS 2 nodes would.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <thread>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "ros2PubSubTypes.h"
#include "support.hpp"

namespace saccade {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace ros = sensor_msgs::msg::dds_;

// A ROS 2-like node: one participant, one topic of ROS 2 type T.
template <class PubSubType>
class PlainRos2Node {
 public:
  explicit PlainRos2Node(const std::string& ros_topic) {
    participant_ = fdds::DomainParticipantFactory::get_instance()->create_participant(0, fdds::PARTICIPANT_QOS_DEFAULT);
    fdds::TypeSupport type(new PubSubType());
    type.register_type(participant_);
    // ROS 2 maps topic /a/b to DDS topic rt/a/b.
    topic_ = participant_->create_topic("rt/" + ros_topic, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  }
  ~PlainRos2Node() {
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  fdds::DataReader* reader() {
    fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    return participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT)->create_datareader(topic_, qos);
  }
  fdds::DataWriter* writer() {
    fdds::DataWriterQos qos = fdds::DATAWRITER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    return participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT)->create_datawriter(topic_, qos);
  }
  std::string type_name() const { return topic_->get_type_name(); }

 private:
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Topic* topic_ = nullptr;
};

// True once process `pid` has ended (a zombie not yet reaped by wait_child).
// The node `xml` describes, opened; nullptr, and a test failure saying why,
// when it cannot be.
std::unique_ptr<testing::NodeHarness> open_node(const std::string& xml) {
  Result<std::unique_ptr<testing::NodeHarness>> node = testing::NodeHarness::create(xml);
  EXPECT_TRUE(node.ok()) << node.error();
  return std::move(node).value_or(nullptr);
}

bool ended(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return true;
  auto paren = line.rfind(')');
  return paren == std::string::npos || paren + 2 >= line.size() || line[paren + 2] == 'Z';
}

// The next sample within `timeout_s`; gives up early when process `child` (if any) has ended.
template <class T>
bool take_within(fdds::DataReader* reader, T& sample, double timeout_s, pid_t child = -1) {
  auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  fdds::SampleInfo info;
  while (std::chrono::steady_clock::now() < give_up) {
    if (child > 0 && ended(child)) return reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK;
    if (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK && info.valid_data) return true;
    reader->wait_for_unread_message(eprosima::fastrtps::Duration_t(0, 100'000'000));
  }
  return false;
}

bool matched_within(fdds::DataWriter* writer, double timeout_s) {
  return test::wait_for(
      [&] {
        fdds::PublicationMatchedStatus status;
        writer->get_publication_matched_status(status);
        return status.current_count > 0;
      },
      timeout_s);
}

std::string unique_topic(const std::string& name) { return "test_ros2_" + std::to_string(getpid()) + "/" + name; }

// graphs/ros2_camera.xml, run by the saccade command in its own process.
TEST(Ros2Interop, APlainRos2ReaderSeesTheCameraGraphsFramesAsSensorMsgsImages) {
  const int frames = 6;
  const std::string topic = unique_topic("camera/image_raw");
  PlainRos2Node<ros::Image_PubSubType> ros_node(topic);
  EXPECT_EQ(ros_node.type_name(), "sensor_msgs::msg::dds_::Image_");
  fdds::DataReader* reader = ros_node.reader();
  ASSERT_NE(reader, nullptr);

  pid_t child = test::spawn_saccade({"--log-level", "warn", "run", SACCADE_SOURCE_DIR "/graphs/ros2_camera.xml",
                                     "--frames", std::to_string(frames), "--set", "image_raw.topic=/" + topic, "--set",
                                     "image_raw.reliable=true", "--set", "image_raw.depth=0", "--set",
                                     "image_raw.wait_ms=20000"});
  ASSERT_GT(child, 0);
  cv::VideoCapture video(test::sample_path("vtest.avi"));
  ASSERT_TRUE(video.isOpened());
  std::vector<cv::Mat> expected(frames);
  for (auto& f : expected) ASSERT_TRUE(video.read(f));
  // The camera's edge keeps the latest frame (a live camera's policy): a frame
  // may be dropped in the graph under load, never changed or reordered.
  int received = 0, last = -1;
  for (;;) {
    ros::Image_ msg;
    ASSERT_TRUE(take_within(reader, msg, 60, child)) << "nothing after frame " << last;
    if (msg.header().frame_id() == "saccade/end_of_stream") {
      EXPECT_TRUE(msg.data().empty()) << "the end of the stream: one empty image";
      break;
    }
    // Frame i's media time at vtest.avi's 10 fps.
    const int64_t stamp_ns = int64_t{msg.header().stamp().sec()} * 1'000'000'000 + msg.header().stamp().nanosec();
    const int i = static_cast<int>(std::lround(static_cast<double>(stamp_ns) / 1e8));
    ASSERT_GT(i, last);
    ASSERT_LT(i, frames);
    EXPECT_NEAR(static_cast<double>(stamp_ns), i * 1e8, 1e6);
    last = i;
    ++received;
    EXPECT_EQ(msg.header().frame_id(), "camera_optical_frame");
    EXPECT_EQ(msg.encoding(), "bgr8");
    ASSERT_EQ(msg.width(), static_cast<uint32_t>(expected[i].cols));
    ASSERT_EQ(msg.height(), static_cast<uint32_t>(expected[i].rows));
    EXPECT_EQ(msg.step(), msg.width() * 3);
    EXPECT_EQ(msg.is_bigendian(), 0);
    ASSERT_EQ(msg.data().size(), static_cast<std::size_t>(msg.step()) * msg.height());
    cv::Mat got(expected[i].rows, expected[i].cols, CV_8UC3, msg.data().data());
    EXPECT_EQ(cv::norm(got, expected[i], cv::NORM_INF), 0) << "frame " << i;
  }
  EXPECT_GE(received, frames / 2) << "paced at 10 fps, the graph has ample time for every frame";
  EXPECT_EQ(test::wait_child(child, 60), 0);
}

TEST(Ros2Interop, APlainRos2ReaderSeesJointStatesWithTheirNames) {
  const std::string topic = unique_topic("joint_states");
  PlainRos2Node<ros::JointState_PubSubType> ros_node(topic);
  fdds::DataReader* reader = ros_node.reader();
  auto publish = open_node("<node plugin=\"dds.publish\"><param name=\"topic\" value=\"" + topic +
                           "\"/><param name=\"type\" value=\"JointState\"/><param name=\"ros2\" value=\"true\"/>"
                           "<param name=\"reliable\" value=\"true\"/><param name=\"depth\" value=\"0\"/>"
                           "<param name=\"wait_ms\" value=\"20000\"/></node>");
  ASSERT_NE(publish, nullptr);
  auto state = std::make_shared<JointState>();
  state->timestamp_ns = 3'000'000'007;
  state->position = {0.1, 0.2, -0.3, 0.4, -0.5};
  state->velocity = {1, 2, 3, 4, 5};
  state->health.assign(5, JointState::Health::kReady);
  publish->set("in", state);
  ASSERT_TRUE(publish->process().ok());

  ros::JointState_ msg;
  ASSERT_TRUE(take_within(reader, msg, 30));
  EXPECT_EQ(msg.name(),
            (std::vector<std::string>{"neck", "vergence_left", "tilt_left", "vergence_right", "tilt_right"}))
      << "the head's joints, by default";
  EXPECT_EQ(msg.position(), state->position);
  EXPECT_EQ(msg.velocity(), state->velocity);
  EXPECT_EQ(msg.header().stamp().sec(), 3);
  EXPECT_EQ(msg.header().stamp().nanosec(), 7u);
}

TEST(Ros2Interop, ASaccadeSubscriberReadsWhatAPlainRos2WriterPublishes) {
  const std::string topic = unique_topic("usb_cam/image_raw");
  auto subscribe = open_node("<node plugin=\"dds.subscribe\"><param name=\"topic\" value=\"" + topic +
                             "\"/><param name=\"type\" value=\"Image\"/><param name=\"ros2\" value=\"true\"/>"
                             "<param name=\"reliable\" value=\"true\"/><param name=\"depth\" value=\"0\"/></node>");
  ASSERT_NE(subscribe, nullptr);
  PlainRos2Node<ros::Image_PubSubType> ros_node(topic);
  fdds::DataWriter* writer = ros_node.writer();
  ASSERT_TRUE(matched_within(writer, 30));

  // A ROS 2 camera driver's usual frame: rgb8, stamped, its own frame name.
  const cv::Mat bgr = cv::imread(test::sample_path("aloeL.jpg"), cv::IMREAD_COLOR);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  ros::Image_ msg;
  msg.header().stamp().sec(12);
  msg.header().stamp().nanosec(500);
  msg.header().frame_id("camera_2");
  msg.height(static_cast<uint32_t>(rgb.rows));
  msg.width(static_cast<uint32_t>(rgb.cols));
  msg.encoding("rgb8");
  msg.step(static_cast<uint32_t>(rgb.cols * 3));
  msg.data().assign(rgb.data, rgb.data + rgb.total() * 3);
  ASSERT_TRUE(writer->write(&msg));
  msg.encoding("yuv422");  // one saccade cannot read: counted, skipped
  ASSERT_TRUE(writer->write(&msg));
  msg.encoding("rgb8");
  msg.header().stamp().sec(13);
  ASSERT_TRUE(writer->write(&msg));

  for (int64_t sec : {12, 13}) {
    subscribe->clear_outputs();
    ASSERT_TRUE(subscribe->process().ok());
    auto image = subscribe->last<Image>("out");
    ASSERT_NE(image, nullptr);
    EXPECT_EQ(image->timestamp_ns, sec * 1'000'000'000 + 500);
    EXPECT_EQ(image->camera_id, 2);
    EXPECT_EQ(cv::norm(image->mat, bgr, cv::NORM_INF), 0) << "RGB arrives as saccade's BGR";
  }
}

}  // namespace
}  // namespace saccade
