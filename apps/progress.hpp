#pragma once
// saccade run's progress line on a terminal: the sources' frames (of how many,
// for finite ones), their rate, the time so far and the time left.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "saccade/executor.hpp"

namespace saccade::cli {

// One source as the line shows it.
struct ProgressSource {
  std::string name;
  const NodeStats* stats = nullptr;
  int64_t total = 0;  // frames it will emit; 0: unknown or endless
};

// The text of the line: "camera 312/795 frames  39%  142.1 fps  2.2 s  ETA 3.4 s";
// without a total, "camera 312 frames  142.1 fps  2.2 s" (and, with a time
// limit, the time left of it).
std::string format_progress(const std::string& name, uint64_t frames, int64_t total, double elapsed_s,
                            double time_limit_s);

class ProgressLine {
 public:
  // The executor opened: its sources' stats and their frames_total counters
  // exist. `max_frames` (--frames) caps each total; `time_limit_s`
  // (--duration) < 0 when none. On a terminal the line is redrawn in place a
  // few times a second; elsewhere (asked for with --progress) a line a second.
  ProgressLine(const Executor& executor, int64_t max_frames, double time_limit_s, std::FILE* out, bool terminal);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  void start();
  // Stops redrawing and leaves the last line, ended.
  void stop();
  // Prints `text` (a stats table) above the line, which is then redrawn.
  void print_above(const std::string& text);

 private:
  std::string text() const;
  void draw(bool final);

  std::vector<ProgressSource> sources_;
  // Its own clock, started with run(): the executor's elapsed time is not for
  // other threads to read while it starts.
  std::chrono::steady_clock::time_point start_;
  double time_limit_s_;
  std::FILE* out_;
  bool terminal_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false, drawn_ = false;
  std::thread thread_;
};

}  // namespace saccade::cli
