#pragma once
// Per-node counters and timing histograms. Each counter has one writer at a time
// (the thread running the node, or the executor under its lock), so updates are
// plain relaxed load+store, not locked read-modify-writes; the stats printer
// reads them at any time.
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace saccade {

// Adds to a counter that only one thread writes at a time.
inline void bump(std::atomic<uint64_t>& counter, uint64_t by = 1) {
  counter.store(counter.load(std::memory_order_relaxed) + by, std::memory_order_relaxed);
}

// Nanosecond durations: count, mean and max over every sample, and exact
// percentiles over the most recent kWindow samples (all of them until there
// are that many). record() writes one slot of a fixed ring: no allocation and
// no locked instruction on the hot path; percentile() copies the ring and
// selects the rank at report time (nearest rank: the smallest sample with at
// least q of the window at or below it). A ring of recent samples rather than
// a histogram (whose buckets gave edges up to 12% off) or a random reservoir
// (a random number per sample, and the start of a long run mixed with its
// end): the figure is a real sample, reproducible, and tells how the node is
// doing now. 4096 samples: p99 is then the 41st largest, 32 KB per timing.
class Histogram {
 public:
  static constexpr std::size_t kWindow = 4096;

  void record(int64_t ns);
  uint64_t count() const { return count_.load(std::memory_order_relaxed); }
  int64_t max() const { return max_.load(std::memory_order_relaxed); }
  // q in [0, 1], over the last min(count, kWindow) samples; 0 when empty.
  // Allocates (a sorted copy): for reports, not for the hot path.
  int64_t percentile(double q) const;
  double mean() const;  // exact, over every sample; 0 when empty

 private:
  std::array<std::atomic<int64_t>, kWindow> recent_{};  // slot count % kWindow holds the next sample
  std::atomic<uint64_t> count_{0};
  std::atomic<int64_t> max_{0};
  std::atomic<int64_t> sum_{0};
};

struct InputStats {
  std::string name;
  std::atomic<uint64_t> received{0};
  std::atomic<uint64_t> dropped{0};       // pushed out by the queue policy
  std::atomic<uint64_t> sync_dropped{0};  // found no partner (in its sync group, or before end of stream)
};

// A count a node keeps of its own (samples lost, writes failed, ...),
// registered when it opens and reported with the executor's counts. Written
// with fetch_add where several threads may count (a middleware's listeners).
struct NamedCounter {
  std::string name;
  std::atomic<uint64_t> value{0};
};

// A timing a node keeps of its own (how long from a cause to its effect),
// registered when it opens and reported with the executor's timings.
struct NamedTiming {
  std::string name;
  Histogram histogram;  // nanoseconds
};

struct NodeStats {
  std::string name;
  std::string plugin;
  std::atomic<uint64_t> processed{0};
  std::atomic<uint64_t> errors{0};
  std::atomic<uint64_t> emitted{0};
  std::atomic<int64_t> first_ns{0};
  std::atomic<int64_t> last_ns{0};
  Histogram process_time;
  Histogram latency;  // now - origin of the message that triggered the call
  std::vector<std::unique_ptr<InputStats>> inputs;
  std::vector<std::unique_ptr<NamedCounter>> counters;  // the node's own, in the order it registered them
  std::vector<std::unique_ptr<NamedTiming>> timings;    // the same, for durations

  double rate_hz() const;
};

// A readable table and a JSON document of a set of node stats.
std::string format_stats_table(const std::vector<const NodeStats*>& nodes, double elapsed_s);
std::string format_stats_json(const std::vector<const NodeStats*>& nodes, double elapsed_s);

}  // namespace saccade
