#pragma once
// A same-host mailbox for serialised messages: the writer of a DDS edge posts
// each message's serialised bytes into numbered slots in shared memory and
// wakes its readers through a futex there, so a reader on the same host is
// woken once, by the writer itself, instead of through Fast DDS' receive
// thread and then its own (two thread hand-offs, most of a small message's
// latency). DDS still carries every message; the sample names the mailbox
// and the message's post number (common::Stamp), so a reader follows the
// mailbox its first sample names and drops the DDS copies of what it read
// there. The frame ring's mailbox does this for images (one slot: the newest
// frame); here a reliable reader reads every post in order, from the slots
// while it keeps up and from DDS when it fell more than a ring behind.
//
// Each slot is behind a sequence lock (odd while the writer copies in, twice
// the post number once whole), in atomic words, so that a reader racing the
// writer reads stale or mixed words that the sequence then rejects, never
// undefined behaviour.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "saccade/status.hpp"
#include "shared_segment.hpp"

namespace saccade::dds {

// "/saccade_mail_<id, hex>": the segment's POSIX name.
std::string mailbox_segment_name(uint64_t id);
// Whether a writer still has the mailbox file at `path` (its lock): false for
// a crashed writer's leftover.
bool mailbox_has_writer(const std::string& path);

class Mailbox {
 public:
  // Marks a post whose message was too large for a slot: read it from DDS.
  static constexpr uint32_t kInDds = 0xffffffffu;

  // `slots` slots of at least `slot_bytes` bytes, or why the segment cannot
  // be made.
  static Result<std::unique_ptr<Mailbox>> create(std::size_t slot_bytes, uint32_t slots);
  // Closes it: its readers go back to DDS.
  ~Mailbox();
  Mailbox(const Mailbox&) = delete;
  Mailbox& operator=(const Mailbox&) = delete;

  uint64_t id() const { return id_; }
  std::size_t slot_bytes() const { return slot_bytes_; }
  uint32_t slots() const { return slots_; }
  // The number the next post gets (1, 2, ...): put it in the DDS sample first.
  uint64_t next_post() const { return next_; }
  // Copies `bytes` into the next post's slot and wakes the readers; on a
  // paced stream waits until a woken reader read it, for at most
  // kReaderFirstNs (ReaderFirst, shared_segment.hpp). A message larger than
  // a slot is posted as kInDds (its readers take it from DDS; nobody waits).
  // One thread posts. True when a reader was asleep on the doorbell.
  bool post(const void* data, std::size_t bytes);
  // Spins until a reader has read post `post`, or `timeout_ns` pass (see
  // spin_until_taken in shared_segment.hpp); false on the timeout.
  bool wait_until_taken(uint64_t post, int64_t timeout_ns) const;
  // Readers asleep on the doorbell now.
  uint32_t sleeping_readers() const;

 private:
  Mailbox() = default;
  std::unique_ptr<SharedSegment> segment_;
  uint64_t id_ = 0;
  std::size_t slot_bytes_ = 0;
  uint32_t slots_ = 0;
  uint64_t next_ = 1;
  ReaderFirst reader_first_;
};

// The reader's end: one writer's mailbox at a time.
class MailboxReader {
 public:
  MailboxReader();
  ~MailboxReader();
  MailboxReader(const MailboxReader&) = delete;
  MailboxReader& operator=(const MailboxReader&) = delete;

  // Maps the mailbox `id` and reads it from now on. An error when it cannot
  // be opened (another host's writer, or a writer gone): then nothing is
  // followed.
  Status follow(uint64_t id);
  // Whether a mailbox is followed and its writer has not closed it.
  bool open() const;
  uint64_t id() const { return id_; }
  // Whether the followed mailbox's writer process is alive (its lock).
  bool writer_alive() const;
  // The newest whole post (0: none, or nothing followed).
  uint64_t newest() const;

  enum class Read {
    kMessage,      // `out` holds the post's bytes
    kInDds,        // the post is there, but its message only in DDS
    kNotYet,       // not posted yet (or the writer died in the middle of it)
    kOverwritten,  // the writer has used the slot again: the post is gone
  };
  Read read(uint64_t post, std::vector<uint8_t>& out);
  // Waits (asleep, or spinning: set_wait) until the writer posts after
  // `after`, or `timeout_ns` pass. False at once when nothing is followed or
  // its writer closed the mailbox.
  bool wait(uint64_t after, int64_t timeout_ns);
  void set_wait(ReaderWait how) { wait_ = how; }

 private:
  std::unique_ptr<SharedSegment> segment_;
  uint64_t id_ = 0;
  ReaderWait wait_ = ReaderWait::kSleep;
};

}  // namespace saccade::dds
