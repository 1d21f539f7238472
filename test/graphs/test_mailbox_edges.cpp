// DDS edges of serialised types with the same-host mailbox (the bridges'
// code: codec, wire sample, QoS), writer and reader in this process: every
// message arrives once and in order whichever way it came (the mailbox, or
// DDS when the reader fell behind, the message was too large, or the writer
// was started again), and either end without the mailbox still talks DDS.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>
#include <vector>

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>

#include "codec.hpp"
#include "domain.hpp"
#include "edge_codec.hpp"
#include "saccade/message.hpp"
#include "support.hpp"

namespace saccade {
namespace {

namespace fdds = eprosima::fastdds::dds;
namespace sd = saccade::dds;

using test::private_domain;

struct EdgeEnds {
  std::shared_ptr<sd::Domain> domain;
  fdds::Topic* topic = nullptr;
  const sd::Codec* codec = nullptr;
  sd::EdgeSettings settings;
};

EdgeEnds edge_of(const std::string& type, const std::string& name, bool reliable, int depth) {
  EdgeEnds e;
  auto domain = sd::Domain::get(private_domain());
  EXPECT_TRUE(domain.ok()) << domain.error();
  e.domain = std::move(domain).value_or(nullptr);
  auto codec = sd::choose_codec(type, {.zero_copy = true, .reliable = reliable});
  EXPECT_TRUE(codec.ok()) << codec.error();
  e.codec = std::move(codec).value_or(nullptr);
  EXPECT_EQ(e.codec->form, sd::Codec::Form::kSerialized);
  e.settings.reliable = reliable;
  e.settings.depth = depth;
  auto topic = e.domain->topic("test_mailbox/" + std::to_string(getpid()) + "/" + name, *e.codec);
  EXPECT_TRUE(topic.ok()) << topic.error();
  e.topic = std::move(topic).value_or(nullptr);
  return e;
}

sd::WireOptions options(bool mailbox, bool in_order, bool spin = false) {
  sd::WireOptions o;
  o.mailbox = mailbox;
  o.in_order = in_order;
  if (spin) o.reader_wait = sd::ReaderWait::kSpin;
  return o;
}

struct Writer {
  std::unique_ptr<sd::WireSample> sample;
  fdds::DataWriter* writer = nullptr;
  const EdgeEnds* edge = nullptr;
  Writer(const EdgeEnds& e, bool mailbox) : edge(&e) {
    sample = e.codec->make_sample(options(mailbox, e.settings.reliable));
    writer = e.domain->publisher()->create_datawriter(e.topic, sd::writer_qos(*e.domain->publisher(), e.settings));
  }
  ~Writer() { edge->domain->publisher()->delete_datawriter(writer); }
  bool matched() const {
    fdds::PublicationMatchedStatus s;
    writer->get_publication_matched_status(s);
    return s.current_count > 0;
  }
  void write(const Message* m) {
    bool written = false;
    ASSERT_TRUE(sample->write(*writer, m, written).ok());
    EXPECT_TRUE(written);
  }
};

struct Reader {
  std::unique_ptr<sd::WireSample> sample;
  fdds::DataReader* reader = nullptr;
  const EdgeEnds* edge = nullptr;
  Reader(const EdgeEnds& e, bool mailbox, bool spin = false) : edge(&e) {
    sample = e.codec->make_sample(options(mailbox, e.settings.reliable, spin));
    reader = e.domain->subscriber()->create_datareader(e.topic, sd::reader_qos(*e.domain->subscriber(), e.settings));
  }
  ~Reader() { edge->domain->subscriber()->delete_datareader(reader); }
  // The frame ids taken until `ends` ends of stream (or 20 s pass).
  std::vector<int64_t> take_until_end(int ends = 1) {
    std::vector<int64_t> ids;
    MessagePtr slot;
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (ends > 0 && std::chrono::steady_clock::now() < give_up) {
      switch (sample->take(*reader, nullptr, 0, slot)) {
        case sd::WireSample::Taken::kMessage: ids.push_back(slot->frame_id); break;
        case sd::WireSample::Taken::kEnd: --ends; break;
        case sd::WireSample::Taken::kUnreadable: ADD_FAILURE() << sample->why_unreadable(); break;
        case sd::WireSample::Taken::kNothing: sample->wait(*reader, 50); break;
      }
    }
    EXPECT_EQ(ends, 0) << "the end of stream never came";
    return ids;
  }
};

void wait_matched(const Writer& w) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!w.matched() && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(w.matched());
}

std::shared_ptr<JointTargets> targets(int64_t id) {
  auto t = std::make_shared<JointTargets>();
  t->frame_id = id;
  t->position = {0.1 * static_cast<double>(id), 0.2, 0.3, 0.4, 0.5};
  return t;
}

std::vector<int64_t> ids_from(int64_t first, int64_t last) {
  std::vector<int64_t> out;
  for (int64_t i = first; i <= last; ++i) out.push_back(i);
  return out;
}

}  // namespace

namespace {

// 200 targets every 0.5 ms over a reliable mailbox edge, read asleep or spinning.
void paced_reliable_edge(const char* name, bool spin) {
  EdgeEnds e = edge_of("JointTargets", name, true, 8);
  Writer w(e, true);
  Reader r(e, true, spin);
  wait_matched(w);
  std::vector<int64_t> ids;
  std::thread reading([&] { ids = r.take_until_end(); });
  for (int64_t i = 0; i < 200; ++i) {
    w.write(targets(i).get());
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  w.write(nullptr);
  reading.join();
  EXPECT_EQ(ids, ids_from(0, 199));
  // The first names the mailbox (through DDS); the writer's mailbox woke the
  // reader for most of the rest, and DDS' copies of those were dropped.
  EXPECT_GE(r.sample->frames_mailed(), 100u) << r.sample->frames_mailed();
}

}  // namespace

TEST(DdsMailbox, AReliableEdgeDeliversEveryMessageOnceAndInOrderMostThroughTheMailbox) {
  paced_reliable_edge("paced", false);
}

TEST(DdsMailbox, AReaderSpinningOnTheMailboxGetsEveryMessageOnceAndInOrder) { paced_reliable_edge("spinning", true); }

TEST(DdsMailbox, AReaderSpinningOnAFrameRingGetsThePacedImagesInOrder) {
  EdgeEnds e;
  auto domain = sd::Domain::get(private_domain());
  ASSERT_TRUE(domain.ok()) << domain.error();
  e.domain = *domain;
  auto codec = sd::choose_codec("Image", {.zero_copy = true});
  ASSERT_TRUE(codec.ok()) << codec.error();
  e.codec = *codec;
  ASSERT_EQ(e.codec->form, sd::Codec::Form::kRing);
  auto topic = e.domain->topic("test_mailbox/" + std::to_string(getpid()) + "/ring_spin", *e.codec);
  ASSERT_TRUE(topic.ok()) << topic.error();
  e.topic = *topic;
  Writer w(e, false);
  Reader r(e, false, /*spin=*/true);
  wait_matched(w);
  std::vector<int64_t> ids;
  std::thread reading([&] { ids = r.take_until_end(); });
  auto image = std::make_shared<Image>();
  image->mat = test::random_image({320, 240}, 3);
  for (int64_t i = 0; i < 100; ++i) {
    image->frame_id = i;
    w.write(image.get());
    std::this_thread::sleep_for(std::chrono::microseconds(1000));
  }
  w.write(nullptr);
  reading.join();
  // Best effort: a frame may be lost, none repeated or out of order.
  ASSERT_GE(ids.size(), 95u);
  EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()) && std::adjacent_find(ids.begin(), ids.end()) == ids.end());
  EXPECT_GE(r.sample->frames_mailed(), 80u) << "the ring's mailbox, which the reader spins on";
}

TEST(DdsMailbox, AReliableReaderThatFellARingBehindGetsTheRestFromDdsInOrder) {
  EdgeEnds e = edge_of("JointTargets", "behind", true, 200);  // DDS keeps every one
  Writer w(e, true);
  Reader r(e, true);
  wait_matched(w);
  // 100 messages before the reader takes any: the mailbox's 16 slots hold the last 16.
  for (int64_t i = 0; i < 100; ++i) w.write(targets(i).get());
  w.write(nullptr);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(r.take_until_end(), ids_from(0, 99));
  EXPECT_GE(r.sample->frames_mailed(), 1u) << "caught up, the reader reads the mailbox again";
  EXPECT_LE(r.sample->frames_mailed(), 17u) << "what the slots no longer held came from DDS";
}

TEST(DdsMailbox, AWriterStartedAgainIsFollowedWithoutRepeatsOrLosses) {
  EdgeEnds e = edge_of("JointTargets", "restart", true, 100);
  Reader r(e, true);
  std::vector<int64_t> ids;
  std::thread reading([&] { ids = r.take_until_end(2); });
  for (int round = 0; round < 2; ++round) {
    Writer w(e, true);  // a new mailbox each time
    wait_matched(w);
    for (int64_t i = 0; i < 50; ++i) {
      w.write(targets(round * 50 + i).get());
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    w.write(nullptr);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  reading.join();
  EXPECT_EQ(ids, ids_from(0, 99));
  EXPECT_GE(r.sample->frames_mailed(), 75u) << "both writers' mailboxes were read: " << r.sample->frames_mailed();
}

TEST(DdsMailbox, AnEndWithoutTheMailboxTalksPlainDds) {
  for (bool writer_has_it : {true, false}) {
    EdgeEnds e = edge_of("JointTargets", writer_has_it ? "reader_without" : "writer_without", true, 100);
    Writer w(e, writer_has_it);
    Reader r(e, !writer_has_it);
    wait_matched(w);
    std::vector<int64_t> ids;
    std::thread reading([&] { ids = r.take_until_end(); });
    for (int64_t i = 0; i < 30; ++i) {
      w.write(targets(i).get());
      std::this_thread::sleep_for(std::chrono::microseconds(300));
    }
    w.write(nullptr);
    reading.join();
    EXPECT_EQ(ids, ids_from(0, 29)) << writer_has_it;
    EXPECT_EQ(r.sample->frames_mailed(), 0u);
  }
}

TEST(DdsMailbox, MessagesThatOutgrowTheSlotsGetANewMailboxOrGoThroughDdsAndKeepTheirOrder) {
  EdgeEnds e = edge_of("Retina", "sizes", true, 100);
  Writer w(e, true);
  Reader r(e, true);
  wait_matched(w);
  // Slots are made for the first (small) one; a 10 KB retina needs a larger
  // mailbox, a 150 KB one is larger than any slot (DDS alone).
  const int widths[] = {16, 16, 64, 64, 16, 256, 16, 64, 256, 16};
  std::vector<int64_t> ids;
  std::thread reading([&] { ids = r.take_until_end(); });
  for (int64_t i = 0; i < 10; ++i) {
    Retina retina;
    retina.frame_id = i;
    const int width = widths[i];
    retina.levels.assign(5, cv::Mat(width * 3 / 4, width, CV_8UC1, cv::Scalar(static_cast<double>(i))));
    retina.geometry.assign(5, LevelGeometry{});
    w.write(&retina);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  w.write(nullptr);
  reading.join();
  EXPECT_EQ(ids, ids_from(0, 9));
  EXPECT_GE(r.sample->frames_mailed(), 3u);
  EXPECT_LE(r.sample->frames_mailed(), 8u) << "the 150 KB retinas came through DDS";
}

}  // namespace saccade
