// The same-host mailbox (plugins/dds/mailbox.hpp): a writer's numbered slots
// of serialised messages in shared memory, read in order or newest first by
// readers it wakes itself.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "mailbox.hpp"
#include "shared_memory.hpp"
#include "shared_segment.hpp"
#include "support.hpp"

using saccade::dds::Mailbox;
using saccade::dds::MailboxReader;
using saccade::dds::ReaderWait;
using Read = saccade::dds::MailboxReader::Read;

namespace {

// A message whose bytes all hold its post's number (low byte) and whose
// length depends on it, so that a torn or misplaced read shows.
std::vector<uint8_t> message_of(uint64_t post) {
  return std::vector<uint8_t>(100 + post % 37, static_cast<uint8_t>(post));
}

bool is_message_of(const std::vector<uint8_t>& bytes, uint64_t post) { return bytes == message_of(post); }

bool shm_exists(const std::string& name) { return std::filesystem::exists("/dev/shm" + name); }

std::unique_ptr<Mailbox> make_mailbox(std::size_t slot_bytes, uint32_t slots) {
  auto box = Mailbox::create(slot_bytes, slots);
  EXPECT_TRUE(box.ok()) << box.error();
  return std::move(box).value_or(nullptr);
}

// Whether the post woke a reader asleep on the mailbox.
bool post(Mailbox& box, uint64_t n) {
  const std::vector<uint8_t> m = message_of(n);
  return box.post(m.data(), m.size());
}

}  // namespace

TEST(Mailbox, EveryPostIsReadInOrderUntilTheWriterHasUsedItsSlotAgain) {
  auto box = make_mailbox(256, 4);
  ASSERT_TRUE(box);
  MailboxReader reader;
  const saccade::Status followed = reader.follow(box->id());
  ASSERT_TRUE(followed.ok()) << followed.message();
  EXPECT_TRUE(reader.open());
  EXPECT_TRUE(reader.writer_alive());
  std::vector<uint8_t> got;
  EXPECT_EQ(reader.newest(), 0u);
  EXPECT_EQ(reader.read(1, got), Read::kNotYet) << "nothing posted yet";

  EXPECT_EQ(box->next_post(), 1u);
  for (uint64_t n = 1; n <= 3; ++n) post(*box, n);
  EXPECT_EQ(box->next_post(), 4u);
  EXPECT_EQ(reader.newest(), 3u);
  for (uint64_t n = 1; n <= 3; ++n) {
    ASSERT_EQ(reader.read(n, got), Read::kMessage) << n;
    EXPECT_TRUE(is_message_of(got, n)) << n;
  }
  EXPECT_EQ(reader.read(4, got), Read::kNotYet);

  // Four slots: posts 4..7 take the slots of 1..3 and 4 again.
  for (uint64_t n = 4; n <= 7; ++n) post(*box, n);
  EXPECT_EQ(reader.read(3, got), Read::kOverwritten) << "gone: its slot holds post 7";
  EXPECT_EQ(reader.read(2, got), Read::kOverwritten);
  for (uint64_t n = 4; n <= 7; ++n) {
    ASSERT_EQ(reader.read(n, got), Read::kMessage) << n;
    EXPECT_TRUE(is_message_of(got, n)) << n;
  }
}

TEST(Mailbox, AMessageLargerThanASlotIsPostedAsOneToTakeFromDds) {
  auto box = make_mailbox(64, 4);
  ASSERT_TRUE(box);
  MailboxReader reader;
  const saccade::Status followed = reader.follow(box->id());
  ASSERT_TRUE(followed.ok()) << followed.message();
  const std::vector<uint8_t> large(65, 7), fits(64, 8);
  box->post(large.data(), large.size());
  box->post(fits.data(), fits.size());
  std::vector<uint8_t> got;
  EXPECT_EQ(reader.read(1, got), Read::kInDds);
  ASSERT_EQ(reader.read(2, got), Read::kMessage);
  EXPECT_EQ(got, fits);
}

TEST(Mailbox, AnUnknownOrForeignMailboxIsRefusedWithTheReason) {
  MailboxReader reader;
  const saccade::Status refused = reader.follow(0x1234);
  EXPECT_FALSE(refused.ok());
  EXPECT_THAT(refused.message(), ::testing::HasSubstr("saccade_mail_0000000000001234"));
  EXPECT_FALSE(reader.open());
  std::vector<uint8_t> got;
  EXPECT_EQ(reader.read(1, got), Read::kNotYet);
  EXPECT_FALSE(reader.wait(0, 1'000'000)) << "nothing followed";
}

void closing_sends_readers_back(ReaderWait how) {
  auto box = make_mailbox(256, 4);
  ASSERT_TRUE(box);
  const std::string name = saccade::dds::mailbox_segment_name(box->id());
  EXPECT_TRUE(shm_exists(name));
  MailboxReader reader;
  reader.set_wait(how);
  const saccade::Status followed = reader.follow(box->id());
  ASSERT_TRUE(followed.ok()) << followed.message();
  post(*box, 1);
  auto woken = std::async(std::launch::async, [&] { return reader.wait(1, 60'000'000'000); });
  EXPECT_TRUE(saccade::test::a_reader_waits_on(*box, how == ReaderWait::kSleep));
  box.reset();
  // Woken by the writer's end, not by the minute's timeout.
  ASSERT_EQ(woken.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_FALSE(woken.get());
  EXPECT_FALSE(reader.open());
  EXPECT_FALSE(shm_exists(name)) << "the writer unlinks its name";
  std::vector<uint8_t> got;
  ASSERT_EQ(reader.read(1, got), Read::kMessage) << "what was posted stays readable";
  EXPECT_TRUE(is_message_of(got, 1));
}

TEST(Mailbox, AWriterClosingItsMailboxWakesItsReadersAndSendsThemBackToDds) {
  for (const ReaderWait how : {ReaderWait::kSleep, ReaderWait::kSpin}) {
    SCOPED_TRACE(how == ReaderWait::kSpin ? "spinning" : "asleep");
    closing_sends_readers_back(how);
  }
}

// A reader in another process, asleep or spinning, against a writer posting
// back to back.
void reader_reads_every_post(ReaderWait how) {
  // The child reads each post in order as the writer posts 20000, back to
  // back, into four slots: the writer laps the reader all the time, so reads
  // race writes of the same slot.
  constexpr uint32_t kSlots = 4;
  auto box = make_mailbox(256, kSlots);
  ASSERT_TRUE(box);
  constexpr uint64_t kPosts = 20000;
  int to_parent[2];
  ASSERT_EQ(pipe(to_parent), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    MailboxReader reader;
    reader.set_wait(how);
    uint64_t last = 0, torn = 0, overwritten = 0, woken = 0;
    if (reader.follow(box->id()).ok()) {
      (void)!write(to_parent[1], "r", 1);
      std::vector<uint8_t> got;
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
      while (last < kPosts && std::chrono::steady_clock::now() < give_up) {
        const Read r = reader.read(last + 1, got);
        if (r == Read::kMessage) {
          torn += is_message_of(got, last + 1) ? 0 : 1;
          ++last;
          continue;
        }
        if (r == Read::kOverwritten) {  // lapped: on from the oldest post still there
          ++overwritten;
          last = reader.newest() - (kSlots - 1) - 1;
          continue;
        }
        if (!reader.wait(last, 100'000'000)) break;
        ++woken;
      }
    }
    std::printf("last %llu, torn %llu, overwritten %llu, woken %llu\n", static_cast<unsigned long long>(last),
                static_cast<unsigned long long>(torn), static_cast<unsigned long long>(overwritten),
                static_cast<unsigned long long>(woken));
    std::fflush(stdout);
    _exit(last == kPosts && torn == 0 && woken > 0 ? 0 : 1);
  }
  char ready = 0;
  ASSERT_EQ(read(to_parent[0], &ready, 1), 1) << "the child follows the mailbox";
  close(to_parent[0]);
  close(to_parent[1]);
  // A sleeping child is asleep on post 1 before it comes (a spinning one
  // never sleeps), and that post wakes it.
  EXPECT_TRUE(saccade::test::a_reader_waits_on(*box, how == ReaderWait::kSleep));
  for (uint64_t n = 1; n <= kPosts; ++n) {
    const bool woke = post(*box, n);
    if (n == 1 && how == ReaderWait::kSleep) { EXPECT_TRUE(woke) << "the reader asleep on the mailbox was not woken"; }
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "the child read a torn message or missed the last post (its line above says which)";
}

TEST(Mailbox, AReaderInAnotherProcessReadsEveryPostInOrderAndNeverATornOne) {
  reader_reads_every_post(ReaderWait::kSleep);
}

TEST(Mailbox, ASpinningReaderInAnotherProcessReadsEveryPostInOrderAndNeverATornOne) {
  reader_reads_every_post(ReaderWait::kSpin);
}

TEST(Mailbox, AMailboxWhoseWriterDiedIsRemovedAsStale) {
  const std::string name = saccade::test::left_by_a_crashed_child([] {
    auto* box = Mailbox::create(256, 4).value_or(nullptr).release();
    return box != nullptr ? saccade::dds::mailbox_segment_name(box->id()) : std::string();
  });
  ASSERT_TRUE(shm_exists(name)) << name;
  EXPECT_FALSE(saccade::dds::mailbox_has_writer("/dev/shm" + name));

  // A live writer's mailbox is kept.
  auto live = make_mailbox(256, 4);
  ASSERT_TRUE(live);
  const std::string live_name = saccade::dds::mailbox_segment_name(live->id());
  EXPECT_TRUE(saccade::dds::mailbox_has_writer("/dev/shm" + live_name));

  auto stale = saccade::dds::remove_stale_shared_memory(0);
  EXPECT_FALSE(shm_exists(name));
  EXPECT_NE(std::find(stale.removed.begin(), stale.removed.end(), name.substr(1)), stale.removed.end());
  EXPECT_TRUE(shm_exists(live_name));
}

TEST(Mailbox, AWriterThatWokeASleepingReaderCanWaitUntilItHasReadThePost) {
  auto box = make_mailbox(256, 4);
  ASSERT_TRUE(box);
  MailboxReader reader;
  const saccade::Status followed = reader.follow(box->id());
  ASSERT_TRUE(followed.ok()) << followed.message();
  const std::vector<uint8_t> m = message_of(1);
  EXPECT_FALSE(box->post(m.data(), m.size())) << "nobody was asleep on the doorbell";
  EXPECT_FALSE(box->wait_until_taken(1, 2'000'000)) << "nobody read it: the wait times out";
  std::vector<uint8_t> got;
  ASSERT_EQ(reader.read(1, got), Read::kMessage);
  EXPECT_TRUE(box->wait_until_taken(1, 0)) << "read";

  // A reader asleep on the doorbell: the post says it woke somebody, and
  // the writer's wait ends once that reader has read it.
  std::thread sleeper([&] {
    std::vector<uint8_t> mine;
    ASSERT_TRUE(reader.wait(1, 10'000'000'000));
    EXPECT_EQ(reader.read(2, mine), Read::kMessage);
  });
  EXPECT_TRUE(saccade::test::a_reader_sleeps_on(*box));
  const std::vector<uint8_t> second = message_of(2);
  EXPECT_TRUE(box->post(second.data(), second.size()));
  EXPECT_TRUE(box->wait_until_taken(2, 10'000'000'000));
  sleeper.join();
}

TEST(Mailbox, AWriterWaitsForTheReaderItWokeOnlyWhenItsPostsArePaced) {
  saccade::dds::ReaderFirst first;
  const int64_t t0 = 1'000'000'000;
  EXPECT_TRUE(first.wait_for(true, t0)) << "the first post of a stream";
  EXPECT_FALSE(first.wait_for(true, t0 + 50'000)) << "back to back: the reader is awake anyway";
  EXPECT_FALSE(first.wait_for(false, t0 + 2'000'000)) << "nobody was woken";
  EXPECT_TRUE(first.wait_for(true, t0 + 4'000'000)) << "paced: 2 ms after the post before";
}
