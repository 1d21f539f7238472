#include "mailbox.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>

#include "shared_segment.hpp"

namespace saccade::dds {

namespace {

constexpr uint64_t kMagic = 0x6c69616d'63636173ull;  // "saccmail"
constexpr uint32_t kVersion = 1;
constexpr off_t kWriterLockByte = 0;

std::size_t round_up(std::size_t n, std::size_t to) { return (n + to - 1) / to * to; }

struct MailHeader {
  uint64_t magic;
  uint32_t version;
  uint32_t slots;
  uint64_t slot_bytes;
  uint64_t id;
  uint32_t writer_pid;
  uint32_t reserved;
  // The newest whole post; `doorbell` (its low 32 bits, a futex) wakes
  // `waiters`; `closed` says the writer let go of the mailbox.
  alignas(64) std::atomic<uint64_t> newest;
  std::atomic<uint64_t> taken;  // the newest post a reader read
  std::atomic<uint32_t> doorbell;
  std::atomic<uint32_t> waiters;
  std::atomic<uint32_t> closed;
};

// A slot: its sequence, the message's byte count (or Mailbox::kInDds), then
// the bytes in 64-bit words.
struct SlotHead {
  std::atomic<uint64_t> sequence;
  std::atomic<uint64_t> bytes;
};

static_assert(std::atomic<uint64_t>::is_always_lock_free, "the mailbox's words are shared between processes");

std::size_t slots_offset() { return round_up(sizeof(MailHeader), 64); }
std::size_t slot_stride(std::size_t slot_bytes) { return round_up(sizeof(SlotHead) + slot_bytes, 64); }
std::size_t segment_bytes(std::size_t slot_bytes, uint32_t slots) {
  return slots_offset() + slot_stride(slot_bytes) * slots;
}

MailHeader& header_of(const SharedSegment& s) { return *reinterpret_cast<MailHeader*>(s.base()); }
uint8_t* slot_of(const SharedSegment& s, uint64_t post) {
  const MailHeader& h = header_of(s);
  return s.base() + slots_offset() + static_cast<std::size_t>((post - 1) % h.slots) * slot_stride(h.slot_bytes);
}
SlotHead& head_of(uint8_t* slot) { return *reinterpret_cast<SlotHead*>(slot); }
uint64_t* words_of(uint8_t* slot) { return reinterpret_cast<uint64_t*>(slot + sizeof(SlotHead)); }

}  // namespace

std::string mailbox_segment_name(uint64_t id) {
  char name[48];
  std::snprintf(name, sizeof name, "/saccade_mail_%016llx", static_cast<unsigned long long>(id));
  return name;
}

bool mailbox_has_writer(const std::string& path) { return file_byte_is_locked(path, kWriterLockByte); }

// --- the writer ---

Result<std::unique_ptr<Mailbox>> Mailbox::create(std::size_t slot_bytes, uint32_t slots) {
  if (slots == 0 || slot_bytes == 0) return Status::error("a mailbox needs at least one slot of at least one byte");
  slot_bytes = round_up(slot_bytes, 8);
  std::unique_ptr<Mailbox> box(new Mailbox());
  std::random_device entropy;
  do box->id_ = (static_cast<uint64_t>(entropy()) << 32) ^ entropy();
  while (box->id_ == 0);
  box->slot_bytes_ = slot_bytes;
  box->slots_ = slots;
  auto segment = SharedSegment::create(mailbox_segment_name(box->id_), segment_bytes(slot_bytes, slots));
  if (!segment.ok()) return segment.status();
  box->segment_ = std::move(segment).value();
  if (!lock_byte(box->segment_->fd(), kWriterLockByte))
    return Status::error("cannot lock the mailbox " + box->segment_->name() + ": " + std::strerror(errno));
  auto* h = new (box->segment_->base()) MailHeader();
  h->version = kVersion;
  h->slots = slots;
  h->slot_bytes = slot_bytes;
  h->id = box->id_;
  h->writer_pid = static_cast<uint32_t>(::getpid());
  h->newest.store(0, std::memory_order_relaxed);
  h->taken.store(0, std::memory_order_relaxed);
  h->doorbell.store(0, std::memory_order_relaxed);
  h->waiters.store(0, std::memory_order_relaxed);
  h->closed.store(0, std::memory_order_relaxed);
  for (uint64_t post = 1; post <= slots; ++post) {
    auto* head = new (slot_of(*box->segment_, post)) SlotHead();
    head->sequence.store(0, std::memory_order_relaxed);
    head->bytes.store(0, std::memory_order_relaxed);
  }
  // Readers open the mailbox only once a DDS sample names it, after all this.
  h->magic = kMagic;
  return box;
}

Mailbox::~Mailbox() {
  if (!segment_) return;
  MailHeader& h = header_of(*segment_);
  h.closed.store(1, std::memory_order_seq_cst);
  h.doorbell.fetch_add(1, std::memory_order_seq_cst);  // its readers go back to DDS now
  futex_wake_all(h.doorbell);
}

bool Mailbox::post(const void* data, std::size_t bytes) {
  const uint64_t post = next_++;
  uint8_t* slot = slot_of(*segment_, post);
  SlotHead& head = head_of(slot);
  const bool fits = bytes <= slot_bytes_;
  // Release stores instead of a fence (TSan has no fences; on x86 both are
  // plain moves): a reader that sees any new word sees the odd sequence too.
  head.sequence.store(2 * post - 1, std::memory_order_relaxed);
  if (fits) {
    uint64_t* words = words_of(slot);
    const auto* in = static_cast<const uint8_t*>(data);
    for (std::size_t i = 0; i * 8 < bytes; ++i) {
      uint64_t word = 0;
      std::memcpy(&word, in + i * 8, std::min<std::size_t>(8, bytes - i * 8));
      std::atomic_ref<uint64_t>(words[i]).store(word, std::memory_order_release);
    }
  }
  head.bytes.store(fits ? bytes : kInDds, std::memory_order_release);
  head.sequence.store(2 * post, std::memory_order_release);
  MailHeader& h = header_of(*segment_);
  h.newest.store(post, std::memory_order_release);
  // seq_cst with the waiters' count: a reader either sees the new doorbell
  // before it sleeps, or counted itself before this looks (no lost wake-up).
  h.doorbell.store(static_cast<uint32_t>(post), std::memory_order_seq_cst);
  const bool woke = h.waiters.load(std::memory_order_seq_cst) != 0;
  if (woke) futex_wake_all(h.doorbell);
  // A message only in DDS is never marked taken: nobody to wait for.
  if (fits) reader_first_.settle(woke, h.taken, post);
  return woke;
}

uint32_t Mailbox::sleeping_readers() const { return header_of(*segment_).waiters.load(std::memory_order_seq_cst); }

bool Mailbox::wait_until_taken(uint64_t post, int64_t timeout_ns) const {
  return spin_until_taken(header_of(*segment_).taken, post, timeout_ns);
}

// --- the reader ---

MailboxReader::MailboxReader() = default;
MailboxReader::~MailboxReader() = default;

Status MailboxReader::follow(uint64_t id) {
  segment_.reset();
  id_ = 0;
  const std::string name = mailbox_segment_name(id);
  auto opened = SharedSegment::open(name, sizeof(MailHeader), "the writer's mailbox");
  if (!opened.ok()) return opened.status();
  std::unique_ptr<SharedSegment> segment = std::move(opened).value();
  const MailHeader& h = header_of(*segment);
  if (h.magic != kMagic || h.version != kVersion || h.id != id || h.slots == 0 || h.slot_bytes % 8 != 0 ||
      segment_bytes(h.slot_bytes, h.slots) > segment->bytes())
    return Status::error("the mailbox " + name + " is not one this version of saccade wrote");
  segment_ = std::move(segment);
  id_ = id;
  return {};
}

bool MailboxReader::open() const {
  return segment_ != nullptr && header_of(*segment_).closed.load(std::memory_order_acquire) == 0;
}

bool MailboxReader::writer_alive() const {
  return segment_ != nullptr && byte_is_locked(segment_->fd(), kWriterLockByte);
}

uint64_t MailboxReader::newest() const {
  return segment_ == nullptr ? 0 : header_of(*segment_).newest.load(std::memory_order_acquire);
}

MailboxReader::Read MailboxReader::read(uint64_t post, std::vector<uint8_t>& out) {
  if (segment_ == nullptr || post == 0) return Read::kNotYet;
  const std::size_t slot_bytes = header_of(*segment_).slot_bytes;
  uint8_t* slot = slot_of(*segment_, post);
  SlotHead& head = head_of(slot);
  uint64_t* words = words_of(slot);
  // The writer copies a message in well under a microsecond: wait that out,
  // but never for a writer that died in the middle of a post (~1 ms at most).
  for (int attempt = 0; attempt < 20000; ++attempt) {
    const uint64_t sequence = head.sequence.load(std::memory_order_acquire);
    if (sequence == 2 * post - 1) {
      if (attempt >= 1000)
        sched_yield();
      else
        cpu_relax();
      continue;
    }
    if (sequence < 2 * post - 1) return Read::kNotYet;
    if (sequence > 2 * post) return Read::kOverwritten;
    const uint64_t bytes = head.bytes.load(std::memory_order_acquire);
    if (bytes == Mailbox::kInDds) {
      return head.sequence.load(std::memory_order_relaxed) == sequence ? Read::kInDds : Read::kOverwritten;
    }
    if (bytes > slot_bytes) continue;  // mixed words: the sequence has moved on
    out.resize(round_up(bytes, 8));
    // Acquire loads: the sequence is read again only after them.
    for (std::size_t i = 0; i * 8 < bytes; ++i) {
      const uint64_t word = std::atomic_ref<uint64_t>(words[i]).load(std::memory_order_acquire);
      std::memcpy(out.data() + i * 8, &word, 8);
    }
    if (head.sequence.load(std::memory_order_relaxed) != sequence) return Read::kOverwritten;
    out.resize(bytes);
    mark_taken(header_of(*segment_).taken, post);
    return Read::kMessage;
  }
  return Read::kNotYet;
}

bool MailboxReader::wait(uint64_t after, int64_t timeout_ns) {
  if (segment_ == nullptr) return false;
  MailHeader& h = header_of(*segment_);
  h.waiters.fetch_add(1, std::memory_order_seq_cst);
  const uint32_t doorbell = h.doorbell.load(std::memory_order_seq_cst);
  if (h.closed.load(std::memory_order_seq_cst) == 0 && doorbell == static_cast<uint32_t>(after))
    wait_for_doorbell(h.doorbell, doorbell, h.closed, timeout_ns, wait_);
  h.waiters.fetch_sub(1, std::memory_order_seq_cst);
  return h.closed.load(std::memory_order_seq_cst) == 0;
}

}  // namespace saccade::dds
