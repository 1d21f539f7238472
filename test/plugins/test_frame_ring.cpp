// The frame ring (plugins/dds/frame_ring.hpp): a writer's buffers in shared
// memory that readers of other processes read in place, pinned while held.
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>
#include <thread>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "frame_ring.hpp"
#include "shared_memory.hpp"
#include "saccade/message.hpp"
#include "support.hpp"

using namespace saccade;
using saccade::dds::FrameRing;
using saccade::dds::ReaderWait;
using saccade::dds::RingAddress;
using saccade::dds::RingReader;

namespace {

std::shared_ptr<FrameRing> make_ring(std::size_t bytes, uint32_t slots) {
  auto ring = FrameRing::create(bytes, slots);
  EXPECT_TRUE(ring.ok()) << ring.error();
  return std::move(ring).value_or(nullptr);
}

// A frame copied into a fresh buffer of `ring`, and where it is.
cv::Mat write_frame(FrameRing& ring, const cv::Mat& frame, RingAddress& at) {
  cv::Mat buffer = ring.take(frame.total() * frame.elemSize());
  if (buffer.empty()) return buffer;
  cv::Mat into(frame.rows, frame.cols, frame.type(), buffer.data);
  frame.copyTo(into);
  std::size_t offset = 1;
  EXPECT_TRUE(ring.locate(buffer, at, offset));
  EXPECT_EQ(offset, 0u);
  return buffer;
}

bool shm_exists(const std::string& name) { return std::filesystem::exists("/dev/shm" + name); }

}  // namespace

TEST(FrameRing, AReaderSeesTheWritersBytesInPlaceAndTheWriterNeverTakesAPinnedBuffer) {
  auto ring = make_ring(640 * 480, 4);
  ASSERT_TRUE(ring);
  const cv::Mat frame = test::random_image({640, 480}, 1);
  RingAddress at;
  cv::Mat buffer = write_frame(*ring, frame, at);
  ASSERT_FALSE(buffer.empty());
  const uint8_t* where = buffer.data;
  buffer.release();  // the writer lets go once written: the frame stays until the buffer is taken again
  EXPECT_EQ(ring->held_slots(), 0u);

  RingReader reader;
  cv::Mat view;
  const Status viewed = reader.view(at, 0, 480, 640, CV_8UC1, view);
  ASSERT_TRUE(viewed.ok()) << viewed.message();
  EXPECT_EQ(test::max_abs_diff(view, frame), 0);
  EXPECT_NE(view.data, where) << "another mapping of the same memory";
  EXPECT_EQ(ring->held_slots(), 1u) << "pinned by the reader";

  // Every other buffer can be taken, that one never while pinned.
  std::vector<cv::Mat> taken;
  for (int i = 0; i < 3; ++i) {
    taken.push_back(ring->take(100));
    ASSERT_FALSE(taken.back().empty()) << i;
    EXPECT_NE(taken.back().data, where);
  }
  EXPECT_TRUE(ring->take(100).empty()) << "the fourth buffer is the pinned one";
  EXPECT_EQ(test::max_abs_diff(view, frame), 0);

  cv::Mat copy_of_header = view;  // headers share the pin
  view.release();
  EXPECT_EQ(ring->held_slots(), 4u);
  copy_of_header.release();
  taken.clear();
  EXPECT_EQ(ring->held_slots(), 0u) << "the last header gone unpins";
  cv::Mat again = ring->take(100);
  EXPECT_FALSE(again.empty());
}

TEST(FrameRing, AFrameWhoseBufferTheWriterTookAgainIsReportedLostNotReadTorn) {
  auto ring = make_ring(4096, 2);
  ASSERT_TRUE(ring);
  RingAddress first;
  ASSERT_FALSE(write_frame(*ring, test::random_image({64, 64}, 1), first).empty());
  RingAddress second, third;
  ASSERT_FALSE(write_frame(*ring, test::random_image({64, 64}, 2), second).empty());
  const cv::Mat newest = test::random_image({64, 64}, 3);
  ASSERT_FALSE(write_frame(*ring, newest, third).empty());  // round robin: first's buffer again
  EXPECT_EQ(third.slot, first.slot);
  EXPECT_NE(third.generation, first.generation);

  RingReader reader;
  cv::Mat view;
  const Status lost = reader.view(first, 0, 64, 64, CV_8UC1, view);
  EXPECT_FALSE(lost.ok());
  EXPECT_THAT(lost.message(), ::testing::HasSubstr("reused the frame's buffer"));
  EXPECT_EQ(reader.overwritten(), 1u);
  EXPECT_TRUE(view.empty());
  const Status newest_viewed = reader.view(third, 0, 64, 64, CV_8UC1, view);
  ASSERT_TRUE(newest_viewed.ok()) << newest_viewed.message();
  EXPECT_EQ(test::max_abs_diff(view, newest), 0);
}

TEST(FrameRing, BytesOutsideABufferOrAMissingRingAreRefusedWithTheReason) {
  auto ring = make_ring(4096, 2);
  ASSERT_TRUE(ring);
  RingAddress at;
  cv::Mat held = write_frame(*ring, test::random_image({64, 64}, 1), at);
  RingReader reader;
  cv::Mat view;
  const Status outside = reader.view(at, 4000, 64, 64, CV_8UC1, view);
  EXPECT_FALSE(outside.ok());
  EXPECT_THAT(outside.message(), ::testing::HasSubstr("outside the writer's ring"));
  RingAddress bad_slot = at;
  bad_slot.slot = 7;
  EXPECT_FALSE(reader.view(bad_slot, 0, 1, 1, CV_8UC1, view).ok());
  RingAddress gone = at;
  gone.ring_id ^= 1;
  const Status missing = reader.view(gone, 0, 1, 1, CV_8UC1, view);
  EXPECT_FALSE(missing.ok());
  EXPECT_THAT(missing.message(), ::testing::HasSubstr("cannot open the writer's frame ring"));
}

TEST(FrameRing, AReaderKeepingManyFramesGetsCopiesSoTheWriterNeverStarves) {
  auto ring = make_ring(4096, 8);  // a reader pins at most 2 of 8
  ASSERT_TRUE(ring);
  RingReader reader;
  std::vector<cv::Mat> kept;
  for (int i = 0; i < 20; ++i) {
    const cv::Mat frame = test::random_image({64, 64}, i);
    RingAddress at;
    ASSERT_FALSE(write_frame(*ring, frame, at).empty()) << "frame " << i << ": the writer found no free buffer";
    cv::Mat view;
    const Status viewed = reader.view(at, 0, 64, 64, CV_8UC1, view);
    ASSERT_TRUE(viewed.ok()) << viewed.message();
    kept.push_back(view);
  }
  EXPECT_EQ(ring->held_slots(), 2u);
  EXPECT_EQ(reader.copied(), 18u);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(test::max_abs_diff(kept[i], test::random_image({64, 64}, i)), 0) << i;
}

TEST(FrameRing, MatsCreatedWithTheRingLiveInItAndARecycledOneIsNeverRewrittenInPlace) {
  auto ring = make_ring(640 * 480, 4);
  ASSERT_TRUE(ring);
  Image image;
  image.mat.allocator = ring.get();  // what a producer that writes into the ring does
  image.mat.create(480, 640, CV_8UC1);
  RingAddress at;
  std::size_t offset = 1;
  ASSERT_TRUE(ring->locate(image.mat, at, offset));
  EXPECT_EQ(offset, 0u);
  const uint8_t* first = image.mat.data;

  // The pool recycles the message: its ring buffer may be read elsewhere, so it goes.
  image.release_shared_buffers();
  EXPECT_TRUE(image.mat.empty());
  image.mat.create(480, 640, CV_8UC1);
  EXPECT_NE(image.mat.data, first) << "the next buffer of the ring";
  ASSERT_TRUE(ring->locate(image.mat, at, offset));

  cv::Mat too_large;
  too_large.allocator = ring.get();
  too_large.create(1000, 1000, CV_8UC1);
  EXPECT_FALSE(ring->locate(too_large, at, offset)) << "too large: on the heap";
  EXPECT_EQ(ring->heap_fallbacks(), 1u);

  cv::Mat plain(10, 10, CV_8UC1);
  EXPECT_FALSE(ring->locate(plain, at, offset));
  const uint8_t* kept = plain.data;
  make_exclusive(plain);
  EXPECT_EQ(plain.data, kept) << "OpenCV's own buffers are still reused";

  // A producer that switches to the ring: its heap buffer goes at the next recycling.
  plain.allocator = ring.get();
  make_exclusive(plain);
  plain.create(10, 10, CV_8UC1);
  EXPECT_TRUE(ring->locate(plain, at, offset));
}

TEST(FrameRing, ARingLargerThanTheFreeSharedMemoryIsWarnedAboutWithTheFix) {
  EXPECT_EQ(saccade::dds::shared_memory_shortfall(4u << 20, 16, 64u << 20), "") << "exactly fits";
  const std::string warning = saccade::dds::shared_memory_shortfall(4u << 20, 16, 60u << 20);
  EXPECT_THAT(warning, ::testing::HasSubstr("16 buffers of 4 MiB (64 MiB) exceed the 60 MiB free in /dev/shm"));
  EXPECT_THAT(warning, ::testing::HasSubstr("capacity"));
  std::string none = "unset";
  auto ring = FrameRing::create(4096, 2, &none);
  ASSERT_TRUE(ring.ok()) << ring.error();
  EXPECT_EQ(none, "") << "this machine's /dev/shm holds 8 KiB";
}

// In a child with a user and mount namespace of its own and a 400 KiB
// /dev/shm: exit 0 when a full /dev/shm sent frames to the heap instead of
// killing the process, 1 when not, 2 when the namespaces cannot be made.
int fill_a_small_shared_memory() {
  const uid_t uid = getuid();
  const gid_t gid = getgid();
  if (unshare(CLONE_NEWUSER | CLONE_NEWNS) != 0) return 2;
  auto write_file = [](const char* path, const std::string& text) {
    FILE* f = std::fopen(path, "w");
    if (f == nullptr) return false;
    const bool ok = std::fputs(text.c_str(), f) >= 0;
    return std::fclose(f) == 0 && ok;
  };
  if (!write_file("/proc/self/setgroups", "deny") ||
      !write_file("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1") ||
      !write_file("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1") ||
      mount("none", "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
      mount("tmpfs", "/dev/shm", "tmpfs", 0, "size=400k") != 0)
    return 2;
  const std::shared_ptr<FrameRing> ring = FrameRing::create(640 * 480, 4).value_or(nullptr);
  if (!ring) return 1;
  RingAddress at;
  std::size_t offset = 0;
  cv::Mat first, second;
  first.allocator = second.allocator = ring.get();
  first.create(480, 640, CV_8UC1);
  first.setTo(1);
  second.create(480, 640, CV_8UC1);  // no room left for a second 300 KiB buffer
  second.setTo(2);
  const bool ok = ring->locate(first, at, offset) && !ring->locate(second, at, offset) && ring->heap_fallbacks() == 1 &&
                  ring->take(640 * 480).empty() && !ring->take(1000).empty() /* fits the first buffer's room */;
  return ok ? 0 : 1;
}

TEST(FrameRing, AFullSharedMemorySendsFramesToTheHeapInsteadOfKillingTheProcess) {
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(fill_a_small_shared_memory());
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status)) << "the child died of signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  if (WEXITSTATUS(status) == 2) GTEST_SKIP() << "no user and mount namespaces here to make a small /dev/shm";
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

TEST(FrameRing, TheRingOutlivesItsOwnerWhileAMatHoldsOneOfItsBuffers) {
  auto ring = make_ring(4096, 2);
  ASSERT_TRUE(ring);
  const std::string name = ring->name();
  EXPECT_TRUE(shm_exists(name));
  cv::Mat buffer = ring->take(4096);
  ASSERT_FALSE(buffer.empty());
  ring.reset();
  EXPECT_FALSE(shm_exists(name)) << "unlinked as its owner lets go";
  buffer.setTo(7);  // still mapped
  EXPECT_EQ(buffer.at<uint8_t>(0, 4095), 7);
  buffer.release();  // deletes the ring (ASan would see a leak or a use after free)
}

TEST(FrameRing, TheWriterTakesBackThePinsOfAReaderWhoseProcessDied) {
  auto ring = make_ring(4096, 4);
  ASSERT_TRUE(ring);
  RingAddress at;
  ASSERT_FALSE(write_frame(*ring, test::random_image({64, 64}, 1), at).empty());
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    auto* reader = new RingReader();  // never deleted: the process dies holding its pin
    cv::Mat view;
    const bool pinned = reader->view(at, 0, 64, 64, CV_8UC1, view).ok();
    new cv::Mat(view);  // keeps the pin past _exit's skipped destructors
    _exit(pinned ? 0 : 1);
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the child could not pin the frame";
  EXPECT_EQ(ring->held_slots(), 1u) << "the dead reader's pin";
  std::vector<cv::Mat> taken;
  for (int i = 0; i < 4; ++i) {
    taken.push_back(ring->take(100));
    EXPECT_FALSE(taken.back().empty()) << i << ": the full ring releases the dead reader's pins";
  }
  EXPECT_EQ(ring->release_dead_readers(), 0) << "done already";
}

TEST(FrameRing, ARingWhoseWriterDiedIsRemovedAsStale) {
  const std::string name = test::left_by_a_crashed_child([] {
    auto* ring = new std::shared_ptr<FrameRing>(FrameRing::create(4096, 2).value_or(nullptr));
    return *ring ? (*ring)->name() : std::string();
  });
  ASSERT_TRUE(shm_exists(name)) << name;
  auto stale = saccade::dds::remove_stale_shared_memory(0);
  EXPECT_FALSE(shm_exists(name));
  EXPECT_NE(std::find(stale.removed.begin(), stale.removed.end(), name.substr(1)), stale.removed.end());
}

namespace {

// A sample as the mailbox carries it: words that all hold the post's number,
// so a torn read (some words from one post, some from the next) shows.
struct Numbered {
  uint64_t words[100];
};

Numbered numbered(uint64_t n) {
  Numbered s;
  std::fill(std::begin(s.words), std::end(s.words), n);
  return s;
}

// A ring with one frame written, whose address a reader follows the ring by.
struct RingWithAFrame {
  std::shared_ptr<FrameRing> ring;
  RingAddress at;
  cv::Mat frame;
};

RingWithAFrame ring_with_a_frame() {
  RingWithAFrame r;
  r.ring = make_ring(4096, 2);
  if (r.ring) r.frame = write_frame(*r.ring, test::random_image({16, 16}, 1), r.at);
  return r;
}

}  // namespace

TEST(FrameRing, TheMailboxHoldsTheNewestSampleAndSaysWhenThereIsNothingNewer) {
  auto [ring, at, frame] = ring_with_a_frame();
  ASSERT_TRUE(ring);
  RingReader reader;
  Numbered got{};
  uint64_t post = 0;
  EXPECT_FALSE(reader.mail(0, &got, sizeof got, post)) << "no ring followed yet";
  const Status followed = reader.follow(at);
  ASSERT_TRUE(followed.ok()) << followed.message();
  EXPECT_TRUE(reader.follows(at));
  EXPECT_FALSE(reader.mail(0, &got, sizeof got, post)) << "nothing posted yet";

  EXPECT_EQ(ring->next_post(), 1u);
  for (uint64_t n = 1; n <= 3; ++n) {
    const Numbered s = numbered(n);
    ring->post(&s, sizeof s);
  }
  EXPECT_EQ(ring->next_post(), 4u);
  ASSERT_TRUE(reader.mail(0, &got, sizeof got, post));
  EXPECT_EQ(post, 3u) << "only the newest is kept";
  EXPECT_EQ(got.words[0], 3u);
  EXPECT_EQ(got.words[99], 3u);
  EXPECT_FALSE(reader.mail(3, &got, sizeof got, post)) << "nothing after 3";
  EXPECT_EQ(reader.mailed(), 1u);

  // A sample of another size is not this reader's type: it goes back to DDS.
  struct Small {
    uint64_t word = 9;
  } small;
  ring->post(&small, sizeof small);
  EXPECT_FALSE(reader.mail(3, &got, sizeof got, post));
  EXPECT_FALSE(reader.following());
}

// A reader in another process, asleep or spinning on the doorbell, against
// a writer posting back to back.
void reader_races_the_writer(ReaderWait how) {
  auto [ring, at, frame] = ring_with_a_frame();
  ASSERT_TRUE(ring);
  const Numbered first = numbered(1);
  ring->post(&first, sizeof first);

  // Another process reads every post it is woken for; the writer posts
  // 20000 more, back to back, so that reads race writes.
  constexpr uint64_t kPosts = 20001;
  int to_parent[2];
  ASSERT_EQ(pipe(to_parent), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    RingReader reader;
    reader.set_wait(how);
    uint64_t last = 0, reads = 0, torn = 0, backwards = 0;
    if (reader.follow(at).ok()) {
      (void)!write(to_parent[1], "r", 1);
      Numbered got{};
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
      while (last < kPosts && std::chrono::steady_clock::now() < give_up) {
        uint64_t post = 0;
        if (reader.mail(last, &got, sizeof got, post)) {
          ++reads;
          torn += std::any_of(std::begin(got.words), std::end(got.words), [&](uint64_t w) { return w != post; });
          backwards += post <= last;
          last = post;
          continue;
        }
        if (!reader.wait_mail(last, 100'000'000)) break;
      }
    }
    std::printf("reads %llu, last %llu, torn %llu, backwards %llu\n", static_cast<unsigned long long>(reads),
                static_cast<unsigned long long>(last), static_cast<unsigned long long>(torn),
                static_cast<unsigned long long>(backwards));
    std::fflush(stdout);
    _exit(last == kPosts && torn == 0 && backwards == 0 && reads > 1 ? 0 : 1);
  }
  char ready = 0;
  ASSERT_EQ(read(to_parent[0], &ready, 1), 1) << "the child follows the ring";
  close(to_parent[0]);
  close(to_parent[1]);
  // The first wake: a sleeping child is asleep on post 1 before post 2 comes
  // (a spinning one never sleeps), and that post wakes it.
  EXPECT_TRUE(test::a_reader_waits_on(*ring, how == ReaderWait::kSleep));
  for (uint64_t n = 2; n <= kPosts; ++n) {
    const Numbered s = numbered(n);
    const bool woke = ring->post(&s, sizeof s);
    if (n == 2 && how == ReaderWait::kSleep) { EXPECT_TRUE(woke) << "the reader asleep on the doorbell was not woken"; }
  }
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "the child saw a torn or out-of-order sample, or missed the last post (its line above says which)";
}

TEST(FrameRing, AReaderSleepingOnTheDoorbellWakesWhenTheWriterPostsAndNeverReadsATornSample) {
  reader_races_the_writer(ReaderWait::kSleep);
}

TEST(FrameRing, AReaderSpinningOnTheDoorbellSeesEveryPostAndNeverReadsATornSample) {
  reader_races_the_writer(ReaderWait::kSpin);
}

TEST(FrameRing, ASpinningReaderWaitsOutItsTimeoutWhenNothingIsPosted) {
  auto [ring, at, frame] = ring_with_a_frame();
  ASSERT_TRUE(ring);
  RingReader reader;
  reader.set_wait(ReaderWait::kSpin);
  const Status followed = reader.follow(at);
  ASSERT_TRUE(followed.ok()) << followed.message();
  const auto start = std::chrono::steady_clock::now();
  EXPECT_TRUE(reader.wait_mail(0, 20'000'000)) << "the ring is still there";
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(20));
  const Numbered s = numbered(1);
  ring->post(&s, sizeof s);
  // A post already there: at once, not after the minute's timeout (which
  // also returns true while the ring is there).
  auto waited = std::async(std::launch::async, [&] { return reader.wait_mail(0, 60'000'000'000); });
  ASSERT_EQ(waited.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_TRUE(waited.get());
  Numbered got{};
  uint64_t post = 0;
  ASSERT_TRUE(reader.mail(0, &got, sizeof got, post));
  EXPECT_EQ(post, 1u);
}

void letting_go_sends_readers_back(ReaderWait how) {
  auto [ring, at, frame] = ring_with_a_frame();
  ASSERT_TRUE(ring);
  RingReader reader;
  reader.set_wait(how);
  const Status followed = reader.follow(at);
  ASSERT_TRUE(followed.ok()) << followed.message();
  auto woken = std::async(std::launch::async, [&] { return reader.wait_mail(0, 60'000'000'000); });
  EXPECT_TRUE(test::a_reader_waits_on(*ring, how == ReaderWait::kSleep));
  ring.reset();
  // Woken by the writer's end, not by the minute's timeout.
  ASSERT_EQ(woken.wait_for(std::chrono::seconds(30)), std::future_status::ready);
  EXPECT_FALSE(woken.get());
  EXPECT_FALSE(reader.following());
  EXPECT_FALSE(reader.wait_mail(0, 60'000'000'000)) << "nothing to follow";
}

TEST(FrameRing, AWriterLettingGoOfItsRingSendsItsReadersBackToDds) {
  for (const ReaderWait how : {ReaderWait::kSleep, ReaderWait::kSpin}) {
    SCOPED_TRACE(how == ReaderWait::kSpin ? "spinning" : "asleep");
    letting_go_sends_readers_back(how);
  }
}

TEST(FrameRing, AReaderLivesWhileItHoldsTheRingWhateverItsProcessIdSays) {
  // Processes in other pid namespaces (containers sharing /dev/shm) register
  // pids that name nobody here, or somebody else: a reader's liveness is its
  // lock on the ring, which only its death releases.
  auto ring = make_ring(4096, 4);
  ASSERT_TRUE(ring);
  RingAddress at;
  ASSERT_FALSE(write_frame(*ring, test::random_image({64, 64}, 1), at).empty());
  RingReader reader;
  cv::Mat view;
  const Status viewed = reader.view(at, 0, 64, 64, CV_8UC1, view);
  ASSERT_TRUE(viewed.ok()) << viewed.message();
  EXPECT_EQ(ring->held_slots(), 1u);

  // The segment's header, as laid out in frame_ring.cpp: the first reader's pid at byte 48.
  const int fd = ::open(("/dev/shm" + ring->name()).c_str(), O_RDWR);
  ASSERT_GE(fd, 0);
  void* base = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  ::close(fd);
  ASSERT_NE(base, MAP_FAILED);
  auto* first_reader_pid = reinterpret_cast<int32_t*>(static_cast<uint8_t*>(base) + 48);
  ASSERT_EQ(*first_reader_pid, getpid()) << "the header's layout changed: update this test";
  int32_t nobody = 4'000'000;
  while (kill(nobody, 0) == 0 || errno != ESRCH) ++nobody;
  *first_reader_pid = nobody;

  EXPECT_EQ(ring->release_dead_readers(), 0) << "the reader still holds its lock";
  EXPECT_EQ(ring->held_slots(), 1u) << "its pin stays";
  EXPECT_EQ(test::max_abs_diff(view, test::random_image({64, 64}, 1)), 0);
  *first_reader_pid = getpid();
  ::munmap(base, 4096);

  // And a ring whose writer lives is never stale, whoever can see its process.
  EXPECT_TRUE(saccade::dds::frame_ring_has_writer("/dev/shm" + ring->name()));
  saccade::dds::remove_stale_shared_memory(0);
  EXPECT_TRUE(shm_exists(ring->name()));
}

TEST(FrameRing, AWriterThatWokeASleepingReaderCanWaitUntilItHasTakenThePost) {
  auto [ring, at, frame] = ring_with_a_frame();
  ASSERT_TRUE(ring);
  RingReader reader;
  const Status followed = reader.follow(at);
  ASSERT_TRUE(followed.ok()) << followed.message();
  const Numbered first = numbered(1);
  EXPECT_FALSE(ring->post(&first, sizeof first)) << "nobody was asleep on the doorbell";
  EXPECT_FALSE(ring->wait_until_taken(1, 2'000'000)) << "nobody took it: the wait times out";
  Numbered got{};
  uint64_t post = 0;
  ASSERT_TRUE(reader.mail(0, &got, sizeof got, post));
  EXPECT_TRUE(ring->wait_until_taken(1, 0)) << "taken";

  std::thread sleeper([&] {
    Numbered mine{};
    uint64_t number = 0;
    ASSERT_TRUE(reader.wait_mail(1, 10'000'000'000));
    EXPECT_TRUE(reader.mail(1, &mine, sizeof mine, number));
  });
  EXPECT_TRUE(test::a_reader_sleeps_on(*ring));
  const Numbered second = numbered(2);
  EXPECT_TRUE(ring->post(&second, sizeof second));
  EXPECT_TRUE(ring->wait_until_taken(2, 10'000'000'000));
  sleeper.join();
}

// The reader's count of what it delivered from a ring's mailbox: a DDS copy of
// a post it had already is dropped, also when it arrives after the reader let
// go of the ring (closed) and follows it again; only another ring (a writer
// that restarted) starts the count afresh. (Re-following the same ring used to
// start it afresh too, delivering the late copies twice.)
TEST(DeliveredPosts, ALateCopyOfAPostAlreadyDeliveredIsDroppedEvenAfterTheRingWasLetGo) {
  saccade::dds::DeliveredPosts delivered;
  const RingAddress ring{.writer_pid = 41, .ring_id = 7, .slot = 0, .generation = 0};
  EXPECT_TRUE(delivered.take(ring, 1));  // through DDS, the reader follows the ring
  EXPECT_TRUE(delivered.take(ring, 3));  // the mailbox's newest
  EXPECT_FALSE(delivered.take(ring, 2)) << "older than what the mailbox gave";
  EXPECT_FALSE(delivered.take(ring, 3)) << "DDS' copy of what the mailbox gave";
  RingAddress other_slot = ring;
  other_slot.slot = 5;
  other_slot.generation = 2;
  EXPECT_FALSE(delivered.take(other_slot, 3)) << "another buffer of the same ring is the same ring";
  EXPECT_TRUE(delivered.take(other_slot, 4));
  EXPECT_EQ(delivered.newest(), 4u);

  const RingAddress restarted{.writer_pid = 42, .ring_id = 1, .slot = 0, .generation = 0};
  EXPECT_TRUE(delivered.take(restarted, 1)) << "a new writer's ring counts from its own first post";
  EXPECT_EQ(delivered.newest(), 1u);
  EXPECT_TRUE(saccade::dds::same_ring(delivered.ring(), restarted));
  EXPECT_FALSE(delivered.take(restarted, 1));
}
