#pragma once
// POSIX shared memory between the processes of one host, and what the frame
// ring and the message mailbox both build on: futex waits and wakes on a word
// in a segment, and liveness told by open-file-description locks.
#include <sys/types.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "saccade/status.hpp"

namespace saccade::dds {

// One mapped POSIX shared-memory segment; its creator unlinks the name
// (at unlink() or when it is destroyed). Keeps its descriptor: the creator
// reserves memory through it, and both ends hold their liveness locks on it.
class SharedSegment {
 public:
  // A new segment `name` of `bytes` bytes, or why it cannot be made (the
  // system's error in words).
  static Result<std::unique_ptr<SharedSegment>> create(const std::string& name, std::size_t bytes);
  // The existing segment `name`, or why it cannot be mapped. `what` names the
  // segment in errors ("the writer's frame ring"); a segment smaller than
  // `min_bytes` is refused.
  static Result<std::unique_ptr<SharedSegment>> open(const std::string& name, std::size_t min_bytes,
                                                     const std::string& what);
  ~SharedSegment();
  SharedSegment(const SharedSegment&) = delete;
  SharedSegment& operator=(const SharedSegment&) = delete;
  // Gives [offset, offset + bytes) memory now (the creator only): false when
  // /dev/shm is full, where writing there would have killed the process (SIGBUS).
  bool reserve(std::size_t offset, std::size_t bytes);
  void unlink();
  uint8_t* base() const { return base_; }
  int fd() const { return fd_; }
  std::size_t bytes() const { return bytes_; }
  const std::string& name() const { return name_; }

 private:
  SharedSegment() = default;
  // Maps `fd` (which it then owns, closed on failure too).
  static Result<std::unique_ptr<SharedSegment>> map(int fd, const std::string& name, std::size_t bytes);
  int fd_ = -1;
  uint8_t* base_ = nullptr;
  std::size_t bytes_ = 0;
  std::string name_;
  bool linked_ = false;
};

// A futex on a 32-bit word of a segment (between processes: not private).
long futex_wait(std::atomic<uint32_t>& word, uint32_t expected, int64_t timeout_ns);
void futex_wake_all(std::atomic<uint32_t>& word);
inline void cpu_relax() {
#if defined(__x86_64__)
  __builtin_ia32_pause();
#endif
}

// How a reader waits for its writer's doorbell: asleep on the futex (the
// default: a wake-up costs some microseconds), or spinning on the word (a
// post is seen within a microsecond, at the cost of a whole core while it
// waits). Either way it counts itself among the waiters, so its writer
// behaves the same (the wake-up it sends a spinning reader is wasted, ~1 us
// of the writer's, after the post is visible).
enum class ReaderWait { kSleep, kSpin };
// Waits until `word` is no longer `value`, `closed` is set, or `timeout_ns`
// pass, in the way `how` says.
void wait_for_doorbell(std::atomic<uint32_t>& word, uint32_t value, const std::atomic<uint32_t>& closed,
                       int64_t timeout_ns, ReaderWait how);

// A writer that woke a sleeping reader lets it take the post before DDS
// delivers the same message: DDS' delivery wakes threads in the reader's
// process too, which then compete with the reader for its core (measured at
// camera rates: twice the latency). The reader marks what it took
// (mark_taken); the writer spins until then, yielding its core (the woken
// reader may be queued on it), for at most `timeout_ns` (spin_until_taken,
// false on the timeout). Both mailboxes' post() do this (ReaderFirst).
// Only for paced streams (the writer's previous post at least 1 ms before):
// back to back the reader is awake anyway, and the wait would halve the
// throughput for nothing (measured: 1024x768 gray 29k -> 12.5k frames/s).
inline constexpr int64_t kReaderFirstNs = 100'000;  // how long a writer waits for that
void mark_taken(std::atomic<uint64_t>& taken, uint64_t post);
bool spin_until_taken(const std::atomic<uint64_t>& taken, uint64_t post, int64_t timeout_ns);
class ReaderFirst {
 public:
  // Called at each post (at `now_ns`, steady clock) with whether it woke a
  // sleeping reader: whether to wait for that reader now.
  bool wait_for(bool woke, int64_t now_ns);
  // Called by a mailbox's post() once post `post` is whole and its readers
  // woken (`woke`): waits, when wait_for says so, until a reader marked it in
  // `taken`, for at most kReaderFirstNs.
  void settle(bool woke, const std::atomic<uint64_t>& taken, uint64_t post);

 private:
  int64_t last_post_ns_ = 0;
};

// Who is alive is told by locks, not process ids: a process holds a lock on
// its byte of the segment for as long as it has it mapped. The kernel drops
// a dead process's locks, and locks work across pid namespaces (containers
// that share /dev/shm but not their process ids), where a pid would name
// nobody or somebody else. Open-file-description locks: per open of the
// segment, so two ends in one process do not share theirs.
bool lock_byte(int fd, off_t at);
void unlock_byte(int fd, off_t at);
// Whether another open of the segment holds the lock on byte `at`.
bool byte_is_locked(int fd, off_t at);
// The same for the segment file at `path` (true when it cannot tell).
bool file_byte_is_locked(const std::string& path, off_t at);

}  // namespace saccade::dds
