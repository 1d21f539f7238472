#include "shared_segment.hpp"

#include "saccade/node.hpp"

#include <fcntl.h>
#include <sched.h>
#include <linux/futex.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>
#include <ctime>

namespace saccade::dds {

static_assert(std::atomic<uint32_t>::is_always_lock_free && sizeof(std::atomic<uint32_t>) == sizeof(uint32_t),
              "a futex is a plain 32-bit word");

namespace {

// `what` failed, with errno's reason.
Status system_error(const std::string& what) { return Status::error(what + ": " + std::strerror(errno)); }

struct flock one_byte(short type, off_t at) {
  struct flock lock {};
  lock.l_type = type;
  lock.l_whence = SEEK_SET;
  lock.l_start = at;
  lock.l_len = 1;
  return lock;
}

}  // namespace

Result<std::unique_ptr<SharedSegment>> SharedSegment::create(const std::string& name, std::size_t bytes) {
  int fd = ::shm_open(name.c_str(), O_CREAT | O_EXCL | O_RDWR | O_CLOEXEC, 0600);
  if (fd < 0) return system_error("cannot create shared memory " + name);
  if (::ftruncate(fd, static_cast<off_t>(bytes)) != 0) {
    Status failed = system_error("cannot size shared memory " + name + " to " + std::to_string(bytes) + " bytes");
    ::close(fd);
    ::shm_unlink(name.c_str());
    return failed;
  }
  auto s = map(fd, name, bytes);
  if (s.ok())
    (*s)->linked_ = true;
  else
    ::shm_unlink(name.c_str());
  return s;
}

Result<std::unique_ptr<SharedSegment>> SharedSegment::open(const std::string& name, std::size_t min_bytes,
                                                           const std::string& what) {
  int fd = ::shm_open(name.c_str(), O_RDWR | O_CLOEXEC, 0);
  if (fd < 0) return system_error("cannot open " + what + " " + name);
  struct stat st {};
  if (::fstat(fd, &st) != 0 || st.st_size < static_cast<off_t>(min_bytes)) {
    ::close(fd);
    return Status::error(what + " " + name + " is too small to be one");
  }
  return map(fd, name, static_cast<std::size_t>(st.st_size));
}

Result<std::unique_ptr<SharedSegment>> SharedSegment::map(int fd, const std::string& name, std::size_t bytes) {
  void* base = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (base == MAP_FAILED) {
    Status failed = system_error("cannot map shared memory " + name);
    ::close(fd);
    return failed;
  }
  auto s = std::unique_ptr<SharedSegment>(new SharedSegment());
  s->fd_ = fd;
  s->base_ = static_cast<uint8_t*>(base);
  s->bytes_ = bytes;
  s->name_ = name;
  return s;
}

SharedSegment::~SharedSegment() {
  unlink();
  ::munmap(base_, bytes_);
  ::close(fd_);
}

bool SharedSegment::reserve(std::size_t offset, std::size_t bytes) {
  return ::posix_fallocate(fd_, static_cast<off_t>(offset), static_cast<off_t>(bytes)) == 0;
}

void SharedSegment::unlink() {
  if (linked_) ::shm_unlink(name_.c_str());
  linked_ = false;
}

long futex_wait(std::atomic<uint32_t>& word, uint32_t expected, int64_t timeout_ns) {
  timespec timeout{static_cast<time_t>(timeout_ns / 1'000'000'000), static_cast<long>(timeout_ns % 1'000'000'000)};
  return ::syscall(SYS_futex, reinterpret_cast<uint32_t*>(&word), FUTEX_WAIT, expected, &timeout, nullptr, 0);
}

void wait_for_doorbell(std::atomic<uint32_t>& word, uint32_t value, const std::atomic<uint32_t>& closed,
                       int64_t timeout_ns, ReaderWait how) {
  if (how == ReaderWait::kSleep) {
    futex_wait(word, value, std::max<int64_t>(timeout_ns, 1));
    return;
  }
  const int64_t deadline = steady_now_ns() + timeout_ns;
  for (unsigned i = 0;; ++i) {
    if (word.load(std::memory_order_acquire) != value || closed.load(std::memory_order_acquire) != 0) return;
    // The clock every 256 pauses (a few microseconds): a timeout that late is still a timeout.
    if ((i & 255u) == 0 && steady_now_ns() >= deadline) return;
    cpu_relax();
  }
}

void futex_wake_all(std::atomic<uint32_t>& word) {
  ::syscall(SYS_futex, reinterpret_cast<uint32_t*>(&word), FUTEX_WAKE, INT32_MAX, nullptr, nullptr, 0);
}

void mark_taken(std::atomic<uint64_t>& taken, uint64_t post) {
  uint64_t seen = taken.load(std::memory_order_relaxed);
  while (seen < post && !taken.compare_exchange_weak(seen, post, std::memory_order_release)) {}
}

bool ReaderFirst::wait_for(bool woke, int64_t now_ns) {
  constexpr int64_t kPacedGapNs = 1'000'000;
  const bool paced = now_ns - last_post_ns_ >= kPacedGapNs;
  last_post_ns_ = now_ns;
  return woke && paced;
}

void ReaderFirst::settle(bool woke, const std::atomic<uint64_t>& taken, uint64_t post) {
  if (wait_for(woke, steady_now_ns())) spin_until_taken(taken, post, kReaderFirstNs);
}

bool spin_until_taken(const std::atomic<uint64_t>& taken, uint64_t post, int64_t timeout_ns) {
  const int64_t deadline = steady_now_ns() + timeout_ns;
  for (;;) {
    if (taken.load(std::memory_order_acquire) >= post) return true;
    // The reader woken may be queued on this core: let it run.
    ::sched_yield();
    if (steady_now_ns() >= deadline) return false;
  }
}

bool lock_byte(int fd, off_t at) {
  struct flock lock = one_byte(F_WRLCK, at);
  return ::fcntl(fd, F_OFD_SETLK, &lock) == 0;
}

void unlock_byte(int fd, off_t at) {
  struct flock lock = one_byte(F_UNLCK, at);
  ::fcntl(fd, F_OFD_SETLK, &lock);
}

bool byte_is_locked(int fd, off_t at) {
  struct flock lock = one_byte(F_WRLCK, at);
  if (::fcntl(fd, F_OFD_GETLK, &lock) != 0) return true;  // cannot tell: assume alive
  return lock.l_type != F_UNLCK;
}

bool file_byte_is_locked(const std::string& path, off_t at) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return errno != ENOENT;  // cannot tell: leave it
  const bool locked = byte_is_locked(fd, at);
  ::close(fd);
  return locked;
}

}  // namespace saccade::dds
