#include "progress.hpp"

#include <algorithm>
#include <chrono>

namespace saccade::cli {

namespace {

std::string seconds(double s) {
  char buf[32];
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.1f s", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%d min %02d s", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  else
    std::snprintf(buf, sizeof buf, "%d h %02d min", static_cast<int>(s) / 3600, static_cast<int>(s) / 60 % 60);
  return buf;
}

}  // namespace

std::string format_progress(const std::string& name, uint64_t frames, int64_t total, double elapsed_s,
                            double time_limit_s) {
  const double rate = elapsed_s > 0 ? static_cast<double>(frames) / elapsed_s : 0.0;
  char buf[160];
  std::string out = name.empty() ? "" : name + " ";
  if (total > 0) {
    std::snprintf(buf, sizeof buf, "%llu/%lld frames  %3.0f%%", static_cast<unsigned long long>(frames),
                  static_cast<long long>(total),
                  100.0 * std::min(1.0, static_cast<double>(frames) / static_cast<double>(total)));
  } else {
    std::snprintf(buf, sizeof buf, "%llu frames", static_cast<unsigned long long>(frames));
  }
  out += buf;
  std::snprintf(buf, sizeof buf, "  %.1f fps  %s", rate, seconds(elapsed_s).c_str());
  out += buf;
  // Time left: the frames left at the rate so far, or the time limit's rest, whichever ends first.
  double left = -1;
  if (total > 0 && rate > 0)
    left = static_cast<double>(std::max<int64_t>(0, total - static_cast<int64_t>(frames))) / rate;
  if (time_limit_s >= 0) {
    const double rest = std::max(0.0, time_limit_s - elapsed_s);
    left = left < 0 ? rest : std::min(left, rest);
  }
  if (left >= 0) out += "  ETA " + seconds(left);
  return out;
}

ProgressLine::ProgressLine(const Executor& executor, int64_t max_frames, double time_limit_s, std::FILE* out,
                           bool terminal)
    : time_limit_s_(time_limit_s), out_(out), terminal_(terminal) {
  for (const ResolvedNode& node : executor.graph().nodes) {
    if (!node.contract.is_source()) continue;
    ProgressSource s;
    s.name = node.decl.name;
    s.stats = executor.stats(s.name);
    if (s.stats == nullptr) continue;
    for (const auto& c : s.stats->counters)
      if (c->name == "frames_total") s.total = static_cast<int64_t>(c->value.load());
    if (max_frames > 0) s.total = s.total > 0 ? std::min(s.total, max_frames) : max_frames;
    sources_.push_back(s);
  }
}

ProgressLine::~ProgressLine() { stop(); }

void ProgressLine::start() {
  if (sources_.empty() || thread_.joinable()) return;
  start_ = std::chrono::steady_clock::now();
  thread_ = std::thread([this] {
    const auto period = terminal_ ? std::chrono::milliseconds(250) : std::chrono::milliseconds(1000);
    std::unique_lock lock(mutex_);
    while (!wake_.wait_for(lock, period, [this] { return stopping_; })) draw(false);
  });
}

void ProgressLine::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || !thread_.joinable()) return;
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
  std::lock_guard lock(mutex_);
  draw(true);
}

void ProgressLine::print_above(const std::string& text) {
  std::lock_guard lock(mutex_);
  if (terminal_ && drawn_) std::fputs("\r\033[K", out_);
  std::fputs(text.c_str(), out_);
  std::fflush(out_);
  drawn_ = false;
}

// The source furthest from its end shows: the one a finite run waits for.
std::string ProgressLine::text() const {
  const ProgressSource* shown = &sources_.front();
  double least = 2.0;
  for (const ProgressSource& s : sources_) {
    if (s.total <= 0) continue;
    const double done = static_cast<double>(s.stats->processed.load()) / static_cast<double>(s.total);
    if (done < least) least = done, shown = &s;
  }
  return format_progress(sources_.size() > 1 ? shown->name : "", shown->stats->processed.load(), shown->total,
                         std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(),
                         time_limit_s_);
}

void ProgressLine::draw(bool final) {
  const std::string line = text();
  if (terminal_)
    std::fprintf(out_, "\r%s\033[K%s", line.c_str(), final ? "\n" : "");
  else
    std::fprintf(out_, "%s\n", line.c_str());
  std::fflush(out_);
  drawn_ = !final;
}

}  // namespace saccade::cli
