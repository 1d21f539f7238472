#pragma once
// Frames shared in place between the processes of one host.
//
// A writer owns a ring of fixed-size buffers in POSIX shared memory; the DDS
// sample of a frame carries only where its bytes sit (a RingAddress), and
// each reader pins that buffer for as long as its graph holds the frame, so
// the writer never takes a buffer somebody still reads. Fast DDS' own data
// sharing cannot promise that: its keep-last pool reuses a sample whatever
// the readers hold, so a reader there must copy before it returns the loan.
//
// Both ends hand the buffers out as cv::Mat through cv::MatAllocator: the
// last Mat header of a buffer gone releases the writer's hold on it or the
// reader's pin. A producer that creates its images with the writer's
// allocator writes its frame straight into the ring (no copy on either side).
//
// Each buffer's state is one 64-bit word in the segment: a generation (upper
// 32 bits, advanced each time the writer takes the buffer for a new frame),
// the writer's hold (bit 31) and one pin bit per registered reader (bits
// 0..15). A reader pins only the generation it was told, so a buffer the
// writer took again meanwhile is reported lost, never read torn; the writer
// takes only buffers nobody holds, round robin, so a frame survives the
// writer's next `slots - 1` frames even unpinned.
//
// The ring also has a mailbox: the writer posts each frame's DDS sample there
// as well and rings a doorbell (a futex in the segment), so a reader on the
// same host is woken once, by the writer itself, instead of through Fast
// DDS' listener thread and then its own (two hand-offs between threads, most
// of an in-place edge's latency). DDS still carries every sample (the first
// one names the ring; a restarted writer's new ring; every reader the
// mailbox does not serve); a reader drops the DDS copies of what its mailbox
// gave it by the post number each sample carries.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/status.hpp"
#include "shared_segment.hpp"

namespace saccade::dds {

// Where a frame's bytes are: the writer's ring and one buffer of it, as it was
// when the frame was written.
struct RingAddress {
  uint32_t writer_pid = 0;
  uint64_t ring_id = 0;
  uint32_t slot = 0;
  uint32_t generation = 0;
};

// Whether two addresses lie in the same ring (of the same writer process).
inline bool same_ring(const RingAddress& a, const RingAddress& b) {
  return a.writer_pid == b.writer_pid && a.ring_id == b.ring_id;
}

// The newest post a reader delivered, and of which ring, so that DDS' copy of
// a sample the ring's mailbox gave first is dropped, even when it comes after
// the reader let go of the ring (closed, or a mail of another type) and
// follows it again: only a different ring starts the count afresh.
class DeliveredPosts {
 public:
  // Whether post `post` of the ring `at` lies in is new to this reader; if
  // so it becomes the newest.
  bool take(const RingAddress& at, uint64_t post) {
    if (!same_ring(at, ring_)) {
      ring_ = at;
      newest_ = 0;
    }
    if (post <= newest_) return false;
    newest_ = post;
    return true;
  }
  uint64_t newest() const { return newest_; }
  const RingAddress& ring() const { return ring_; }

 private:
  RingAddress ring_;
  uint64_t newest_ = 0;
};

// The segment is sparse: only the frames written take memory, reserved
// before a buffer is first handed out for that many bytes, so a full
// /dev/shm means frames on the heap and failed writes (counted), never a
// SIGBUS. Empty when `free_bytes` holds the whole ring, else the warning
// that it may run out and what to change.
std::string shared_memory_shortfall(std::size_t slot_bytes, uint32_t slots, std::size_t free_bytes);

// Whether a writer still has the frame ring file at `path` (its lock on the
// file, which the kernel drops when the process dies, whatever its pid
// namespace): false for a crashed writer's leftover.
bool frame_ring_has_writer(const std::string& path);

// "/saccade_ring_<pid>_<ring id, hex>": the segment's POSIX name.
std::string ring_segment_name(uint32_t writer_pid, uint64_t ring_id);

class SharedSegment;

// The writer's end. Created once per edge; the Mats it handed out may outlive
// it (the segment is unlinked at once, unmapped when the last one is gone).
class FrameRing final : public cv::MatAllocator {
 public:
  static constexpr uint32_t kMaxReaders = 16;
  static constexpr std::size_t kMailBytes = 2048;  // the largest sample the mailbox holds

  // A ring of `slots` buffers of at least `slot_bytes` each, or why the
  // segment cannot be made. `warning`, when given, is set when /dev/shm has
  // less room free than the whole ring (see shared_memory_shortfall): a
  // warning, not an error, the ring is made anyway.
  static Result<std::shared_ptr<FrameRing>> create(std::size_t slot_bytes, uint32_t slots,
                                                   std::string* warning = nullptr);

  // A buffer of `bytes` (one row of CV_8U) for a frame to be copied into;
  // empty when the frame is larger than a buffer or every buffer is held.
  cv::Mat take(std::size_t bytes);
  // Where `mat`'s first byte lies when its buffer is one of this ring's:
  // the buffer's address and the byte's offset in it.
  bool locate(const cv::Mat& mat, RingAddress& at, std::size_t& offset) const;

  // The number the next post() gets (1, 2, ...): put it in the sample first.
  uint64_t next_post() const;
  // Copies `bytes` of `sample` (at most kMailBytes) into the mailbox, replacing
  // what was there, and wakes the readers waiting for it; on a paced stream
  // waits until a woken reader took it, for at most kReaderFirstNs
  // (ReaderFirst, shared_segment.hpp). One thread posts. True when a reader
  // was asleep on the doorbell.
  bool post(const void* sample, std::size_t bytes);
  // Spins until a reader has taken post `post` from the mailbox, or
  // `timeout_ns` pass; false on the timeout (see spin_until_taken in
  // shared_segment.hpp).
  bool wait_until_taken(uint64_t post, int64_t timeout_ns) const;
  // Readers asleep on the doorbell now.
  uint32_t sleeping_readers() const;

  // Readers whose process died keep their pins until the writer notices:
  // take() does, when it finds every buffer held. Returns how many it dropped.
  int release_dead_readers() const;

  const std::string& name() const;
  std::size_t slot_bytes() const { return slot_bytes_; }
  uint32_t slots() const { return slots_; }
  uint32_t writer_pid() const { return pid_; }
  uint64_t ring_id() const { return ring_id_; }
  // Buffers held now by the writer (a live Mat) or by any reader.
  uint32_t held_slots() const;
  // Mats created with this allocator that got heap memory instead (too large,
  // or the ring full): such frames are copied into the ring when written.
  uint64_t heap_fallbacks() const;

  // cv::MatAllocator: a Mat whose `allocator` is this ring gets a free buffer.
  cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step, cv::AccessFlag flags,
                         cv::UMatUsageFlags usage) const override;
  bool allocate(cv::UMatData* data, cv::AccessFlag flags, cv::UMatUsageFlags usage) const override;
  void deallocate(cv::UMatData* data) const override;

  ~FrameRing() override;
  FrameRing(const FrameRing&) = delete;
  FrameRing& operator=(const FrameRing&) = delete;

 private:
  friend struct RingRelease;
  FrameRing() = default;
  int take_slot() const;  // -1 when every buffer is held

  std::unique_ptr<SharedSegment> segment_;
  std::size_t slot_bytes_ = 0;
  uint32_t slots_ = 0;
  uint64_t ring_id_ = 0;
  uint32_t pid_ = 0;
  mutable std::mutex mu_;
  mutable uint32_t next_ = 0;
  mutable uint32_t local_holds_ = 0;  // buffers a Mat of this process holds
  mutable uint64_t heap_fallbacks_ = 0;
  bool retired_ = false;  // its owner let go: deleted when local_holds_ drops to 0
  ReaderFirst reader_first_;
  std::vector<std::unique_ptr<cv::UMatData>> umat_;
  mutable std::vector<std::size_t> reserved_;  // bytes of each buffer given memory (posix_fallocate)
};

class RingMapping;

// The reader's end: maps the writers' rings as their frames arrive.
class RingReader {
 public:
  RingReader() = default;
  ~RingReader();
  RingReader(const RingReader&) = delete;
  RingReader& operator=(const RingReader&) = delete;

  // The frame bytes at `offset` of the buffer `at`, in place, as a rows x
  // cols Mat of `type` (rows packed): the buffer stays pinned until the last
  // header of it is gone. A reader that pins a quarter of the ring already
  // gets a copy instead (counted), so it never starves the writer. An error
  // when the writer's ring cannot be opened, the bytes lie outside the
  // buffer, or the writer has taken the buffer for a newer frame (counted: a
  // lost frame).
  Status view(const RingAddress& at, std::size_t offset, int rows, int cols, int type, cv::Mat& out);

  // The mailbox of the ring `at` lies in (mapped now if it is not) becomes the
  // one mail() and wait_mail() read. An error when it cannot be opened (then
  // no ring is followed).
  Status follow(const RingAddress& at);
  bool following() const { return followed_ != nullptr; }
  // Whether `at` lies in the followed ring.
  bool follows(const RingAddress& at) const;
  // The newest sample posted to the followed ring after post number `after`:
  // copied into `out` (`bytes` of it), its number in `post`. False when there
  // is none (or no ring is followed).
  bool mail(uint64_t after, void* out, std::size_t bytes, uint64_t& post);
  // The number of the followed ring's newest post (0: none, or no ring followed).
  uint64_t newest_post() const;
  // Waits (asleep, or spinning: set_wait) until the followed ring's writer
  // posts after `after`, or `timeout_ns` pass. False at once when no ring is
  // followed or its writer closed it (let go of the ring: a new one comes
  // through DDS).
  bool wait_mail(uint64_t after, int64_t timeout_ns);
  void set_wait(ReaderWait how) { wait_ = how; }
  // Samples mail() gave.
  uint64_t mailed() const { return mailed_; }

  // Rings mapped now (the current writer's, and earlier ones still pinned).
  std::size_t mapped() const { return mappings_.size(); }
  // Frames copied out because this reader held too many buffers.
  uint64_t copied() const { return copied_; }
  // Frames whose buffer the writer had taken again before they were pinned.
  uint64_t overwritten() const { return overwritten_; }

 private:
  // The mapping of the ring `at` lies in, mapped now if it is not; an error
  // when that ring cannot be opened.
  Result<RingMapping*> find_or_open(const RingAddress& at);
  std::vector<RingMapping*> mappings_;
  RingMapping* followed_ = nullptr;  // one of mappings_
  ReaderWait wait_ = ReaderWait::kSleep;
  uint64_t mailed_ = 0;
  uint64_t copied_ = 0;
  uint64_t overwritten_ = 0;
};

}  // namespace saccade::dds
