#pragma once
// How much processor time the live view may take from the graph it shows: a
// share of one core, kept as a leaky bucket over the view's own threads'
// CPU time. A layout that pulls every picture at 30 Hz then gets them at a
// lower rate instead of slowing the graph: the view degrades, the robot not.
#include <pthread.h>
#include <time.h>

#include <algorithm>
#include <cstdint>

namespace saccade::view {

// CPU time a thread has used so far, ns; 0 when the system cannot say.
inline int64_t thread_cpu_ns(pthread_t thread) {
  clockid_t clock;
  timespec t{};
  if (pthread_getcpuclockid(thread, &clock) != 0 || clock_gettime(clock, &t) != 0) return 0;
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

class CpuBudget {
 public:
  // `share`: of one core (0.05 = 50 ms of CPU a second); <= 0: no limit.
  // `burst_s`: how much unused allowance may be saved up, in seconds of it.
  explicit CpuBudget(double share, double burst_s = 0.5) : share_(share), burst_s_(burst_s) {}

  // Given the view's threads' CPU time so far and the wall clock (both ns,
  // any origin, never going back): whether it may do more work now.
  bool has_room(int64_t cpu_ns, int64_t wall_ns) {
    if (share_ <= 0) return true;
    if (last_wall_ns_ == 0) {
      last_wall_ns_ = wall_ns;
      last_cpu_ns_ = cpu_ns;
      credit_ns_ = max_credit();
      return true;
    }
    credit_ns_ += share_ * static_cast<double>(wall_ns - last_wall_ns_);
    credit_ns_ -= static_cast<double>(cpu_ns - last_cpu_ns_);
    credit_ns_ = std::min(credit_ns_, max_credit());
    last_wall_ns_ = wall_ns;
    last_cpu_ns_ = cpu_ns;
    if (credit_ns_ > 0) return true;
    ++refusals_;
    return false;
  }
  // Times has_room said no: rounds the view waited for its allowance.
  uint64_t refusals() const { return refusals_; }
  double share() const { return share_; }

 private:
  double max_credit() const { return share_ * burst_s_ * 1e9; }
  double share_, burst_s_;
  double credit_ns_ = 0;
  int64_t last_wall_ns_ = 0, last_cpu_ns_ = 0;
  uint64_t refusals_ = 0;
};

}  // namespace saccade::view
