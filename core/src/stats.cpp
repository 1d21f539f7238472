#include "saccade/stats.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

namespace saccade {

void Histogram::record(int64_t ns) {
  // One writer at a time (see above): no locked instructions needed.
  const uint64_t n = count_.load(std::memory_order_relaxed);
  recent_[static_cast<std::size_t>(n % kWindow)].store(ns, std::memory_order_relaxed);
  count_.store(n + 1, std::memory_order_relaxed);
  sum_.store(sum_.load(std::memory_order_relaxed) + ns, std::memory_order_relaxed);
  if (ns > max_.load(std::memory_order_relaxed)) max_.store(ns, std::memory_order_relaxed);
}

int64_t Histogram::percentile(double q) const {
  const uint64_t total = count();
  if (total == 0) return 0;
  const std::size_t n = static_cast<std::size_t>(std::min<uint64_t>(total, kWindow));
  std::vector<int64_t> samples(n);
  for (std::size_t i = 0; i < n; ++i) samples[i] = recent_[i].load(std::memory_order_relaxed);
  // Nearest rank: the ceil(q n)-th smallest (1-based), at least the first.
  const double wanted = std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(n));
  const std::size_t rank = std::clamp<std::size_t>(static_cast<std::size_t>(wanted), 1, n) - 1;
  std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(rank), samples.end());
  return samples[rank];
}

double Histogram::mean() const {
  uint64_t n = count();
  return n == 0 ? 0.0 : static_cast<double>(sum_.load(std::memory_order_relaxed)) / static_cast<double>(n);
}

double NodeStats::rate_hz() const {
  uint64_t n = processed.load(std::memory_order_relaxed);
  int64_t span = last_ns.load(std::memory_order_relaxed) - first_ns.load(std::memory_order_relaxed);
  if (n < 2 || span <= 0) return 0.0;
  return static_cast<double>(n - 1) * 1e9 / static_cast<double>(span);
}

namespace {

std::string us(int64_t ns) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", static_cast<double>(ns) / 1000.0);
  return buf;
}

std::string json_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

std::string format_stats_table(const std::vector<const NodeStats*>& nodes, double elapsed_s) {
  std::string out;
  char line[512];
  // Every column says its unit: calls, calls per second, microseconds.
  std::snprintf(line, sizeof line, "stats after %.2f s\n%-18s %-22s %9s %7s %9s %9s %9s %9s %10s  %s\n", elapsed_s,
                "node", "plugin", "processed", "errors", "rate Hz", "p50 us", "p99 us", "max us", "lat p50 us",
                "drops per input (messages), the node's own counts");
  out += line;
  for (const NodeStats* n : nodes) {
    std::string drops;
    for (const auto& in : n->inputs) {
      uint64_t d = in->dropped.load(std::memory_order_relaxed);
      uint64_t s = in->sync_dropped.load(std::memory_order_relaxed);
      drops += in->name + "=" + std::to_string(d);
      if (s) drops += "+" + std::to_string(s) + "sync";
      drops += " ";
    }
    for (const auto& c : n->counters) drops += c->name + ":" + std::to_string(c->value.load()) + " ";
    for (const auto& t : n->timings)
      drops += t->name + ":" + us(t->histogram.percentile(0.5)) + "/" + us(t->histogram.percentile(0.99)) +
               "us(n=" + std::to_string(t->histogram.count()) + ") ";
    std::snprintf(line, sizeof line, "%-18s %-22s %9llu %7llu %9.1f %9s %9s %9s %10s  ", n->name.c_str(),
                  n->plugin.c_str(), static_cast<unsigned long long>(n->processed.load()),
                  static_cast<unsigned long long>(n->errors.load()), n->rate_hz(),
                  us(n->process_time.percentile(0.5)).c_str(), us(n->process_time.percentile(0.99)).c_str(),
                  us(n->process_time.max()).c_str(), us(n->latency.percentile(0.5)).c_str());
    out += line;
    out += drops;  // any length: node names and counters are the plugins'
    out += "\n";
  }
  return out;
}

std::string format_stats_json(const std::vector<const NodeStats*>& nodes, double elapsed_s) {
  std::string out = "{\n  \"elapsed_s\": " + std::to_string(elapsed_s) + ",\n  \"nodes\": [";
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const NodeStats* n = nodes[i];
    out += i ? ",\n    {" : "\n    {";
    out += "\"name\": \"" + json_escape(n->name) + "\", \"plugin\": \"" + json_escape(n->plugin) + "\"";
    out += ", \"processed\": " + std::to_string(n->processed.load());
    out += ", \"errors\": " + std::to_string(n->errors.load());
    out += ", \"emitted\": " + std::to_string(n->emitted.load());
    out += ", \"rate_hz\": " + std::to_string(n->rate_hz());
    out += ", \"process_ns\": {\"mean\": " + std::to_string(static_cast<int64_t>(n->process_time.mean())) +
           ", \"p50\": " + std::to_string(n->process_time.percentile(0.5)) +
           ", \"p99\": " + std::to_string(n->process_time.percentile(0.99)) +
           ", \"max\": " + std::to_string(n->process_time.max()) + "}";
    out += ", \"latency_ns\": {\"mean\": " + std::to_string(static_cast<int64_t>(n->latency.mean())) +
           ", \"p50\": " + std::to_string(n->latency.percentile(0.5)) +
           ", \"p99\": " + std::to_string(n->latency.percentile(0.99)) +
           ", \"max\": " + std::to_string(n->latency.max()) + "}";
    out += ", \"inputs\": [";
    for (std::size_t k = 0; k < n->inputs.size(); ++k) {
      const auto& in = n->inputs[k];
      out += (k ? ", " : "") + std::string("{\"name\": \"") + json_escape(in->name) +
             "\", \"received\": " + std::to_string(in->received.load()) +
             ", \"dropped\": " + std::to_string(in->dropped.load()) +
             ", \"sync_dropped\": " + std::to_string(in->sync_dropped.load()) + "}";
    }
    out += "], \"counters\": {";
    for (std::size_t k = 0; k < n->counters.size(); ++k)
      out += (k ? ", \"" : "\"") + json_escape(n->counters[k]->name) +
             "\": " + std::to_string(n->counters[k]->value.load());
    out += "}, \"timings_ns\": {";
    for (std::size_t k = 0; k < n->timings.size(); ++k) {
      const Histogram& h = n->timings[k]->histogram;
      out += (k ? ", \"" : "\"") + json_escape(n->timings[k]->name) + "\": {\"count\": " + std::to_string(h.count()) +
             ", \"mean\": " + std::to_string(static_cast<int64_t>(h.mean())) +
             ", \"p50\": " + std::to_string(h.percentile(0.5)) + ", \"p99\": " + std::to_string(h.percentile(0.99)) +
             ", \"max\": " + std::to_string(h.max()) + "}";
    }
    out += "}}";
  }
  out += "\n  ]\n}\n";
  return out;
}

}  // namespace saccade
