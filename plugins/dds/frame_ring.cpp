#include "frame_ring.hpp"

#include <fcntl.h>
#include <sched.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>

#include "saccade/message.hpp"
#include "shared_segment.hpp"

namespace saccade::dds {

namespace {

constexpr uint64_t kMagic = 0x676e6972'63636173ull;  // "saccring"
constexpr uint32_t kVersion = 3;                     // 2: the mailbox; 3: its readers say what they took
constexpr uint64_t kWriterBit = 1ull << 31;
constexpr uint64_t kReaderBits = (1ull << FrameRing::kMaxReaders) - 1;
constexpr uint64_t kHoldBits = kWriterBit | kReaderBits;
constexpr std::size_t kPage = 4096;

static_assert(std::atomic<uint64_t>::is_always_lock_free && std::atomic<int32_t>::is_always_lock_free,
              "the ring's state words are shared between processes: they must be lock-free");

uint32_t generation_of(uint64_t state) { return static_cast<uint32_t>(state >> 32); }
uint64_t with_generation(uint32_t generation) { return static_cast<uint64_t>(generation) << 32; }
std::size_t round_up(std::size_t n, std::size_t to) { return (n + to - 1) / to * to; }

struct RingHeader {
  uint64_t magic;
  uint32_t version;
  uint32_t slots;
  uint64_t slot_bytes;
  uint64_t ring_id;
  uint64_t data_offset;
  uint32_t writer_pid;
  uint32_t reserved;
  // 0: free; else the reader's pid as its own pid namespace sees it (for
  // diagnostics: whether it lives is told by its lock, below).
  std::atomic<int32_t> reader_pid[FrameRing::kMaxReaders];
};

// The last sample the writer posted, behind a sequence lock: `sequence` is
// odd while the writer copies it in, twice the post number once it is
// whole. The words are atomics so that a reader racing the writer reads
// stale or mixed words (which the sequence then rejects), never undefined
// behaviour. `doorbell` (the post number's low 32 bits, a futex) wakes
// `waiters`; `closed` says the writer let go of the ring.
struct RingMailbox {
  alignas(64) std::atomic<uint64_t> sequence;
  std::atomic<uint64_t> taken;  // the newest post a reader took
  std::atomic<uint32_t> doorbell;
  std::atomic<uint32_t> waiters;
  std::atomic<uint32_t> closed;
  std::atomic<uint32_t> bytes;
  alignas(64) std::atomic<uint64_t> words[FrameRing::kMailBytes / 8];
};

std::size_t states_offset() { return round_up(sizeof(RingHeader), 64); }
std::size_t mailbox_offset(uint32_t slots) { return round_up(states_offset() + slots * sizeof(uint64_t), 64); }
std::size_t data_offset(uint32_t slots) { return round_up(mailbox_offset(slots) + sizeof(RingMailbox), kPage); }

// Liveness (shared_segment.hpp): each reader locks byte `reader index` of
// the segment and the writer byte kWriterLockByte while they have it mapped.
constexpr off_t kWriterLockByte = FrameRing::kMaxReaders;

// Resets a buffer's OpenCV bookkeeping for its next Mat.
void reset_umat(cv::UMatData& u, uchar* data, std::size_t size, uint32_t slot) {
  u.refcount = 0;
  u.urefcount = 0;
  u.data = u.origdata = data;
  u.size = size;
  u.flags = static_cast<cv::UMatData::MemoryFlag>(0);
  u.handle = nullptr;
  u.userdata = reinterpret_cast<void*>(static_cast<uintptr_t>(slot));
}

uint32_t slot_of(const cv::UMatData* u) { return static_cast<uint32_t>(reinterpret_cast<uintptr_t>(u->userdata)); }

}  // namespace

bool frame_ring_has_writer(const std::string& path) { return file_byte_is_locked(path, kWriterLockByte); }

std::string ring_segment_name(uint32_t writer_pid, uint64_t ring_id) {
  char name[64];
  std::snprintf(name, sizeof name, "/saccade_ring_%u_%016llx", writer_pid, static_cast<unsigned long long>(ring_id));
  return name;
}

namespace {

RingHeader& header_of(const SharedSegment& s) { return *reinterpret_cast<RingHeader*>(s.base()); }
std::atomic<uint64_t>* states_of(const SharedSegment& s) {
  return reinterpret_cast<std::atomic<uint64_t>*>(s.base() + states_offset());
}
RingMailbox& mailbox_of(const SharedSegment& s) {
  return *reinterpret_cast<RingMailbox*>(s.base() + mailbox_offset(header_of(s).slots));
}
uint8_t* slot_data(const SharedSegment& s, uint32_t slot) {
  const RingHeader& h = header_of(s);
  return s.base() + h.data_offset + static_cast<std::size_t>(slot) * h.slot_bytes;
}

}  // namespace

// --- the writer ---

// The owner's shared_ptr lets go through this: the ring is deleted now when
// no Mat holds one of its buffers, else by the last one's deallocate.
struct RingRelease {
  void operator()(FrameRing* ring) const {
    bool last = false;
    {
      std::lock_guard lock(ring->mu_);
      ring->retired_ = true;
      ring->segment_->unlink();  // no reader opens it any more; mapped ones stay valid
      RingMailbox& mail = mailbox_of(*ring->segment_);
      mail.closed.store(1, std::memory_order_seq_cst);
      mail.doorbell.fetch_add(1, std::memory_order_seq_cst);  // its followers go back to DDS now
      futex_wake_all(mail.doorbell);
      last = ring->local_holds_ == 0;
    }
    if (last) delete ring;
  }
};

std::string shared_memory_shortfall(std::size_t slot_bytes, uint32_t slots, std::size_t free_bytes) {
  const std::size_t bytes = slot_bytes * slots;
  if (bytes <= free_bytes) return {};
  return "the frame ring's " + std::to_string(slots) + " buffers of " + std::to_string(slot_bytes >> 20) + " MiB (" +
         std::to_string(bytes >> 20) + " MiB) exceed the " + std::to_string(free_bytes >> 20) +
         " MiB free in /dev/shm: once its frames fill /dev/shm, more frames are written from the heap or fail "
         "(counted); give the edge a capacity near its frames' size (qos=\"capacity=...\"), fewer ring_slots, or "
         "/dev/shm more room (a container's --shm-size)";
}

Result<std::shared_ptr<FrameRing>> FrameRing::create(std::size_t slot_bytes, uint32_t slots, std::string* warning) {
  if (slots == 0 || slot_bytes == 0)
    return Status::error("a frame ring needs at least one buffer of at least one byte");
  slot_bytes = round_up(slot_bytes, kPage);
  std::unique_ptr<FrameRing> ring(new FrameRing());
  ring->slot_bytes_ = slot_bytes;
  ring->slots_ = slots;
  ring->pid_ = static_cast<uint32_t>(::getpid());
  std::random_device entropy;
  ring->ring_id_ = (static_cast<uint64_t>(entropy()) << 32) ^ entropy();
  const std::size_t bytes = data_offset(slots) + slot_bytes * slots;
  struct statvfs shm {};
  if (warning != nullptr && ::statvfs("/dev/shm", &shm) == 0)
    *warning = shared_memory_shortfall(slot_bytes, slots, static_cast<std::size_t>(shm.f_bavail) * shm.f_frsize);
  auto segment = SharedSegment::create(ring_segment_name(ring->pid_, ring->ring_id_), bytes);
  if (!segment.ok()) return segment.status();
  ring->segment_ = std::move(segment).value();
  if (!lock_byte(ring->segment_->fd(), kWriterLockByte))
    return Status::error("cannot lock the frame ring " + ring->segment_->name() + ": " + std::strerror(errno));
  auto* h = new (ring->segment_->base()) RingHeader();
  h->version = kVersion;
  h->slots = slots;
  h->slot_bytes = slot_bytes;
  h->ring_id = ring->ring_id_;
  h->data_offset = data_offset(slots);
  h->writer_pid = ring->pid_;
  for (auto& pid : h->reader_pid) pid.store(0, std::memory_order_relaxed);
  std::atomic<uint64_t>* states = states_of(*ring->segment_);
  for (uint32_t i = 0; i < slots; ++i) new (&states[i]) std::atomic<uint64_t>(0);
  new (ring->segment_->base() + mailbox_offset(slots)) RingMailbox();
  // Readers open the ring only once a DDS sample names it, after all this.
  h->magic = kMagic;
  ring->reserved_.assign(slots, 0);
  ring->umat_.reserve(slots);
  for (uint32_t i = 0; i < slots; ++i) ring->umat_.push_back(std::make_unique<cv::UMatData>(ring.get()));
  return std::shared_ptr<FrameRing>(ring.release(), RingRelease());
}

FrameRing::~FrameRing() = default;

const std::string& FrameRing::name() const { return segment_->name(); }

int FrameRing::take_slot() const {
  std::atomic<uint64_t>* states = states_of(*segment_);
  for (int attempt = 0; attempt < 2; ++attempt) {
    for (uint32_t i = 0; i < slots_; ++i) {
      const uint32_t k = (next_ + i) % slots_;
      uint64_t s = states[k].load(std::memory_order_acquire);
      if ((s & kHoldBits) != 0) continue;
      // A reader pins only the generation it was told: from here on it cannot pin the old frame.
      if (states[k].compare_exchange_strong(s, with_generation(generation_of(s) + 1) | kWriterBit,
                                            std::memory_order_acq_rel)) {
        next_ = (k + 1) % slots_;
        return static_cast<int>(k);
      }
    }
    if (attempt == 0 && release_dead_readers() == 0) break;
  }
  return -1;
}

cv::UMatData* FrameRing::allocate(int dims, const int* sizes, int type, void* data, size_t* step, cv::AccessFlag flags,
                                  cv::UMatUsageFlags usage) const {
  const cv::MatAllocator* heap = cv::Mat::getStdAllocator();
  if (data != nullptr) return heap->allocate(dims, sizes, type, data, step, flags, usage);
  std::size_t total = CV_ELEM_SIZE(type);
  for (int i = dims - 1; i >= 0; --i) {
    if (step != nullptr) step[i] = total;
    total *= static_cast<std::size_t>(sizes[i]);
  }
  std::lock_guard lock(mu_);
  int slot = total <= slot_bytes_ && !retired_ ? take_slot() : -1;
  if (slot >= 0 && total > reserved_[static_cast<std::size_t>(slot)]) {
    const std::size_t offset = header_of(*segment_).data_offset + static_cast<std::size_t>(slot) * slot_bytes_;
    if (segment_->reserve(offset, total)) {
      reserved_[static_cast<std::size_t>(slot)] = total;
    } else {  // /dev/shm is full: this buffer stays free, the frame goes to the heap
      states_of(*segment_)[slot].fetch_and(~kWriterBit, std::memory_order_release);
      slot = -1;
    }
  }
  if (slot < 0) {
    ++heap_fallbacks_;
    return heap->allocate(dims, sizes, type, nullptr, step, flags, usage);
  }
  cv::UMatData* u = umat_[static_cast<std::size_t>(slot)].get();
  reset_umat(*u, slot_data(*segment_, static_cast<uint32_t>(slot)), total, static_cast<uint32_t>(slot));
  ++local_holds_;
  return u;
}

bool FrameRing::allocate(cv::UMatData*, cv::AccessFlag, cv::UMatUsageFlags) const { return false; }

void FrameRing::deallocate(cv::UMatData* u) const {
  bool last = false;
  {
    std::lock_guard lock(mu_);
    const uint32_t slot = slot_of(u);
    // The frame stays readable until the writer takes this buffer again.
    states_of(*segment_)[slot].fetch_and(~kWriterBit, std::memory_order_release);
    reset_umat(*u, nullptr, 0, slot);
    last = --local_holds_ == 0 && retired_;
  }
  if (last) delete this;
}

cv::Mat FrameRing::take(std::size_t bytes) {
  if (bytes == 0 || bytes > slot_bytes_) return {};
  cv::Mat buffer;
  buffer.allocator = this;
  buffer.create(1, static_cast<int>(bytes), CV_8U);
  if (buffer.u == nullptr || buffer.u->currAllocator != this) return {};  // every buffer held
  return buffer;
}

bool FrameRing::locate(const cv::Mat& mat, RingAddress& at, std::size_t& offset) const {
  if (mat.u == nullptr || mat.u->currAllocator != this || mat.data == nullptr) return false;
  const uint32_t slot = slot_of(mat.u);
  at.writer_pid = pid_;
  at.ring_id = ring_id_;
  at.slot = slot;
  // The writer holds the buffer (mat is alive): its generation cannot change.
  at.generation = generation_of(states_of(*segment_)[slot].load(std::memory_order_acquire));
  offset = static_cast<std::size_t>(mat.data - slot_data(*segment_, slot));
  return true;
}

uint64_t FrameRing::next_post() const { return mailbox_of(*segment_).sequence.load(std::memory_order_relaxed) / 2 + 1; }

bool FrameRing::post(const void* sample, std::size_t bytes) {
  RingMailbox& mail = mailbox_of(*segment_);
  bytes = std::min(bytes, kMailBytes);
  uint64_t words[kMailBytes / 8];
  const std::size_t n = (bytes + 7) / 8;
  words[n - 1] = 0;
  std::memcpy(words, sample, bytes);
  const uint64_t sequence = mail.sequence.load(std::memory_order_relaxed);
  // Release stores instead of a fence (TSan has no fences; on x86 both are
  // plain moves): a reader that sees any new word sees the odd sequence too.
  mail.sequence.store(sequence + 1, std::memory_order_relaxed);
  for (std::size_t i = 0; i < n; ++i) mail.words[i].store(words[i], std::memory_order_release);
  mail.bytes.store(static_cast<uint32_t>(bytes), std::memory_order_release);
  mail.sequence.store(sequence + 2, std::memory_order_release);
  // seq_cst with the waiters' count: a reader either sees the new doorbell
  // before it sleeps, or counted itself before this looks (no lost wake-up).
  mail.doorbell.store(static_cast<uint32_t>(sequence / 2 + 1), std::memory_order_seq_cst);
  const bool woke = mail.waiters.load(std::memory_order_seq_cst) != 0;
  if (woke) futex_wake_all(mail.doorbell);
  reader_first_.settle(woke, mail.taken, sequence / 2 + 1);
  return woke;
}

uint32_t FrameRing::sleeping_readers() const { return mailbox_of(*segment_).waiters.load(std::memory_order_seq_cst); }

bool FrameRing::wait_until_taken(uint64_t post, int64_t timeout_ns) const {
  return spin_until_taken(mailbox_of(*segment_).taken, post, timeout_ns);
}

int FrameRing::release_dead_readers() const {
  RingHeader& h = header_of(*segment_);
  std::atomic<uint64_t>* states = states_of(*segment_);
  int released = 0;
  for (uint32_t r = 0; r < kMaxReaders; ++r) {
    int32_t pid = h.reader_pid[r].load(std::memory_order_acquire);
    if (pid == 0 || byte_is_locked(segment_->fd(), static_cast<off_t>(r))) continue;
    for (uint32_t i = 0; i < slots_; ++i) states[i].fetch_and(~(1ull << r), std::memory_order_acq_rel);
    // Only now may another reader register here: its pins cannot be cleared above.
    if (h.reader_pid[r].compare_exchange_strong(pid, 0)) ++released;
  }
  return released;
}

uint32_t FrameRing::held_slots() const {
  uint32_t held = 0;
  for (uint32_t i = 0; i < slots_; ++i)
    if ((states_of(*segment_)[i].load(std::memory_order_acquire) & kHoldBits) != 0) ++held;
  return held;
}

uint64_t FrameRing::heap_fallbacks() const {
  std::lock_guard lock(mu_);
  return heap_fallbacks_;
}

// --- the reader ---

// One writer's ring as a reader maps it, registered under one reader bit.
// Deleted once its RingReader has let go and no Mat pins a buffer of it.
class RingMapping final : public cv::MatAllocator {
 public:
  // The writer's ring `at` lies in, mapped and registered as one of its
  // readers; an error when it cannot be opened, is not a ring this version
  // wrote, or has all its readers.
  static Result<RingMapping*> open(const RingAddress& at) {
    const std::string name = ring_segment_name(at.writer_pid, at.ring_id);
    auto opened = SharedSegment::open(name, sizeof(RingHeader), "the writer's frame ring");
    if (!opened.ok()) return opened.status();
    std::unique_ptr<SharedSegment> segment = std::move(opened).value();
    RingHeader& h = header_of(*segment);
    if (h.magic != kMagic || h.version != kVersion || h.ring_id != at.ring_id || h.slots == 0 ||
        h.data_offset != data_offset(h.slots) || h.data_offset + h.slot_bytes * h.slots > segment->bytes())
      return Status::error("the frame ring " + name + " is not one this version of saccade wrote");
    const auto pid = static_cast<int32_t>(::getpid());
    for (uint32_t r = 0; r < FrameRing::kMaxReaders; ++r) {
      // The lock first: a registered reader always holds it, so the writer
      // never takes one between the two for dead.
      if (!lock_byte(segment->fd(), static_cast<off_t>(r))) continue;
      int32_t expected = 0;
      if (!h.reader_pid[r].compare_exchange_strong(expected, pid)) {
        unlock_byte(segment->fd(), static_cast<off_t>(r));  // a dead reader's, not yet cleared
        continue;
      }
      auto* m = new RingMapping();
      m->segment_ = std::move(segment);
      m->bit_ = 1ull << r;
      m->index_ = r;
      m->at_ = at;
      m->pinned_generation_.assign(h.slots, 0);
      m->pinned_.assign(h.slots, false);
      m->max_pins_ = std::max<uint32_t>(1, h.slots / 4);
      for (uint32_t i = 0; i < h.slots; ++i) m->umat_.push_back(std::make_unique<cv::UMatData>(m));
      return m;
    }
    return Status::error("the frame ring " + name + " has " + std::to_string(FrameRing::kMaxReaders) +
                         " readers already");
  }

  bool same_ring(const RingAddress& at) const { return dds::same_ring(at, at_); }
  RingMailbox& mailbox() const { return mailbox_of(*segment_); }

  // The frame at `offset` of buffer at.slot into `out` (see
  // RingReader::view); an error when it lies outside the buffer or the
  // writer took the buffer again (`overwritten` set). `copied`: the frame
  // was copied out rather than pinned.
  Status pin(const RingAddress& at, std::size_t offset, int rows, int cols, int type, cv::Mat& out, bool& overwritten,
             bool& copied) {
    const RingHeader& h = header_of(*segment_);
    const std::size_t bytes = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type);
    if (at.slot >= h.slots || offset > h.slot_bytes || bytes > h.slot_bytes - offset)
      return Status::error("a frame outside the writer's ring (buffer " + std::to_string(at.slot) + ", bytes " +
                           std::to_string(offset) + ".." + std::to_string(offset + bytes) + " of " +
                           std::to_string(h.slot_bytes) + ")");
    out.release();  // before the lock: it may be a Mat of this ring, whose release locks it
    std::lock_guard lock(mu_);
    cv::UMatData* u = umat_[at.slot].get();
    if (pinned_[at.slot]) {
      // Pinned already (another part of the same frame, or the same frame
      // again while its last Mat is being released: deallocate then sees the
      // new reference and keeps the pin). The writer cannot have taken it.
      if (pinned_generation_[at.slot] != at.generation) {
        overwritten = true;
        return Status::error("the writer reused the frame's buffer before it was read");
      }
    } else {
      std::atomic<uint64_t>& state = states_of(*segment_)[at.slot];
      uint64_t s = state.load(std::memory_order_acquire);
      do {
        if (generation_of(s) != at.generation) {
          overwritten = true;
          return Status::error("the writer reused the frame's buffer before it was read (its ring of " +
                               std::to_string(h.slots) + " buffers went round)");
        }
      } while (!state.compare_exchange_weak(s, s | bit_, std::memory_order_acq_rel));
      if (pins_ >= max_pins_) {
        // A graph that keeps many frames (a recorder, a long queue) would hold
        // the writer's ring: past a quarter of it, frames are copied out.
        cv::Mat copy(rows, cols, type);
        std::memcpy(copy.data, slot_data(*segment_, at.slot) + offset, bytes);
        state.fetch_and(~bit_, std::memory_order_release);
        out = std::move(copy);
        copied = true;
        return {};
      }
      reset_umat(*u, slot_data(*segment_, at.slot), h.slot_bytes, at.slot);
      pinned_generation_[at.slot] = at.generation;
      pinned_[at.slot] = true;
      ++pins_;
    }
    out = view_of_buffer(u, slot_data(*segment_, at.slot) + offset, {cols, rows}, type);
    return {};
  }

  // Its RingReader let go: gone now when nothing is pinned, else with the last pin.
  void retire() {
    bool idle = false;
    {
      std::lock_guard lock(mu_);
      retired_ = true;
      idle = pins_ == 0;
    }
    if (idle) delete this;
  }
  bool idle() const {
    std::lock_guard lock(mu_);
    return pins_ == 0;
  }

  cv::UMatData* allocate(int, const int*, int, void*, size_t*, cv::AccessFlag, cv::UMatUsageFlags) const override {
    return nullptr;  // a reader's Mats are never created here, only viewed
  }
  bool allocate(cv::UMatData*, cv::AccessFlag, cv::UMatUsageFlags) const override { return false; }
  void deallocate(cv::UMatData* u) const override {
    bool last = false;
    {
      std::lock_guard lock(mu_);
      if (u->refcount != 0) return;  // pinned again meanwhile (see pin)
      const uint32_t slot = slot_of(u);
      states_of(*segment_)[slot].fetch_and(~bit_, std::memory_order_release);
      reset_umat(*u, nullptr, 0, slot);
      pinned_[slot] = false;
      last = --pins_ == 0 && retired_;
    }
    if (last) delete this;
  }

  ~RingMapping() override { header_of(*segment_).reader_pid[index_].store(0, std::memory_order_release); }

 private:
  RingMapping() = default;
  std::unique_ptr<SharedSegment> segment_;
  uint64_t bit_ = 0;
  uint32_t index_ = 0;
  RingAddress at_;
  mutable std::mutex mu_;
  mutable uint32_t pins_ = 0;
  uint32_t max_pins_ = 1;
  bool retired_ = false;
  std::vector<uint32_t> pinned_generation_;
  mutable std::vector<bool> pinned_;
  std::vector<std::unique_ptr<cv::UMatData>> umat_;
};

RingReader::~RingReader() {
  for (RingMapping* m : mappings_) m->retire();
}

Result<RingMapping*> RingReader::find_or_open(const RingAddress& at) {
  for (RingMapping* m : mappings_)
    if (m->same_ring(at)) return m;
  // A new writer (the old one restarted): earlier rings go once nothing pins them.
  for (auto it = mappings_.begin(); it != mappings_.end();) {
    if ((*it)->idle()) {
      if (*it == followed_) followed_ = nullptr;
      (*it)->retire();
      it = mappings_.erase(it);
    } else {
      ++it;
    }
  }
  Result<RingMapping*> m = RingMapping::open(at);
  if (m.ok()) mappings_.push_back(*m);
  return m;
}

Status RingReader::view(const RingAddress& at, std::size_t offset, int rows, int cols, int type, cv::Mat& out) {
  Result<RingMapping*> m = find_or_open(at);
  if (!m.ok()) return m.status();
  bool overwritten = false, copied = false;
  Status pinned = (*m)->pin(at, offset, rows, cols, type, out, overwritten, copied);
  overwritten_ += overwritten ? 1 : 0;
  copied_ += copied ? 1 : 0;
  return pinned;
}

Status RingReader::follow(const RingAddress& at) {
  Result<RingMapping*> m = find_or_open(at);
  followed_ = m.ok() ? *m : nullptr;
  return m.status();
}

bool RingReader::follows(const RingAddress& at) const { return followed_ != nullptr && followed_->same_ring(at); }

bool RingReader::mail(uint64_t after, void* out, std::size_t bytes, uint64_t& post) {
  if (followed_ == nullptr) return false;
  RingMailbox& mail = followed_->mailbox();
  uint64_t words[FrameRing::kMailBytes / 8];
  const std::size_t n = (std::min(bytes, FrameRing::kMailBytes) + 7) / 8;
  // The writer copies a sample in well under a microsecond: wait that out,
  // but never for a writer that died in the middle of a post (~1 ms at most).
  for (int attempt = 0; attempt < 20000; ++attempt) {
    const uint64_t sequence = mail.sequence.load(std::memory_order_acquire);
    if (sequence / 2 <= after) return false;
    if (sequence & 1) {
      if (attempt >= 1000)
        sched_yield();
      else
        cpu_relax();
      continue;
    }
    // Acquire loads: the sequence is read again only after them.
    for (std::size_t i = 0; i < n; ++i) words[i] = mail.words[i].load(std::memory_order_acquire);
    const uint32_t posted_bytes = mail.bytes.load(std::memory_order_acquire);
    if (mail.sequence.load(std::memory_order_relaxed) != sequence) continue;
    if (posted_bytes != bytes) {  // not the sample type this reader reads: DDS only
      followed_ = nullptr;
      return false;
    }
    std::memcpy(out, words, bytes);
    post = sequence / 2;
    mark_taken(mail.taken, post);
    ++mailed_;
    return true;
  }
  return false;
}

uint64_t RingReader::newest_post() const {
  return followed_ == nullptr ? 0 : followed_->mailbox().sequence.load(std::memory_order_acquire) / 2;
}

bool RingReader::wait_mail(uint64_t after, int64_t timeout_ns) {
  if (followed_ == nullptr) return false;
  RingMailbox& mail = followed_->mailbox();
  mail.waiters.fetch_add(1, std::memory_order_seq_cst);
  const uint32_t doorbell = mail.doorbell.load(std::memory_order_seq_cst);
  if (mail.closed.load(std::memory_order_seq_cst) == 0 && doorbell == static_cast<uint32_t>(after))
    wait_for_doorbell(mail.doorbell, doorbell, mail.closed, timeout_ns, wait_);
  mail.waiters.fetch_sub(1, std::memory_order_seq_cst);
  const bool closed = mail.closed.load(std::memory_order_seq_cst) != 0;
  if (closed) followed_ = nullptr;
  return !closed;
}

}  // namespace saccade::dds
