// DDS Security end to end: scripts/make-security.sh makes a CA, the head and
// robot PCs' identities and the signed governance and permissions; two saccade
// processes with them exchange images and joint targets, while a participant
// without security, and one whose certificate comes from another CA, can
// neither read the images nor publish joint targets the robot accepts.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <set>
#include <thread>

#include <fastdds/dds/log/Log.hpp>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>

#include "saccadePubSubTypes.h"
#include "support.hpp"

namespace saccade {
namespace {

namespace fs = std::filesystem;
namespace fdds = eprosima::fastdds::dds;

// A plain Fast DDS participant, secured with `identity` (a folder made by the
// script) or not at all, with one topic of each type the test uses.
class Participant {
 public:
  Participant(const std::string& identity, const std::string& prefix, int domain) {
    fdds::DomainParticipantQos qos;
    if (!identity.empty()) {
      auto& p = qos.properties().properties();
      const std::string dir = "file://" + fs::absolute(identity).string() + "/";
      p.emplace_back("dds.sec.auth.plugin", "builtin.PKI-DH");
      p.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_ca", dir + "ca.pem");
      p.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_certificate", dir + "cert.pem");
      p.emplace_back("dds.sec.auth.builtin.PKI-DH.private_key", dir + "key.pem");
      p.emplace_back("dds.sec.access.plugin", "builtin.Access-Permissions");
      p.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions_ca", dir + "ca.pem");
      p.emplace_back("dds.sec.access.builtin.Access-Permissions.governance", dir + "governance.p7s");
      p.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions", dir + "permissions.p7s");
      p.emplace_back("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
    }
    participant_ =
        fdds::DomainParticipantFactory::get_instance()->create_participant(static_cast<fdds::DomainId_t>(domain), qos);
    if (participant_ == nullptr) return;
    fdds::TypeSupport image(new saccade_idl::ImagePubSubType()), targets(new saccade_idl::JointTargetsPubSubType());
    image.register_type(participant_);
    targets.register_type(participant_);
    images_ = participant_->create_topic(prefix + "images", image.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    targets_ = participant_->create_topic(prefix + "targets", targets.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  }
  ~Participant() {
    if (participant_ == nullptr) return;
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  bool ok() const { return participant_ != nullptr && images_ != nullptr && targets_ != nullptr; }
  fdds::DataReader* image_reader() {
    fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    return participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT)->create_datareader(images_, qos);
  }
  fdds::DataWriter* target_writer() {
    fdds::DataWriterQos qos = fdds::DATAWRITER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    return participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT)->create_datawriter(targets_, qos);
  }

 private:
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Topic* images_ = nullptr;
  fdds::Topic* targets_ = nullptr;
};

// The shared-memory ports a process maps ("(deleted)": one whose file another
// process removed and made again, which its listener no longer hears), for a
// failure to show.
std::string mapped_ports(pid_t pid) {
  std::ifstream maps("/proc/" + std::to_string(pid) + "/maps");
  const std::string shm = "/dev/shm/";
  std::set<std::string> ports;
  for (std::string line; std::getline(maps, line);)
    if (auto at = line.find(shm + "fastrtps_port"); at != std::string::npos) ports.insert(line.substr(at + shm.size()));
  std::string out;
  for (const auto& port : ports) out += "  " + port + "\n";
  return out;
}

// Runs `f` when it goes out of scope.
class Finally {
 public:
  explicit Finally(std::function<void()> f) : f_(std::move(f)) {}
  ~Finally() { f_(); }
  Finally(const Finally&) = delete;
  Finally& operator=(const Finally&) = delete;

 private:
  std::function<void()> f_;
};

int make_security(const fs::path& dir, const std::string& names) {
  const std::string command = "bash " SACCADE_SOURCE_DIR "/scripts/make-security.sh " + dir.string() + " " + names +
                              " > " + (dir.string() + ".log") + " 2>&1";
  return std::system(command.c_str());
}

TEST(DdsSecurity, OnlyParticipantsWithTheRobotsCertificatesReadImagesOrPublishJointTargets) {
  const fs::path root = fs::temp_directory_path() / ("saccade_security_" + std::to_string(getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  ASSERT_EQ(make_security(root / "keys", "head_pc robot_pc"), 0) << "see " << root << "/keys.log";
  ASSERT_EQ(make_security(root / "foreign", "head_pc"), 0) << "another CA, a participant of the same name";
  const std::string prefix = "test_security_" + std::to_string(getpid()) + "/";
  // A domain of its own: a secured participant authenticates every
  // participant it discovers, and a handshake that other tests' participants
  // (or a loaded machine) delay past Fast DDS 2.9's fixed resends is given up
  // for good. (CTest runs this test alone too.)
  const int domain = test::private_domain();
  const std::string domain_text = std::to_string(domain);
  // This process's participants' Fast DDS warnings, in the output a failure shows.
  fdds::Log::SetVerbosity(fdds::Log::Kind::Warning);

  Participant plain("", prefix, domain), foreign((root / "foreign" / "head_pc").string(), prefix, domain),
      authorised((root / "keys" / "head_pc").string(), prefix, domain);
  ASSERT_TRUE(plain.ok());
  ASSERT_TRUE(foreign.ok()) << "a valid identity of another CA still makes a participant";
  ASSERT_TRUE(authorised.ok());
  fdds::DataReader* plain_reader = plain.image_reader();
  fdds::DataReader* foreign_reader = foreign.image_reader();
  fdds::DataWriter* plain_writer = plain.target_writer();
  fdds::DataWriter* foreign_writer = foreign.target_writer();
  fdds::DataWriter* writer = authorised.target_writer();
  ASSERT_TRUE(plain_reader && foreign_reader && plain_writer && foreign_writer && writer);

  // Both processes' output, with Fast DDS' warnings, is shown if the test fails.
  const fs::path stats = root / "robot.json", robot_log = root / "robot.log", head_log = root / "head.log";
  pid_t robot = test::spawn_saccade(
      {"--log-level", "debug", "run", SACCADE_SOURCE_DIR "/test/graphs/secure_robot.xml", "--security",
       (root / "keys" / "robot_pc").string(), "--set", "images.topic=" + prefix + "images", "--set",
       "targets.topic=" + prefix + "targets", "--set", "images.domain=" + domain_text, "--set",
       "targets.domain=" + domain_text, "--stats-json", stats.string()},
      robot_log.string());
  const fs::path head_stats = root / "head.json";
  pid_t head = test::spawn_saccade(
      {"--log-level", "debug", "run", SACCADE_SOURCE_DIR "/test/graphs/secure_images.xml", "--security",
       (root / "keys" / "head_pc").string(), "--set", "publish.topic=" + prefix + "images", "--set",
       "publish.domain=" + domain_text, "--stats-json", head_stats.string()},
      head_log.string());
  ASSERT_GT(robot, 0);
  ASSERT_GT(head, 0);
  // Whatever fails below (an ASSERT returns at once), both processes' output is shown.
  std::string ports;
  const Finally show_and_clean_up([&] {
    if (HasFailure())
      std::cout << "domain " << domain << "\n"
                << ports << "robot's output:\n"
                << test::read_text(robot_log.string()) << "head's output:\n"
                << test::read_text(head_log.string());
    fs::remove_all(root);
    fs::remove(root.string() + ".log");
  });

  // The intruders keep offering joint targets the whole time.
  std::atomic<bool> done{false};
  std::thread intruders([&] {
    saccade_idl::JointTargets bogus;
    bogus.position() = {1, 1, 1, 1, 1};
    while (!done.load()) {
      plain_writer->write(&bogus);
      foreign_writer->write(&bogus);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });

  // The authorised participant sends five targets and the end of the stream.
  fdds::PublicationMatchedStatus matched;
  for (int i = 0; i < 3000 && matched.current_count == 0; ++i) {
    writer->get_publication_matched_status(matched);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(matched.current_count, 1) << "the robot's secured reader matches the authorised writer";
  ports = "shared-memory ports the robot maps:\n" + mapped_ports(robot) + "the head's:\n" + mapped_ports(head);
  saccade_idl::JointTargets targets;
  targets.position() = {0.1, 0.2, 0.3, 0.4, 0.5};
  for (int i = 0; i < 5; ++i) {
    targets.stamp().frame_id(i);
    EXPECT_TRUE(writer->write(&targets));
  }
  targets.stamp().flags(1);  // saccade's end of stream
  EXPECT_TRUE(writer->write(&targets));
  writer->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(10.0));

  const int head_code = test::wait_child(head, 60), robot_code = test::wait_child(robot, 60);
  done = true;
  intruders.join();
  EXPECT_EQ(head_code, 0);
  ASSERT_EQ(robot_code, 0) << "the robot ends once both secured streams end";
  EXPECT_EQ(test::stats_emitted(stats, "images"), 40) << "every image, over the secured edge";
  EXPECT_EQ(test::stats_emitted(stats, "targets"), 5) << "the authorised targets and none of the intruders'";
  // The bridges' own counts, in the stats.
  EXPECT_EQ(test::stats_counter(head_stats, "publish", "written"), 40);
  EXPECT_EQ(test::stats_counter(head_stats, "publish", "failed_writes"), 0);
  EXPECT_EQ(test::stats_counter(stats, "images", "unreadable"), 0);
  EXPECT_EQ(test::stats_counter(stats, "images", "lost"), 0);
  EXPECT_EQ(test::stats_counter(stats, "images", "nonexistent"), -1);

  for (fdds::DataReader* reader : {plain_reader, foreign_reader}) {
    saccade_idl::Image image;
    fdds::SampleInfo info;
    EXPECT_NE(reader->take_next_sample(&image, &info), ReturnCode_t::RETCODE_OK) << "an intruder read an image";
    fdds::SubscriptionMatchedStatus s;
    reader->get_subscription_matched_status(s);
    EXPECT_EQ(s.total_count, 0) << "an intruder's reader matched a secured writer";
  }
  for (fdds::DataWriter* w : {plain_writer, foreign_writer}) {
    fdds::PublicationMatchedStatus s;
    w->get_publication_matched_status(s);
    EXPECT_EQ(s.total_count, 0) << "an intruder's writer matched the robot's reader";
  }
}

TEST(DdsSecurity, AMissingFileOfTheFolderIsNamed) {
  const fs::path root = fs::temp_directory_path() / ("saccade_security_missing_" + std::to_string(getpid()));
  fs::remove_all(root);
  ASSERT_EQ(make_security(root, "head_pc"), 0);
  fs::remove(root / "head_pc" / "permissions.p7s");
  const fs::path log = root / "out.log";
  const std::string command = std::string(SACCADE_BINARY_DIR "/bin/saccade run ") +
                              SACCADE_SOURCE_DIR "/test/graphs/secure_images.xml --security " +
                              (root / "head_pc").string() + " > " + log.string() + " 2>&1";
  EXPECT_NE(std::system(command.c_str()), 0);
  const std::string text = test::read_text(log);
  EXPECT_THAT(text,
              ::testing::HasSubstr("DDS security: " + (root / "head_pc" / "permissions.p7s").string() + " is missing"));
  fs::remove_all(root);
  fs::remove(root.string() + ".log");
}

}  // namespace
}  // namespace saccade
