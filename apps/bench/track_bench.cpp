// The tracking benchmark: the fovea's box tracker against OpenCV's CSRT, KCF
// and MIL on the same sequences from the same initial box, scored with the
// OTB/VOT measures (see tracking_data.hpp). Every tracker sees every frame;
// the time per frame is the wall clock of its update alone (for the fovea
// tracker: the retina sampled at its last box's centre plus its update), with
// OpenCV on one thread for all.
//
//   saccade_track_bench [--data DIR] [--otb DIR[:FIRST]]... [--vot DIR]... [--video FILE:FIRST:x,y,w,h[:COUNT]]...
//                       [--no-generated] [--holdout] [--fresh K,...]
//                       [--trackers fovea,csrt,kcf,mil] [--frames N] [--every N] [--scale F] [--gray] [--jpeg Q]
//                       [--white-balance A]
//                       [--sequences a,b] [--markdown FILE]
//                       [--export DIR]   (the sequences written as OTB folders, for other tools, instead)
#ifndef SACCADE_TRACK_BENCH_FOVEA
#define SACCADE_TRACK_BENCH_FOVEA 1
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/tracking.hpp>

#include "saccade/status.hpp"
#include "tracking_data.hpp"
#include "unique_names.hpp"

#if SACCADE_TRACK_BENCH_FOVEA
#include "box_tracker.hpp"
#include "color_histogram.hpp"
#include "fovea_params.hpp"
#include "retina.hpp"
#endif

namespace {

using namespace saccade::bench;
using saccade::Status;

// One tracker under test, behind the interface the benchmark drives.
class Tracker {
 public:
  virtual ~Tracker() = default;
  // Ok, or the error saying why the tracker refused the box.
  virtual Status init(const cv::Mat& frame, cv::Rect2d box) = 0;
  // The box and whether the tracker claims to follow the target (ms left 0).
  virtual TrackedFrame update(const cv::Mat& frame) = 0;
};

// MIL draws its samples from OpenCV's thread-wide generator; each tracker
// gets a stream of its own, so a run repeats whatever else runs beside it.
class OwnRandomStream {
 public:
  explicit OwnRandomStream(cv::RNG& own) : own_(own), saved_(cv::theRNG()) { cv::theRNG() = own_; }
  ~OwnRandomStream() {
    own_ = cv::theRNG();
    cv::theRNG() = saved_;
  }
  OwnRandomStream(const OwnRandomStream&) = delete;
  OwnRandomStream& operator=(const OwnRandomStream&) = delete;

 private:
  cv::RNG& own_;
  cv::RNG saved_;
};

class OpenCvTracker final : public Tracker {
 public:
  explicit OpenCvTracker(cv::Ptr<cv::Tracker> tracker) : tracker_(std::move(tracker)) {}
  Status init(const cv::Mat& frame, cv::Rect2d box) override {
    // OpenCV's trackers take integer boxes.
    last_ = cv::Rect(cvRound(box.x), cvRound(box.y), cvRound(box.width), cvRound(box.height));
    const OwnRandomStream stream(random_);
    try {
      tracker_->init(frame, last_);
    } catch (const cv::Exception& e) { return Status::error(e.what()); }
    return {};
  }
  TrackedFrame update(const cv::Mat& frame) override {
    cv::Rect box;
    bool found = false;
    const OwnRandomStream stream(random_);
    try {
      found = tracker_->update(frame, box);
    } catch (const cv::Exception&) {
      found = false;  // a box driven off the frame makes some of them throw: lost, not fatal
    }
    // On failure the box is not always set: keep the last one.
    if (found && box.area() > 0) last_ = box;
    return {cv::Rect2d(last_), found, 0, found ? "found" : "not found"};
  }

 private:
  cv::Ptr<cv::Tracker> tracker_;
  cv::Rect last_;
  cv::RNG random_{0x5eed};
};

#if SACCADE_TRACK_BENCH_FOVEA
using BoxConfig = saccade::fovea::BoxTrackerConfig;

// The fovea tracker as the robot runs it: every frame the retina is sampled
// where the tracker last saw the target, then the tracker updates.
class FoveaTracker final : public Tracker {
 public:
  explicit FoveaTracker(const BoxConfig& config) : tracker_(config), retina_(saccade::retina::RetinaConfig{}) {}
  Status init(const cv::Mat& frame, cv::Rect2d box) override {
    // As the retina node refuses them: frames smaller than a level, not 8-bit gray or BGR.
    if (const Status fits = retina_.check(frame); !fits.ok()) return Status::error("the retina: " + fits.message());
    fovea_ = (box.tl() + box.br()) * 0.5;
    return tracker_.init(frame, box);
  }
  TrackedFrame update(const cv::Mat& frame) override {
    if (retina_.check(frame).ok()) retina_.sample(frame, fovea_, levels_, geometry_);  // (a frame of another size)
    const saccade::fovea::TrackEstimate e = tracker_.update(frame);
    const cv::Point2d center = (e.box.tl() + e.box.br()) * 0.5;
    if (std::isfinite(center.x) && std::isfinite(center.y)) fovea_ = center;
    return {e.box, e.state == saccade::fovea::TrackState::kTracking, 0, saccade::fovea::to_string(e.state),
            e.confidence};
  }

 private:
  saccade::fovea::BoxTracker tracker_;
  saccade::retina::RetinaSampler retina_;
  std::vector<cv::Mat> levels_;
  std::vector<saccade::LevelGeometry> geometry_;
  cv::Point2d fovea_;
};
#else
struct BoxConfig {};
#endif

// `box`: the fovea tracker's configuration (the defaults, or as --set changed them).
std::unique_ptr<Tracker> make_tracker(const std::string& name, const BoxConfig& box) {
#if SACCADE_TRACK_BENCH_FOVEA
  if (name == "fovea") return std::make_unique<FoveaTracker>(box);
#else
  (void)box;
#endif
  if (name == "csrt") return std::make_unique<OpenCvTracker>(cv::TrackerCSRT::create());
  if (name == "kcf") return std::make_unique<OpenCvTracker>(cv::TrackerKCF::create());
  if (name == "mil") return std::make_unique<OpenCvTracker>(cv::TrackerMIL::create());
  return nullptr;
}

#ifndef SACCADE_SAMPLE_DATA
#define SACCADE_SAMPLE_DATA "/usr/share/doc/opencv-doc/examples/data"
#endif

struct Options {
  std::string data = SACCADE_SAMPLE_DATA;
  std::vector<std::string> otb, vot, videos;
  bool no_generated = false;
  bool holdout = false;    // the held-out generated set too
  bool round = false;      // generated targets cut round (SyntheticScript::round)
  double turn = 0;         // generated targets turning back and forth by this many degrees (SyntheticScript::turn_deg)
  std::vector<int> fresh;  // fresh generated sets (fresh_scripts)
  std::string trackers = SACCADE_TRACK_BENCH_FOVEA ? "fovea,csrt,kcf,mil" : "csrt,kcf,mil";
  std::string markdown;
  std::string sequences;  // names to keep, all when empty
  int frames = 0;
  int every = 1;                  // every Nth frame of each sequence
  double scale = 1.0;             // each sequence's frames resized by this
  bool gray = false;              // each sequence as a monochrome camera sees it
  int jpeg = 0;                   // each frame through a JPEG of this quality (0: not)
  double white_balance = 0;       // each frame's red and blue swung by this much (0: not)
  std::string trace;              // a folder for per-frame CSV files, one per sequence and tracker
  std::string jumps;              // a CSV file with a line per jump of every tracker (--jumps)
  std::string export_dir;         // --export: the sequences are written there in the OTB layout instead of run
  int runs = 1;                   // runs per sequence, the first box moved a little in all but the first
  std::vector<std::string> sets;  // the fovea node's box_* parameters, key=value
  BoxConfig box;                  // the fovea tracker's configuration, as they set it
};

std::vector<std::string> split_list(const std::string& list) {
  std::vector<std::string> items;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) items.push_back(item);
  return items;
}

// --- Running.

struct TrackerResult {
  std::string tracker;
  Status status;  // why it did not run; ok when it did
  TrackScore score;
  WitnessScore witness;           // a sequence without truth
  FrameTimes times;               // what its frames took
  std::vector<double> agreement;  // ... and with each tracker, in the order run (-1: itself or failed)
};

struct SequenceResults {
  std::string name;
  std::string sequence;  // the sequence's own name (name adds the run)
  int frames = 0, invisible = 0;
  cv::Size size;
  bool truth_known = true;
  std::vector<TrackerResult> results;
};

// One line per frame: what was true, what the tracker said, how well that fits.
// An error names the folder or file that could not be written.
Status write_trace(const std::string& folder, const Sequence& sequence, int run, const std::string& tracker,
                   const std::vector<TrackedFrame>& track) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) return Status::error("cannot create " + folder + ": " + ec.message());
  const std::string path =
      folder + "/" + sequence.name + (run > 0 ? "_run" + std::to_string(run) : "") + "_" + tracker + ".csv";
  std::ofstream out(path);
  out << "frame,visible,truth_x,truth_y,truth_w,truth_h,x,y,w,h,tracking,state,confidence,iou,centre_error,ms\n";
  for (std::size_t i = 0; i < track.size(); ++i) {
    const cv::Rect2d& t = sequence.truth[i];
    const TrackedFrame& f = track[i];
    out << i << ',';
    // Without truth, only frame 0's box is known: the rest left empty.
    const bool known = sequence.truth_known || i == 0;
    if (known)
      out << (sequence.visible[i] ? 1 : 0) << ',' << t.x << ',' << t.y << ',' << t.width << ',' << t.height << ',';
    else
      out << ",,,,,";
    out << f.box.x << ',' << f.box.y << ',' << f.box.width << ',' << f.box.height << ',' << (f.tracking ? 1 : 0) << ','
        << f.state << ',' << f.confidence << ',';
    if (known)
      out << iou(t, f.box) << ',' << center_error(t, f.box);
    else
      out << ',';
    out << ',' << f.ms << '\n';
  }
  if (!out) return Status::error("cannot write " + path);
  return {};
}

// The header of --jumps' file; an error names it.
Status start_jumps(const std::string& path) {
  std::ofstream out(path);
  out << "sequence,run,tracker,frame,from_x,from_y,to_x,to_y,w,h,state,confidence,visible,iou,right,"
         "tones_shared,colours_shared\n";
  if (!out) return Status::error("cannot write " + path);
  return {};
}

#if SACCADE_TRACK_BENCH_FOVEA
// How much of the first box's tones and colours the box at a jump has,
// measured as the box tracker measures them (plugins/fovea/color_histogram.hpp,
// its colour tolerance `box`'s); colours -1 where the target has none (a
// gray frame's are all one bin).
struct Shares {
  double tones = -1, colours = -1;
};
Shares shares_of(const cv::Mat& first, cv::Rect2d first_box, const cv::Mat& frame, cv::Rect2d box,
                 const BoxConfig& config) {
  namespace fv = saccade::fovea;
  const auto inner = [](const cv::Mat& image, cv::Rect2d b) {
    return fv::central_half(image, (b.tl() + b.br()) * 0.5, b.size());
  };
  std::vector<float> learnt, seen;
  Shares shares;
  fv::tone_histogram(first, inner(first, first_box), learnt);
  fv::tone_histogram(frame, inner(frame, box), seen);
  shares.tones = fv::shared_colors(learnt, seen);
  if (fv::colourful_share(first, inner(first, first_box), config.min_chroma_change) < fv::kMinColourful) return shares;
  fv::chroma_histogram(first, inner(first, first_box), learnt);
  fv::chroma_histogram(frame, inner(frame, box), seen);
  shares.colours = fv::shared_colors(learnt, seen);
  return shares;
}
#endif

// A line per jump of a tracker's track (jump_frames): where the box went
// from and to, what the tracker said, whether it was right (the truth
// visible there and IoU >= 0.3; empty without truth) and how much of the
// first box's tones and colours the box it jumped to has: what tells a right
// re-detection from a wrong one, measured before it is built into a tracker.
Status write_jumps(const std::string& path, const Sequence& sequence, int run, const std::string& tracker,
                   const std::vector<TrackedFrame>& track, [[maybe_unused]] const BoxConfig& config) {
  const std::vector<int> jumps = jump_frames(track);
  if (jumps.empty()) return {};
  const saccade::Result<cv::Mat> first = sequence.frame(0);
  if (!first.ok()) return first.status();
  std::ofstream out(path, std::ios::app);
  for (const int i : jumps) {
    const std::size_t at = static_cast<std::size_t>(i);
    const cv::Rect2d &from = track[at - 1].box, &to = track[at].box;
    out << sequence.name << ',' << run << ',' << tracker << ',' << i << ',' << from.x + from.width / 2 << ','
        << from.y + from.height / 2 << ',' << to.x + to.width / 2 << ',' << to.y + to.height / 2 << ',' << to.width
        << ',' << to.height << ',' << track[at].state << ',' << track[at].confidence << ',';
    if (sequence.truth_known) {
      const double overlap = sequence.visible[at] ? iou(sequence.truth[at], to) : 0.0;
      out << (sequence.visible[at] ? 1 : 0) << ',' << overlap << ',' << (overlap >= 0.3 ? 1 : 0) << ',';
    } else {
      out << ",,,";
    }
#if SACCADE_TRACK_BENCH_FOVEA
    const saccade::Result<cv::Mat> frame = sequence.frame(i);
    if (!frame.ok()) return frame.status();
    const Shares shares = shares_of(*first, track.front().box, *frame, to, config);
    out << shares.tones << ',';
    if (shares.colours >= 0) out << shares.colours;
#else
    out << ',';
#endif
    out << '\n';
  }
  if (!out) return Status::error("cannot write " + path);
  return {};
}

// Runs each tracker over the sequence from the same first box. A tracker
// that refuses the first box is reported as failed; an error is a frame that
// cannot be read or a trace that cannot be written.
saccade::Result<SequenceResults> run_sequence(const Sequence& sequence, const std::vector<std::string>& names,
                                              const Options& options, int run) {
  const std::string& trace = options.trace;
  const cv::Rect2d box = perturbed_first_box(sequence.truth.front(), run);
  SequenceResults out{run == 0 ? sequence.name : sequence.name + ", run " + std::to_string(run),
                      sequence.name,
                      sequence.size(),
                      static_cast<int>(std::count(sequence.visible.begin(), sequence.visible.end(), false)),
                      sequence.frame_size,
                      sequence.truth_known,
                      {}};
  const saccade::Result<cv::Mat> first = sequence.frame(0);
  if (!first.ok()) return first.status();
  std::vector<std::unique_ptr<Tracker>> trackers;
  std::vector<std::vector<TrackedFrame>> tracks;
  for (const std::string& name : names) {
    out.results.push_back({name, {}, {}, {}, {}, {}});
    trackers.push_back(make_tracker(name, options.box));
    if (!sequence.visible.front())
      out.results.back().status = Status::error("the target is not visible in frame 1");
    else
      out.results.back().status = trackers.back()->init(*first, box);
    tracks.emplace_back(static_cast<std::size_t>(sequence.size()));
    tracks.back()[0] = {box, true, 0};
  }
  // Each tracker runs the whole sequence on its own (the frames rendered or
  // read again for each): run frame by frame side by side, each tracker's
  // memory traffic evicted the next one's state from the caches (the fovea's
  // 640x480 frames took 0.48-0.49 ms that way against 0.43-0.44 ms alone).
  for (std::size_t k = 0; k < trackers.size(); ++k) {
    if (!out.results[k].status.ok()) continue;
    for (int i = 1; i < sequence.size(); ++i) {
      const saccade::Result<cv::Mat> read = sequence.frame(i);
      if (!read.ok()) return read.status();
      const auto t0 = std::chrono::steady_clock::now();
      TrackedFrame f = trackers[k]->update(*read);
      f.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      // A tracker that gives no usable box keeps its last one (scores stay finite).
      const bool usable =
          std::isfinite(f.box.x) && std::isfinite(f.box.y) && std::isfinite(f.box.width) && std::isfinite(f.box.height);
      if (!usable) f.box = tracks[k][static_cast<std::size_t>(i - 1)].box;
      tracks[k][static_cast<std::size_t>(i)] = f;
    }
  }
  for (std::size_t k = 0; k < trackers.size(); ++k) {
    if (!out.results[k].status.ok()) continue;
    out.results[k].times = frame_times(tracks[k]);
    if (sequence.truth_known) {
      const saccade::Result<TrackScore> score = score_track(sequence.truth, sequence.visible, tracks[k]);
      if (!score.ok()) return score.status();
      out.results[k].score = *score;
    } else {
      out.results[k].witness = witness_score(tracks[k]);
      for (std::size_t other = 0; other < trackers.size(); ++other)
        out.results[k].agreement.push_back(
            other == k || !out.results[other].status.ok() ? -1.0 : agreement(tracks[k], tracks[other]));
    }
    if (!options.jumps.empty())
      if (Status written = write_jumps(options.jumps, sequence, run, names[k], tracks[k], options.box); !written.ok())
        return written;
    if (trace.empty()) continue;
    if (Status written = write_trace(trace, sequence, run, names[k], tracks[k]); !written.ok()) return written;
  }
  return out;
}

// --- Reporting: Markdown tables with padded columns, readable as plain text too.

std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  return text;
}

std::string table(const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> width(rows.front().size(), 3);
  for (const auto& row : rows)
    for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
  std::string out;
  auto line = [&](const std::vector<std::string>& cells) {
    for (std::size_t c = 0; c < cells.size(); ++c)
      out += "| " + cells[c] + std::string(width[c] - cells[c].size(), ' ') + " ";
    out += "|\n";
  };
  line(rows.front());
  std::vector<std::string> rule;
  for (std::size_t w : width) rule.push_back(std::string(w, '-'));
  line(rule);
  for (std::size_t r = 1; r < rows.size(); ++r) line(rows[r]);
  return out;
}

const std::vector<std::string> kHeader = {"tracker",     "centre error (px)",  "precision@20",
                                          "success AUC", "success@0.5",        "frames lost",
                                          "honest lost", "claimed off target", "max re-acquisition (frames)",
                                          "ms/frame"};

std::string reacquisition_cell(const TrackScore& s) {
  if (s.reappearances == 0) return "-";
  std::string cell = s.max_reacquire_delay >= 0 ? std::to_string(s.max_reacquire_delay) : "";
  if (s.reacquire_misses > 0)
    cell += (cell.empty() ? "" : ", ") + std::string("never ") + std::to_string(s.reacquire_misses) + "/" +
            std::to_string(s.reappearances);
  return cell;
}

std::vector<std::string> score_row(const TrackerResult& r) {
  if (!r.status.ok()) return {r.tracker, "failed: " + r.status.message(), "", "", "", "", "", "", "", ""};
  const TrackScore& s = r.score;
  return {r.tracker,
          fixed(s.mean_center_error, 1),
          fixed(s.precision20, 3),
          fixed(s.success_auc, 3),
          fixed(s.success50, 3),
          std::to_string(s.frames_lost),
          s.honest_lost >= 0 ? fixed(s.honest_lost, 2) : "-",
          std::to_string(s.claimed_off_target),
          reacquisition_cell(s),
          fixed(s.ms_per_frame, 2)};
}

// Without truth: what each track shows of itself and how far the trackers agree.
std::vector<std::string> witness_header(const std::vector<TrackerResult>& results) {
  std::vector<std::string> header{"tracker", "claimed tracking", "jumps"};
  for (const TrackerResult& r : results) header.push_back("within 20 px of " + r.tracker);
  header.push_back("ms/frame");
  return header;
}

std::vector<std::string> witness_row(const TrackerResult& r, std::size_t trackers) {
  std::vector<std::string> row{r.tracker};
  if (!r.status.ok() || r.witness.frames == 0) {
    row.push_back(r.status.ok() ? "no frame after the first" : "failed: " + r.status.message());
    row.resize(trackers + 4);
    return row;
  }
  row.push_back(fixed(r.witness.claimed, 2));
  row.push_back(std::to_string(r.witness.jumps));
  for (const double a : r.agreement) row.push_back(a >= 0 ? fixed(a, 2) : "-");
  row.push_back(fixed(r.witness.ms_per_frame, 2));
  return row;
}

std::string sequence_section(const SequenceResults& sequence) {
  const std::string size = std::to_string(sequence.size.width) + "x" + std::to_string(sequence.size.height);
  std::vector<std::vector<std::string>> rows;
  if (!sequence.truth_known) {
    rows.push_back(witness_header(sequence.results));
    for (const TrackerResult& r : sequence.results) rows.push_back(witness_row(r, sequence.results.size()));
    return "## " + sequence.name + " (" + std::to_string(sequence.frames) + " frames, " + size +
           ", no truth: witness measures)\n\n" + table(rows) + "\n";
  }
  rows.push_back(kHeader);
  for (const TrackerResult& r : sequence.results) rows.push_back(score_row(r));
  return "## " + sequence.name + " (" + std::to_string(sequence.frames) + " frames, " + size +
         ", target invisible in " + std::to_string(sequence.invisible) + ")\n\n" + table(rows) + "\n";
}

// Mean of a measure over the sequences that have it.
struct Mean {
  double sum = 0;
  int count = 0;
  void add(double value) { sum += value, ++count; }
  std::string cell(int decimals) const { return count > 0 ? fixed(sum / count, decimals) : "-"; }
};

std::vector<std::string> average_row(const std::string& tracker, const std::vector<SequenceResults>& all) {
  Mean error, precision, auc, success, lost, honest, off_target, reacquire, ms;
  int misses = 0, reappearances = 0, failed = 0;
  for (const SequenceResults& sequence : all)
    for (const TrackerResult& r : sequence.results) {
      if (r.tracker != tracker || !sequence.truth_known) continue;
      if (!r.status.ok()) {
        ++failed;
        continue;
      }
      const TrackScore& s = r.score;
      error.add(s.mean_center_error), precision.add(s.precision20), auc.add(s.success_auc);
      success.add(s.success50), lost.add(s.frames_lost), ms.add(s.ms_per_frame);
      if (s.honest_lost >= 0) honest.add(s.honest_lost);
      off_target.add(s.claimed_off_target);
      if (s.max_reacquire_delay >= 0) reacquire.add(s.max_reacquire_delay);
      misses += s.reacquire_misses, reappearances += s.reappearances;
    }
  std::string reacquire_cell = reacquire.count > 0 || misses == 0 ? reacquire.cell(1) : "";
  if (misses > 0)
    reacquire_cell +=
        (reacquire_cell.empty() ? "never " : ", never ") + std::to_string(misses) + "/" + std::to_string(reappearances);
  const std::string name = failed > 0 ? tracker + " (failed on " + std::to_string(failed) + ")" : tracker;
  return {name,         error.cell(1),  precision.cell(3),  auc.cell(3),    success.cell(3),
          lost.cell(1), honest.cell(2), off_target.cell(1), reacquire_cell, ms.cell(2)};
}

// With several runs per sequence: per sequence and tracker, the spread of
// its measures over the runs.
std::string spread_section(const std::vector<SequenceResults>& all, const std::vector<std::string>& trackers,
                           int runs) {
  std::vector<std::vector<std::string>> rows{
      {"sequence", "tracker", "precision@20 mean [min, max]", "success AUC mean [min, max]",
       "success@0.5 mean [min, max]", "honest lost (mean)", "claimed off target (mean)", "max re-acquisition per run"}};
  std::vector<std::string> names;
  for (const SequenceResults& r : all)
    if (std::find(names.begin(), names.end(), r.sequence) == names.end()) names.push_back(r.sequence);
  for (const std::string& name : names)
    for (const std::string& tracker : trackers) {
      std::vector<double> precision, auc, success;
      Mean honest, off_target;
      std::string reacquisition;
      for (const SequenceResults& sequence : all) {
        if (sequence.sequence != name || !sequence.truth_known) continue;
        for (const TrackerResult& r : sequence.results) {
          if (r.tracker != tracker || !r.status.ok()) continue;
          precision.push_back(r.score.precision20), auc.push_back(r.score.success_auc);
          success.push_back(r.score.success50);
          if (r.score.honest_lost >= 0) honest.add(r.score.honest_lost);
          off_target.add(r.score.claimed_off_target);
          reacquisition += (reacquisition.empty() ? "" : " / ") + reacquisition_cell(r.score);
        }
      }
      if (precision.empty()) continue;
      const auto spread = [](const std::vector<double>& v) {
        double sum = 0;
        for (double x : v) sum += x;
        return fixed(sum / static_cast<double>(v.size()), 3) + " [" + fixed(*std::min_element(v.begin(), v.end()), 3) +
               ", " + fixed(*std::max_element(v.begin(), v.end()), 3) + "]";
      };
      rows.push_back({name, tracker, spread(precision), spread(auc), spread(success), honest.cell(2),
                      off_target.cell(1), reacquisition});
    }
  return "## Spread over " + std::to_string(runs) +
         " runs per sequence (run 0 from the true first box, the others from it moved by up to 1.5 px)\n\n" +
         table(rows) + "\n";
}

// Over the sequences without truth, per tracker: the claimed share's mean,
// the jumps (and the sequences with one), the mean agreement with each other.
std::string witness_summary(const std::vector<SequenceResults>& all, const std::vector<std::string>& trackers) {
  std::vector<std::vector<std::string>> rows{{"tracker", "claimed tracking", "jumps (sequences with one)"}};
  for (const std::string& t : trackers) rows.front().push_back("within 20 px of " + t);
  const auto videos = std::count_if(all.begin(), all.end(), [](const SequenceResults& s) { return !s.truth_known; });
  if (videos == 0) return "";
  for (const std::string& tracker : trackers) {
    Mean claimed;
    std::vector<Mean> agree(trackers.size());
    int jumps = 0, jumping = 0;
    for (const SequenceResults& sequence : all) {
      if (sequence.truth_known) continue;
      for (const TrackerResult& r : sequence.results) {
        if (r.tracker != tracker || !r.status.ok()) continue;
        claimed.add(r.witness.claimed);
        jumps += r.witness.jumps, jumping += r.witness.jumps > 0;
        for (std::size_t k = 0; k < r.agreement.size() && k < agree.size(); ++k)
          if (r.agreement[k] >= 0) agree[k].add(r.agreement[k]);
      }
    }
    std::vector<std::string> row{tracker, claimed.cell(2),
                                 std::to_string(jumps) + " (" + std::to_string(jumping) + ")"};
    for (const Mean& a : agree) row.push_back(a.cell(2));
    rows.push_back(row);
  }
  return "## Without truth, over " + std::to_string(videos) + (videos == 1 ? " video run" : " video runs") + "\n\n" +
         table(rows) + "\n";
}

// Per sequence and tracker, what its frames took: a real-time budget is set
// by the slow frames (a lost target's searches), not by the mean.
std::string time_section(const std::vector<SequenceResults>& all, const std::vector<std::string>& trackers) {
  std::vector<std::vector<std::string>> rows{
      {"sequence", "tracker", "mean", "median", "p99", "max", "not claiming tracking: mean (frames)"}};
  const auto untracked_cell = [](double mean, int frames) {
    return frames > 0 ? fixed(mean, 2) + " (" + std::to_string(frames) + ")" : std::string("- (0)");
  };
  for (const SequenceResults& sequence : all)
    for (const TrackerResult& r : sequence.results) {
      if (!r.status.ok() || r.times.frames == 0) continue;
      const FrameTimes& t = r.times;
      rows.push_back({sequence.name, r.tracker, fixed(t.mean, 2), fixed(t.median, 2), fixed(t.p99, 2), fixed(t.max, 2),
                      untracked_cell(t.untracked_mean, t.untracked_frames)});
    }
  if (rows.size() == 1) return "";
  for (const std::string& tracker : trackers) {
    Mean mean, median, p99;
    double slowest = 0, untracked_sum = 0;
    int untracked = 0;
    for (const SequenceResults& sequence : all)
      for (const TrackerResult& r : sequence.results) {
        if (r.tracker != tracker || !r.status.ok() || r.times.frames == 0) continue;
        mean.add(r.times.mean), median.add(r.times.median), p99.add(r.times.p99);
        slowest = std::max(slowest, r.times.max);
        if (r.times.untracked_frames > 0)
          untracked_sum += r.times.untracked_mean * r.times.untracked_frames, untracked += r.times.untracked_frames;
      }
    if (mean.count == 0) continue;
    rows.push_back({"all (means; max: the slowest)", tracker, mean.cell(2), median.cell(2), p99.cell(2),
                    fixed(slowest, 2), untracked_cell(untracked > 0 ? untracked_sum / untracked : 0, untracked)});
  }
  return "## Time per frame (ms)\n\n" + table(rows) + "\n";
}

// The tracking floors (docs/tracking.md), the fovea tracker's figures against
// CSRT's on the same run of each sequence with truth: precision@20 at least
// CSRT's - 0.02 and success@0.5 at least CSRT's - 0.05; honest lost at least
// 0.9 and every reappearance re-acquired within 15 frames; a frame in at most
// 1/20 of CSRT's time, and at most 0.5 ms from 640x480 on; the success AUC
// averaged over all at least CSRT's. Empty unless both ran.
struct FloorCheck {
  std::vector<std::string> row;
  bool met = true;
};

FloorCheck check_floors(const SequenceResults& sequence, const TrackScore& ours, const TrackScore& csrt) {
  FloorCheck check;
  std::string missed;
  const auto miss = [&](const std::string& what) {
    missed += (missed.empty() ? "" : ", ") + what;
    check.met = false;
  };
  if (ours.precision20 < csrt.precision20 - 0.02) miss("precision");
  if (ours.success50 < csrt.success50 - 0.05) miss("success@0.5");
  if (ours.honest_lost >= 0 && ours.honest_lost < 0.9) miss("honest lost");
  if (ours.reappearances > 0 && (ours.reacquire_misses > 0 || ours.max_reacquire_delay > 15)) miss("re-acquisition");
  const bool vga = sequence.size.area() >= 640 * 480;
  if (ours.ms_per_frame > csrt.ms_per_frame / 20 || (vga && ours.ms_per_frame > 0.5)) miss("time");
  const double ratio = ours.ms_per_frame > 0 ? csrt.ms_per_frame / ours.ms_per_frame : 0;
  const std::string share = csrt.ms_per_frame <= 0 ? "-"
                            : ratio >= 1.5         ? "1/" + fixed(ratio, 0)
                                                   : fixed(ours.ms_per_frame / csrt.ms_per_frame, 2) + " times";
  check.row = {sequence.name,
               fixed(ours.precision20, 3) + " / " + fixed(csrt.precision20, 3),
               fixed(ours.success50, 3) + " / " + fixed(csrt.success50, 3),
               ours.honest_lost >= 0 ? fixed(ours.honest_lost, 2) : "-",
               reacquisition_cell(ours),
               fixed(ours.ms_per_frame, 2) + " (" + share + ")",
               check.met ? "yes" : "no: " + missed};
  return check;
}

std::string floors_section(const std::vector<SequenceResults>& all) {
  std::vector<std::vector<std::string>> rows{{"sequence", "precision@20 (fovea / CSRT)", "success@0.5 (fovea / CSRT)",
                                              "honest lost", "re-acquisition (frames)", "fovea ms (of CSRT's)", "met"}};
  Mean ours_auc, csrt_auc;
  int met = 0;
  for (const SequenceResults& sequence : all) {
    if (!sequence.truth_known) continue;
    const TrackerResult *ours = nullptr, *csrt = nullptr;
    for (const TrackerResult& r : sequence.results) {
      if (r.tracker == "fovea") ours = &r;
      if (r.tracker == "csrt") csrt = &r;
    }
    if (ours == nullptr || csrt == nullptr || !csrt->status.ok()) continue;
    if (!ours->status.ok()) {
      rows.push_back({sequence.name, "", "", "", "", "", "no: failed: " + ours->status.message()});
      continue;
    }
    const FloorCheck check = check_floors(sequence, ours->score, csrt->score);
    rows.push_back(check.row);
    met += check.met;
    ours_auc.add(ours->score.success_auc), csrt_auc.add(csrt->score.success_auc);
  }
  if (rows.size() == 1) return "";
  const bool auc_met = ours_auc.count > 0 && ours_auc.sum >= csrt_auc.sum;
  return "## The floors: fovea against CSRT\n\n"
         "Each sequence's: precision@20 at least CSRT's - 0.02, success@0.5 at least CSRT's - 0.05, honest lost "
         "at least 0.9, every reappearance re-acquired within 15 frames, a frame in at most 1/20 of CSRT's time "
         "(and at most 0.5 ms from 640x480 on); over all, the success AUC's mean at least CSRT's.\n\n" +
         table(rows) + "\n" + std::to_string(met) + " of " + std::to_string(rows.size() - 1) +
         " meet every floor; success AUC averaged " + ours_auc.cell(3) + " against CSRT's " + csrt_auc.cell(3) + " (" +
         (auc_met ? "met" : "not met") + ").\n\n";
}

std::string report(const std::vector<SequenceResults>& all, const std::vector<std::string>& trackers, int runs) {
  std::string out =
      "# Tracking benchmark\n\n"
      "Centre error, precision and success over the frames after the first where the target is visible; "
      "success AUC over IoU thresholds 0, 0.05, ..., 1 (OTB); frames lost: the tracker did not claim "
      "tracking; honest lost: share of the frames without the target where it did not claim tracking; "
      "claimed off target: frames with the target in view where it claimed tracking with a box that does not "
      "touch the target (IoU 0, VOT's failure: a false lock; per sequence, and in the average row its mean); "
      "max re-acquisition: frames after a reappearance until it claims tracking with IoU >= 0.3; "
      "ms/frame: its update alone (fovea: retina + update), one thread, each tracker in its own pass over the "
      "sequence. A video without truth (--video) has witness measures instead: the share of frames claimed, "
      "jumps (the box's centre moving more than 0.75 of its larger side in one frame: most often a switch to "
      "another object), and the share of frames each tracker's box centre is within 20 px of each other's. "
      "Time per frame: each tracker's frames' mean, median, 99th percentile (nearest rank) and slowest, and "
      "the mean over the frames where it did not claim tracking (where a tracker searches).\n\n";
  for (const SequenceResults& sequence : all) out += sequence_section(sequence);
  const auto scored = static_cast<std::size_t>(
      std::count_if(all.begin(), all.end(), [](const SequenceResults& s) { return s.truth_known; }));
  if (runs > 1 && scored > 0) out += spread_section(all, trackers, runs);
  out += witness_summary(all, trackers);
  out += time_section(all, trackers);
  out += floors_section(all);
  if (scored == 0) return out;
  std::vector<std::vector<std::string>> rows{kHeader};
  for (const std::string& tracker : trackers) rows.push_back(average_row(tracker, all));
  // The counts are per sequence there: their average says so.
  for (std::string& heading : rows.front())
    if (heading == "frames lost" || heading == "claimed off target") heading += " (per sequence)";
  out += "## Average over " + std::to_string(scored) + (runs > 1 ? " runs" : " sequences") + "\n\n" + table(rows);
  return out;
}

// --- Main.

// Appends the sequence in each VOT folder of `dirs`.
Status read_vot_folders(const std::vector<std::string>& dirs, std::vector<Sequence>& sequences) {
  for (const std::string& dir : dirs) {
    saccade::Result<Sequence> sequence = read_vot(dir);
    if (!sequence.ok()) return sequence.status();
    sequences.push_back(std::move(sequence).value());
  }
  return {};
}

// Appends every target of each OTB folder of `specs`, "DIR" or "DIR:FIRST"
// (parse_otb_folder).
Status read_otb_folders(const std::vector<std::string>& specs, std::vector<Sequence>& sequences) {
  for (const std::string& spec : specs) {
    saccade::Result<OtbFolder> folder = parse_otb_folder(spec);
    if (!folder.ok()) return Status::error("--otb " + folder.error());
    saccade::Result<std::vector<Sequence>> targets = read_otb_targets(folder->dir, folder->first_image);
    if (!targets.ok()) return Status::error("--otb " + spec + ": " + targets.error());
    for (Sequence& target : *targets) {
      if (!target.note.empty())
        std::fprintf(stderr,
                     "note: %s: %s; if the truth starts at a later image, give it as --otb DIR:FIRST (OTB's David: "
                     "David:300)\n",
                     target.name.c_str(), target.note.c_str());
      sequences.push_back(std::move(target));
    }
  }
  return {};
}

// The generated sequences and those read from folders, kept and shortened as
// the options say; or the error naming the image, file or folder at fault.
saccade::Result<std::vector<Sequence>> load_sequences(const Options& options) {
  std::vector<Sequence> sequences;
  const auto shaped = [&](std::vector<SyntheticScript> scripts) {
    if (options.round) scripts = with_round_targets(std::move(scripts));
    return options.turn > 0 ? with_turning_targets(std::move(scripts), options.turn) : scripts;
  };
  if (!options.no_generated) {
    saccade::Result<std::vector<Sequence>> generated = generate_sequences(options.data, shaped(standard_scripts()));
    if (!generated.ok()) return generated.status();
    sequences = std::move(generated).value();
  }
  if (options.holdout) {
    saccade::Result<std::vector<Sequence>> held_out = generate_sequences(options.data, shaped(holdout_scripts()));
    if (!held_out.ok()) return held_out.status();
    for (Sequence& s : *held_out) sequences.push_back(std::move(s));
  }
  for (const int set : options.fresh) {
    saccade::Result<std::vector<Sequence>> fresh = generate_sequences(options.data, shaped(fresh_scripts(set)));
    if (!fresh.ok()) return fresh.status();
    for (Sequence& s : *fresh) sequences.push_back(std::move(s));
  }
  if (Status read = read_otb_folders(options.otb, sequences); !read.ok()) return read;
  if (Status read = read_vot_folders(options.vot, sequences); !read.ok()) return read;
  for (const std::string& spec : options.videos) {
    const saccade::Result<VideoTarget> target = parse_video_target(spec);
    if (!target.ok()) return target.status();
    saccade::Result<Sequence> video = read_video(*target);
    if (!video.ok()) return Status::error("--video " + spec + ": " + video.error());
    if (!video->note.empty()) std::fprintf(stderr, "note: %s: %s\n", video->name.c_str(), video->note.c_str());
    sequences.push_back(std::move(video).value());
  }
  const std::vector<std::string> keep = split_list(options.sequences);
  for (const std::string& name : keep)
    if (std::none_of(sequences.begin(), sequences.end(), [&](const Sequence& s) { return s.name == name; })) {
      std::string known;
      for (const Sequence& s : sequences) known += (known.empty() ? "" : ", ") + s.name;
      return Status::error("--sequences: no sequence '" + name + "' (known: " + known + ")");
    }
  if (!keep.empty())
    std::erase_if(sequences,
                  [&](const Sequence& s) { return std::find(keep.begin(), keep.end(), s.name) == keep.end(); });
  for (Sequence& s : sequences) {
    if (Status resampled = resample(s, options.every, options.scale); !resampled.ok())
      return Status::error("--every/--scale: " + resampled.message());
    // In a camera's order: the white balance, then the gray a monochrome
    // output keeps, then the compression.
    if (options.white_balance > 0)
      if (Status balanced = make_white_balance(s, options.white_balance); !balanced.ok())
        return Status::error("--white-balance: " + balanced.message());
    if (options.gray) make_gray(s);
    if (options.jpeg > 0)
      if (Status compressed = make_jpeg(s, options.jpeg); !compressed.ok())
        return Status::error("--jpeg: " + compressed.message());
    truncate(s, options.frames);
  }
  make_names_unique(sequences, [](Sequence& s) -> std::string& { return s.name; });
  return sequences;
}

// The fovea node's parameters --set names, checked as in a graph, into
// options.box; false (the reason printed) on one that is not.
bool apply_sets(Options& options) {
  if (options.sets.empty()) return true;
#if SACCADE_TRACK_BENCH_FOVEA
  const auto settings = saccade::split_settings(options.sets);
  const saccade::Result<saccade::fovea::ControllerConfig> configured =
      settings.ok() ? saccade::configure(&saccade::fovea::bind_fovea_params, *settings) : settings.status();
  if (!configured.ok()) {
    std::cerr << "saccade_track_bench: --set: " << configured.error() << "\n";
    return false;
  }
  options.box = configured->box;
  std::cerr << "the fovea tracker with";
  for (const std::string& s : options.sets) std::cerr << " " << s;
  std::cerr << "\n";
  return true;
#else
  std::cerr << "saccade_track_bench: --set: built without the fovea tracker\n";
  return false;
#endif
}

// --export: each sequence with truth as an OTB folder DIR/<its name>.
int export_sequences(const std::vector<Sequence>& sequences, const std::string& dir) {
  for (const Sequence& sequence : sequences) {
    if (!sequence.truth_known) {
      std::cerr << "note: " << sequence.name << " left out: a video's only known box is its first\n";
      continue;
    }
    const std::string to = dir + "/" + sequence.name;
    if (const Status written = write_otb(sequence, to); !written.ok()) {
      std::cerr << "error: --export " << written.message() << "\n";
      return 1;
    }
    std::cout << to << ": " << sequence.size() << " frames, " << sequence.frame_size.width << "x"
              << sequence.frame_size.height << "\n";
  }
  return 0;
}

int run(const Options& options) {
  const std::vector<std::string> trackers = split_list(options.trackers);
  for (const std::string& name : trackers)
    if (!make_tracker(name, options.box)) {
      std::cerr << "unknown tracker '" << name << "' (known: " << (SACCADE_TRACK_BENCH_FOVEA ? "fovea, " : "")
                << "csrt, kcf, mil)\n";
      return 2;
    }
  const saccade::Result<std::vector<Sequence>> loaded = load_sequences(options);
  if (!loaded.ok()) {
    std::cerr << "error: " << loaded.error() << "\n";
    return 1;
  }
  const std::vector<Sequence>& sequences = *loaded;
  if (!options.export_dir.empty()) return export_sequences(sequences, options.export_dir);
  if (sequences.empty()) {
    std::cerr << "no sequences to run\n";
    return 2;
  }
  if (!options.jumps.empty())
    if (Status started = start_jumps(options.jumps); !started.ok()) {
      std::cerr << "error: " << started.message() << "\n";
      return 1;
    }
  std::vector<SequenceResults> results;
  for (const Sequence& sequence : sequences)
    for (int run = 0; run < options.runs; ++run) {
      std::cerr << "running " << sequence.name << " (" << sequence.size() << " frames)"
                << (options.runs > 1 ? ", run " + std::to_string(run) : "") << "\n";
      saccade::Result<SequenceResults> result = run_sequence(sequence, trackers, options, run);
      if (!result.ok()) {
        std::cerr << "error: " << result.error() << "\n";
        return 1;
      }
      results.push_back(std::move(result).value());
    }
  const std::string text = report(results, trackers, options.runs);
  std::cout << text;
  if (!options.markdown.empty()) {
    std::ofstream file(options.markdown);
    if (!(file << text)) {
      std::cerr << "cannot write " << options.markdown << "\n";
      return 1;
    }
  }
  return 0;
}

// The options that show every sequence as another camera would: its frame
// rate, resolution, colours, compression and white balance.
void add_camera_options(CLI::App& app, Options& options) {
  app.add_option("--every", options.every,
                 "N: every Nth frame of each sequence, as a camera of 1/N the frame rate sees it (the target "
                 "moving N times as far between frames)")
      ->check(CLI::Range(1, 100));
  app.add_option("--scale", options.scale, "F: each sequence's frames and truth resized by F (0.1 to 8)")
      ->check(CLI::Range(0.1, 8.0));
  app.add_flag("--gray", options.gray,
               "each sequence as a monochrome camera sees it: its frames' gray in all three channels (name@gray)");
  app.add_option("--jpeg", options.jpeg,
                 "Q: each frame through a JPEG of quality Q (1-100), as a recorded video's or a network camera's "
                 "(name@jpegQ)")
      ->check(CLI::Range(1, 100));
  app.add_option("--white-balance", options.white_balance,
                 "A: each frame as a camera whose white balance drifts sees it: red times 1 + A sin(2 pi i / 150), "
                 "blue times 1 - A sin(...), A from 0.01 to 0.5, as an automatic white balance warms and cools the "
                 "image (name@wbA)")
      ->check(CLI::Range(0.01, 0.5));
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app{"Tracking benchmark: the fovea box tracker against OpenCV's CSRT, KCF and MIL"};
  app.add_option("--data", options.data, "OpenCV's sample data folder (the generated sequences' images)");
  app.add_option("--otb", options.otb,
                 "an OTB sequence folder (img/, groundtruth_rect.txt or .1.txt, .2.txt ... for several targets), "
                 "as DIR:FIRST when the truth starts at image FIRST (OTB's David:300); repeatable");
  app.add_option("--vot", options.vot,
                 "a VOT sequence folder (groundtruth.txt; frames beside it, in color/ or, as LaSOT, in img/; GOT-10k "
                 "too); repeatable");
  app.add_option("--video", options.videos,
                 "FILE:FIRST:x,y,w,h[:COUNT]: a video without truth, the box in frame FIRST (0-based), followed for "
                 "COUNT frames (to the end when left out) and scored by witness measures (claimed share, jumps, "
                 "agreement between the trackers); repeatable");
  app.add_flag("--no-generated", options.no_generated, "leave out the generated sequences");
  app.add_flag("--holdout", options.holdout,
               "also the held-out generated set: the same scripts with other targets, backgrounds and seeds "
               "(holdout_<name>)");
  app.add_option("--fresh", options.fresh,
                 "K[,K...]: also fresh generated sets, as many as wanted: the same scripts with a target and a "
                 "background drawn by K from opencv-doc's pictures (fresh<K>_<name>; nothing was tuned on them)")
      ->delimiter(',')
      ->check(CLI::Range(1, 1000000));
  app.add_option("--trackers", options.trackers, "comma-separated trackers to run")->capture_default_str();
  app.add_option("--sequences", options.sequences, "comma-separated sequence names to keep (default all)");
  app.add_option("--frames", options.frames, "at most this many frames per sequence (quick runs)");
  app.add_flag("--round", options.round,
               "the generated targets cut as the ellipse inscribed in their box, its corners showing the moving "
               "scene behind, as around a real ball or face (name@round)");
  app.add_option("--turn", options.turn,
                 "A: the generated targets turning about their vertical axis, back and forth by up to A degrees "
                 "(1-180) over about 150 frames: each picture wrapped round a cylinder, its back half the mirror "
                 "image, so the box's contents change as a head's or a ball's do when it turns (name@turnA)")
      ->check(CLI::Range(1.0, 180.0));
  add_camera_options(app, options);
  app.add_option("--markdown", options.markdown, "also write the tables to this Markdown file");
  app.add_option("--runs", options.runs,
                 "runs per sequence: run 0 from the true first box, the others from it moved by up to 1.5 px "
                 "(the spread of each measure over them is reported)")
      ->check(CLI::Range(1, 100));
  app.add_option("--trace", options.trace,
                 "write each tracker's frames to FOLDER/<sequence>_<tracker>.csv (truth, box, state, confidence, IoU)");
  app.add_option("--jumps", options.jumps,
                 "FILE: a CSV line per jump of every tracker (the box's centre moving more than 0.75 of its larger "
                 "side in a frame): from where to where, its state and confidence, whether it was right (with "
                 "truth), and how much of the first box's tones and colours the box it jumped to has");
  app.add_option("--set", options.sets,
                 "key=value: the fovea tracker with the fovea node's box_* parameter changed so (repeatable; "
                 "docs/plugins.md)");
  app.add_option("--export", options.export_dir,
                 "FOLDER: write the sequences with truth in the OTB layout (FOLDER/<sequence>/img/0001.png ..., "
                 "groundtruth_rect.txt; NaN rows where the target is hidden) instead of running them");
  // A value given twice is the last one: make's TRACK_ARGS can change what a target gives.
  for (const char* single : {"--data", "--trackers", "--sequences", "--frames", "--every", "--scale", "--turn",
                             "--jpeg", "--white-balance", "--markdown", "--runs", "--trace", "--jumps", "--export"})
    app.get_option(single)->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  CLI11_PARSE(app, argc, argv);
  if (!apply_sets(options)) return 2;
  if ((options.round || options.turn > 0) && options.no_generated && !options.holdout && options.fresh.empty()) {
    std::fprintf(stderr, "%s, and no generated sequence is chosen (--no-generated without --holdout or --fresh)\n",
                 options.round ? "--round cuts the generated targets round" : "--turn turns the generated targets");
    return 2;
  }
  // One thread for everything: the times compare the algorithms, not how
  // well each spreads over cores.
  cv::setNumThreads(1);
  return run(options);
}
