// Two builds whose messages differ must not fail silently on one DDS edge:
// each endpoint of a serialised type says its schema's fingerprint in its
// user data, and a peer's of another fingerprint is named as an error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>

#include "domain.hpp"
#include "saccade/cdr.hpp"
#include "saccade/schema.hpp"
#include "saccade/testing.hpp"
#include "support.hpp"
#include "wire.hpp"

namespace saccade {
namespace {

namespace fdds = eprosima::fastdds::dds;

std::vector<uint8_t> bytes(const std::string& text) { return {text.begin(), text.end()}; }

TEST(SchemaFingerprint, EachTypeHasItsOwnAndItIsStable) {
  std::vector<uint64_t> seen;
  for (const std::string_view type : described_message_types()) {
    const uint64_t f = cdr::schema_fingerprint(type);
    EXPECT_NE(f, 0u) << type;
    EXPECT_EQ(f, cdr::schema_fingerprint(type)) << type;
    for (const uint64_t other : seen) EXPECT_NE(f, other) << type;
    seen.push_back(f);
  }
  EXPECT_EQ(cdr::schema_fingerprint("NoSuchType"), 0u);
  EXPECT_EQ(cdr::idl_of("NoSuchType"), "");
}

TEST(SchemaFingerprint, ATypesOwnIdlIsTheWholeIdlsStructForIt) {
  const std::string region = cdr::idl_of("Region");
  ASSERT_NE(region.find("struct Region {"), std::string::npos);
  EXPECT_EQ(region.find("struct FoveaState {"), std::string::npos) << "only the type asked for";
  const std::size_t at = region.find("  struct Region {");
  const std::string body = region.substr(at, region.find("};", at) - at);
  EXPECT_NE(cdr::idl().find(body), std::string::npos) << "the same struct idl() writes:\n" << body;
}

TEST(SchemaFingerprint, TheUserDataSaysItAndOnlyWellFormedOnesAreRead) {
  const dds::Codec* codec = dds::find_codec("Region");
  ASSERT_NE(codec, nullptr);
  const std::vector<uint8_t> data = dds::schema_user_data(*codec);
  EXPECT_EQ(dds::schema_in_user_data(data), cdr::schema_fingerprint("Region"));
  EXPECT_EQ(dds::schema_in_user_data(bytes("saccade-schema=00000000000000ff")), 0xffu);
  EXPECT_EQ(dds::schema_in_user_data({}), 0u);
  EXPECT_EQ(dds::schema_in_user_data(bytes("saccade-schema=12")), 0u) << "too short";
  EXPECT_EQ(dds::schema_in_user_data(bytes("saccade-schema=zz00000000000000")), 0u) << "not hex";
  EXPECT_EQ(dds::schema_in_user_data(bytes("something else")), 0u);
}

// A participant of "another build": our type's name and layout, whatever
// fingerprint it is told to say; it notes the fingerprints the writers it
// discovers say, by topic.
class OtherBuild final : public fdds::DomainParticipantListener {
 public:
  OtherBuild(int domain, const dds::Codec& codec) : codec_(codec) {
    participant_ = fdds::DomainParticipantFactory::get_instance()->create_participant(
        domain, fdds::PARTICIPANT_QOS_DEFAULT, this, fdds::StatusMask::none());
    if (participant_ == nullptr) return;
    fdds::TypeSupport type(codec.make_type().release());
    type.register_type(participant_);
    publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  }
  ~OtherBuild() override {
    if (participant_ == nullptr) return;
    participant_->set_listener(nullptr);
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  bool ok() const { return publisher_ != nullptr && subscriber_ != nullptr; }
  fdds::DataWriter* writer(const std::string& topic, const std::string& user_data) {
    fdds::DataWriterQos qos = fdds::DATAWRITER_QOS_DEFAULT;
    qos.user_data().data_vec(bytes(user_data));
    return publisher_->create_datawriter(topic_of(topic), qos);
  }
  fdds::DataReader* reader(const std::string& topic, const std::string& user_data) {
    fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
    qos.user_data().data_vec(bytes(user_data));
    return subscriber_->create_datareader(topic_of(topic), qos);
  }
  // The fingerprint a writer of `topic` it discovered said (0: none, or none discovered).
  uint64_t writers_fingerprint(const std::string& topic) {
    std::lock_guard lock(mu_);
    auto it = writers_.find(topic);
    return it == writers_.end() ? 0 : it->second;
  }
  void on_publisher_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override {
    std::lock_guard lock(mu_);
    writers_[info.info.topicName().to_string()] = dds::schema_in_user_data(info.info.m_qos.m_userData.data_vec());
  }

 private:
  fdds::Topic* topic_of(const std::string& name) {
    if (auto it = topics_.find(name); it != topics_.end()) return it->second;
    fdds::TypeSupport type(codec_.make_type().release());
    return topics_[name] = participant_->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  }
  const dds::Codec& codec_;
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Publisher* publisher_ = nullptr;
  fdds::Subscriber* subscriber_ = nullptr;
  std::map<std::string, fdds::Topic*> topics_;
  std::mutex mu_;
  std::map<std::string, uint64_t> writers_;
};

TEST(SchemaFingerprint, APeerOfAnotherSchemaIsNamedAndOnesThatAgreeOrSayNothingAreNot) {
  const int domain_id = test::private_domain();
  const std::string topic = "test_schema_" + std::to_string(getpid()), early = topic + "_early";
  const dds::Codec* codec = dds::find_codec("Region");
  ASSERT_NE(codec, nullptr);
  auto domain = dds::Domain::get(domain_id);
  ASSERT_TRUE(domain.ok()) << domain.error();
  OtherBuild other(domain_id, *codec);
  ASSERT_TRUE(other.ok());
  // A writer of another build discovered before this process makes its topic.
  ASSERT_NE(other.writer(early, "saccade-schema=00000000000000ee"), nullptr);

  auto ours = (*domain)->topic(topic, *codec);
  ASSERT_TRUE(ours.ok()) << ours.error();
  fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
  fdds::DataReader* reader = (*domain)->subscriber()->create_datareader(*ours, qos);
  ASSERT_NE(reader, nullptr);
  const std::vector<uint8_t> this_builds = dds::schema_user_data(*codec);
  const std::string same(this_builds.begin(), this_builds.end());
  ASSERT_NE(other.writer(topic, same), nullptr);                               // this build's
  ASSERT_NE(other.writer(topic, ""), nullptr);                                 // a DDS program that does not say
  ASSERT_NE(other.writer(topic, "saccade-schema=0123456789abcdef"), nullptr);  // another build's
  const auto matched = [&] {
    fdds::SubscriptionMatchedStatus status;
    reader->get_subscription_matched_status(status);
    return status.current_count;
  };
  // (Another fingerprint does not stop a match: the type's name is the same.)
  ASSERT_TRUE(test::wait_for([&] { return matched() >= 3; }, 20)) << "writers matched: " << matched();
  EXPECT_TRUE(test::wait_for([&] { return (*domain)->peers_of_another_schema(topic) >= 1; }, 5));
  EXPECT_EQ((*domain)->peers_of_another_schema(topic), 1u) << "only the writer of another fingerprint";

  // A reader of another build is named too: this build's samples are unreadable to it.
  ASSERT_NE(other.reader(topic, "saccade-schema=fedcba9876543210"), nullptr);
  EXPECT_TRUE(test::wait_for([&] { return (*domain)->peers_of_another_schema(topic) >= 2; }, 20));
  EXPECT_EQ((*domain)->peers_of_another_schema("some_other_topic"), 0u);

  // The early writer, discovered long since, is named once its topic is made here.
  EXPECT_EQ((*domain)->peers_of_another_schema(early), 0u);
  ASSERT_TRUE((*domain)->topic(early, *codec).ok());
  EXPECT_EQ((*domain)->peers_of_another_schema(early), 1u);
  (*domain)->subscriber()->delete_datareader(reader);
}

// The bridges themselves say their fingerprint (what the test above gave its
// own reader by hand): a dds.publish node's writer, as another participant discovers it.
TEST(SchemaFingerprint, APublishNodesWriterSaysItsTypesFingerprint) {
  const int domain_id = test::private_domain();
  const std::string topic = "test_schema_node_" + std::to_string(getpid());
  const dds::Codec* codec = dds::find_codec("Region");
  ASSERT_NE(codec, nullptr);
  OtherBuild other(domain_id, *codec);
  ASSERT_TRUE(other.ok());
  ASSERT_NE(other.reader(topic, ""), nullptr);
  auto node =
      testing::NodeHarness::create("<node plugin=\"dds.publish\"><param name=\"topic\" value=\"" + topic +
                                   "\"/><param name=\"type\" value=\"Region\"/><param name=\"domain\" value=\"" +
                                   std::to_string(domain_id) + "\"/></node>");
  ASSERT_TRUE(node.ok()) << node.error();
  EXPECT_TRUE(test::wait_for([&] { return other.writers_fingerprint(topic) != 0; }, 20));
  EXPECT_EQ(other.writers_fingerprint(topic), cdr::schema_fingerprint("Region"));
}

}  // namespace
}  // namespace saccade
