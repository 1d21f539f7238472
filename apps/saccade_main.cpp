// saccade: run, check, list and draw plugin graphs.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>

#include <unistd.h>

#include "calibrate_command.hpp"
#include "command_line.hpp"
#include "completion.hpp"
#include "progress.hpp"
#include "recognition.hpp"
#include "recording.hpp"
#include "saccade/executor.hpp"
#include "saccade/graph.hpp"
#include "saccade/log.hpp"
#include "saccade/partition.hpp"
#include "saccade/plugin.hpp"
#include "saccade/registry.hpp"
#include "saccade/cdr.hpp"
#include "saccade/schema.hpp"
#include "view_server.hpp"

namespace {

using namespace saccade;
using saccade::cli::CompletionArgs;
using saccade::cli::GraphArgs;
using saccade::cli::GraphOverrides;
using saccade::cli::PluginsArgs;
using saccade::cli::RunArgs;
using saccade::cli::TrainArgs;
using Common = saccade::cli::Common;

std::atomic<bool> g_stop{false};
std::atomic<int> g_signal{0};  // the signal that stopped the run

extern "C" void on_signal(int sig) {
  g_signal.store(sig);
  g_stop.store(true);
  // A second Ctrl-C ends the process the hard way.
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  std::signal(SIGHUP, SIG_DFL);
}

void load_registry(Registry& registry, const Common& common, bool show_errors) {
  registry.load_folders(Registry::default_search_path(common.plugin_path));
  if (show_errors)
    for (const auto& e : registry.load_errors()) std::cerr << "warning: " << e << "\n";
}

// Loads, overrides and validates; prints every diagnostic. Empty on error.
std::optional<ResolvedGraph> prepare(const std::string& file, const std::vector<std::string>& sets,
                                     const Registry& registry, const GraphOverrides& overrides) {
  Diagnostics diag;
  GraphDecl decl = load_graph_file(file, diag);
  if (!diag.has_errors()) apply_overrides(decl, sets, diag);
  if (overrides.domain >= 0) decl.domain = overrides.domain;
  if (!overrides.topic_prefix.empty()) decl.topic_prefix = overrides.topic_prefix;
  std::optional<ResolvedGraph> graph;
  if (!diag.has_errors()) graph = resolve_graph(decl, registry, diag);
  std::cerr << diag.format();
  if (diag.has_errors()) {
    std::cerr << diag.error_count() << " error" << (diag.error_count() == 1 ? "" : "s") << " in " << file
              << "; nothing was started\n";
    return std::nullopt;
  }
  return graph;
}

std::string param_default(const ParamSpec& p) {
  if (p.required) return "(required)";
  if (p.default_value.empty()) return "(none)";
  return p.default_value;
}

std::string param_range(const ParamSpec& p) {
  std::string out;
  if (p.min || p.max) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "[%g, %g]", p.min.value_or(-1e300), p.max.value_or(1e300));
    out = buf;
  }
  if (!p.choices.empty()) {
    for (std::size_t i = 0; i < p.choices.size(); ++i) out += (i ? "|" : "") + p.choices[i];
  }
  return out;
}

std::string kind_name(InputKind k) {
  switch (k) {
    case InputKind::kTrigger: return "required";
    case InputKind::kOptional: return "optional";
    case InputKind::kSide: return "side";
  }
  return "";
}

void print_plugin_text(const NodeTypeInfo& info) {
  const Contract& c = info.contract;
  std::printf("%s\n  %s\n  library: %s\n", info.type.c_str(), c.doc().c_str(), info.library.c_str());
  if (!c.inputs().empty()) std::printf("  inputs:\n");
  for (const auto& p : c.inputs())
    std::printf("    %-16s %-12s %-9s %s\n", p.name.c_str(), p.type.c_str(), kind_name(p.kind).c_str(), p.doc.c_str());
  if (!c.outputs().empty()) std::printf("  outputs:\n");
  for (const auto& p : c.outputs()) std::printf("    %-16s %-12s %s\n", p.name.c_str(), p.type.c_str(), p.doc.c_str());
  if (!c.params().empty()) std::printf("  parameters:\n");
  for (const auto& p : c.params())
    std::printf("    %-20s %-7s default %-12s %s  %s\n", p.name.c_str(), std::string(to_string(p.type)).c_str(),
                param_default(p).c_str(), param_range(p).c_str(), p.doc.c_str());
  std::printf("\n");
}

std::string md_cell(std::string text) {
  for (std::size_t i = 0; (i = text.find('|', i)) != std::string::npos; i += 2) text.insert(i, "\\");
  return text;
}

// The JSON every message type is written as (util.jsonl), from the fields
// each type names once (saccade/schema.hpp).
void print_message_schemas_markdown() {
  std::printf(
      "# Messages as JSON\n\nWhat `util.jsonl` writes: one object per message, `type`, `frame` (the frame id), "
      "`stamp_ns` (capture time), `origin_ns`, then the type's fields in order. Matrices appear by shape "
      "(`rows`, `cols`, `depth` as OpenCV's CV_8U = 0 ... CV_64F = 6, `channels`), not by pixels; "
      "non-finite numbers are `null`. The JSON Schema of each type:\n\n");
  for (std::string_view type : saccade::described_message_types())
    std::printf("## %.*s\n\n```json\n%s\n```\n\n", static_cast<int>(type.size()), type.data(),
                saccade::json_schema(type).c_str());
}

void print_plugin_markdown(const NodeTypeInfo& info) {
  const Contract& c = info.contract;
  std::printf("## `%s`\n\n%s\n\n", info.type.c_str(), c.doc().c_str());
  if (!c.inputs().empty()) {
    std::printf("| input | type | kind | doc |\n|---|---|---|---|\n");
    for (const auto& p : c.inputs())
      std::printf("| `%s` | %s | %s | %s |\n", p.name.c_str(), p.type.c_str(), kind_name(p.kind).c_str(),
                  p.doc.c_str());
    std::printf("\n");
  }
  if (!c.outputs().empty()) {
    std::printf("| output | type | doc |\n|---|---|---|\n");
    for (const auto& p : c.outputs())
      std::printf("| `%s` | %s | %s |\n", p.name.c_str(), p.type.c_str(), p.doc.c_str());
    std::printf("\n");
  }
  if (!c.params().empty()) {
    std::printf("| parameter | type | default | range / choices | doc |\n|---|---|---|---|---|\n");
    for (const auto& p : c.params())
      std::printf("| `%s` | %s | `%s` | %s | %s |\n", p.name.c_str(), std::string(to_string(p.type)).c_str(),
                  param_default(p).c_str(), md_cell(param_range(p)).c_str(), md_cell(p.doc).c_str());
    std::printf("\n");
  }
}

int train_command(TrainArgs& args) {
  if (Status options = saccade::cli::parse_training_options(args); !options.ok()) {
    std::cerr << "saccade train: " << options.message() << "\n";
    return 2;
  }
  if (args.training.data.empty() == args.samples.empty()) {
    std::cerr << "saccade train: give either a data folder or --samples FILE\n";
    return 2;
  }
  if (!args.samples.empty()) {
    // The recipe is the one the graph collected with.
    Result<classifier::SampleSet> samples = classifier::SampleSet::load(args.samples);
    if (!samples.ok()) {
      std::cerr << "saccade train: " << samples.error() << "\n";
      return 2;
    }
    Result<classifier::TrainingResult> result = classifier::train_rows(*samples, args.training, std::cout);
    if (!result.ok()) std::cerr << "saccade train: " << result.error() << "\n";
    return result.ok() ? 0 : 2;
  }
  Result<classifier::TrainingResult> result = classifier::train_folder(args.training, std::cout);
  if (!result.ok()) std::cerr << "saccade train: " << result.error() << "\n";
  return result.ok() ? 0 : 2;
}

int plugins_command(const Common& common, const PluginsArgs& args) {
  Registry registry;
  load_registry(registry, common, true);
  const bool reference = args.markdown && args.name.empty();
  if (reference)
    std::printf(
        "# Plugin reference\n\nGenerated from the plugins' own contracts by `saccade plugins --markdown`; a test "
        "fails when\nthis file and the built plugins disagree (regenerate with `make docs`).\n\n");
  int shown = 0;
  for (const auto& type : registry.types()) {
    if (!args.name.empty() && type != args.name && type.rfind(args.name + ".", 0) != 0) continue;
    const NodeTypeInfo* info = registry.find(type);
    if (args.names)
      std::printf("%s\n", type.c_str());
    else if (args.markdown)
      print_plugin_markdown(*info);
    else
      print_plugin_text(*info);
    ++shown;
  }
  if (shown == 0) {
    std::cerr << "no plugin '" << args.name << "'" << did_you_mean(args.name, registry.types()) << " ("
              << registry.searched_summary() << ")\n";
    return 2;
  }
  if (reference) print_message_schemas_markdown();
  return 0;
}

// A graph checked, planned and, with --process, cut to that process's part.
// The caller owns it: the plan points into the graph's edges.
struct LoadedGraph {
  std::optional<ResolvedGraph> graph;
  std::optional<GraphPlan> plan;  // after a --process cut, only when asked for
};

// Prints every diagnostic; false on error.
bool load_graph(const GraphArgs& args, const Registry& registry, bool keep_plan, LoadedGraph& out) {
  out.graph = prepare(args.file, args.sets, registry, args.overrides);
  if (!out.graph) return false;
  Diagnostics diag;
  out.plan = plan_graph(*out.graph, diag);
  if (!args.process.empty() && out.plan) {
    out.graph = partition_graph(*out.graph, *out.plan, args.process, registry, diag);
    // The old plan points into the graph it replaced; only `plan` needs the new one.
    out.plan = out.graph && keep_plan ? plan_graph(*out.graph, diag) : std::nullopt;
  }
  std::cerr << diag.format();
  return !diag.has_errors();
}

int plan_command(const Common& common, const GraphArgs& args) {
  Registry registry;
  load_registry(registry, common, false);
  LoadedGraph loaded;
  if (!load_graph(args, registry, true, loaded)) return 2;
  std::printf("%s", format_plan(*loaded.graph, *loaded.plan).c_str());
  return 0;
}

int check_command(const Common& common, const GraphArgs& args) {
  Registry registry;
  load_registry(registry, common, false);
  LoadedGraph loaded;
  if (!load_graph(args, registry, false, loaded)) return 2;
  if (args.open) {
    // What run would refuse at open: a missing file, a bad model, a calibration for other images.
    Executor executor(*loaded.graph, registry, {});
    if (Status status = executor.open(); !status.ok()) {
      std::cerr << args.file << ": error: " << status.message() << "\n";
      return 1;
    }
  }
  std::printf("%s: ok (%zu nodes, %zu edges%s)\n", args.file.c_str(), loaded.graph->nodes.size(),
              loaded.graph->edges.size(), args.open ? ", every node opened" : "");
  return 0;
}

int dot_command(const Common& common, const GraphArgs& args) {
  Registry registry;
  load_registry(registry, common, false);
  LoadedGraph loaded;
  if (!load_graph(args, registry, false, loaded)) return 2;
  std::printf("%s", to_dot(*loaded.graph).c_str());
  return 0;
}

int completion_command(const CLI::App& app, const CompletionArgs& args) {
  const std::string script = saccade::cli::bash_completion(app);
  if (args.out.empty()) {
    std::fputs(script.c_str(), stdout);
    return 0;
  }
  std::ofstream out(args.out);
  out << script;
  if (!out.flush()) {
    std::cerr << "saccade completion: cannot write " << args.out << "\n";
    return 2;
  }
  return 0;
}

// --record: every edge recorded from here on; 0 or the command's exit status.
int attach_recording(const RunArgs& args, Executor& executor, std::unique_ptr<saccade::mcap::GraphRecorder>& recorder) {
  if (args.record.empty()) return 0;
  saccade::mcap::RecorderOptions ro;
  saccade::mcap::parse_compression(args.record_compression, ro.writer.compression);
  ro.lossless = args.record_lossless;
  Result<std::unique_ptr<saccade::mcap::GraphRecorder>> attached =
      saccade::mcap::attach_recorder(executor, args.record, ro);
  if (!attached.ok()) {
    std::cerr << "saccade run: --record: " << attached.error() << "\n";
    return 1;
  }
  recorder = std::move(attached).value();
  return 0;
}

// --view: the live view's server started; 0 or the command's exit status.
int attach_view(const RunArgs& args, Executor& executor, std::unique_ptr<saccade::view::ViewServer>& server) {
  if (args.view.empty()) return 0;
  saccade::view::ViewOptions vo;
  vo.cpu_share = args.view_cpu;
  if (Status address = saccade::view::parse_view_address(args.view, vo); !address.ok()) {
    std::cerr << "saccade run: " << address.message() << "\n";
    return 2;
  }
  Result<std::unique_ptr<saccade::view::ViewServer>> started = saccade::view::start_view(executor, vo);
  if (!started.ok()) {
    std::cerr << "saccade run: " << started.error() << "\n";
    return 1;
  }
  server = std::move(started).value();
  std::cerr << "view: " << server->url() << " (Foxglove: ws://" << vo.address << ":" << server->port() << ")\n";
  return 0;
}

// After the run: the recording closed and reported, the stats printed and
// written; the run's status, or what of those failed when the run did not.
Status report_run(const RunArgs& args, bool stats, Executor& executor, saccade::mcap::GraphRecorder* recorder,
                  Status status) {
  if (recorder != nullptr) {
    if (Status finished = recorder->finish(); !finished.ok()) {
      std::cerr << "saccade run: --record: " << finished.message() << "\n";
      if (status.ok()) status = Status::error("the recording is incomplete");
    }
    std::cerr << recorder->report() << "\n";
  }
  if (stats) std::printf("%s", executor.stats_table().c_str());
  if (!args.stats_json.empty()) {
    std::ofstream out(args.stats_json);
    out << executor.stats_json();
    if (!out.flush()) {
      std::cerr << "saccade run: --stats-json: cannot write " << args.stats_json << "\n";
      if (status.ok()) status = Status::error("the stats were not written");
    }
  }
  return status;
}

int run_command(const Common& common, const GraphArgs& graph_args, RunArgs& args) {
  const bool stats = args.stats->count() > 0;
  Registry registry;
  load_registry(registry, common, false);
  LoadedGraph loaded;
  if (!load_graph(graph_args, registry, false, loaded)) return 2;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  // A closed terminal stops the run cleanly too (its shared memory removed,
  // its stats written); a reader gone from a pipe is a write error, not death.
  std::signal(SIGHUP, on_signal);
  std::signal(SIGPIPE, SIG_IGN);
  ExecutorOptions& options = args.options;
  options.external_stop = &g_stop;
  options.stats_interval_s = stats ? args.stats_interval : 0;
  std::unique_ptr<saccade::cli::ProgressLine> progress;  // made after open(), when the sources know their length
  options.on_stats = [&progress](const std::string& table) {
    if (progress)
      progress->print_above(table + "\n");
    else
      std::fprintf(stderr, "%s\n", table.c_str());
  };
  // A stats file that cannot be written is said now, not after the run.
  if (!args.stats_json.empty() && !std::ofstream(args.stats_json, std::ios::app)) {
    std::cerr << "saccade run: --stats-json: cannot write " << args.stats_json << "\n";
    return 2;
  }
  Executor executor(*loaded.graph, registry, options);
  Status status = executor.open();
  if (!status.ok()) {
    std::cerr << graph_args.file << ": error: " << status.message() << "\n";
    return 1;
  }
  // What watches the run (taps, a viewer, a recorder) attaches here, between open() and run().
  std::unique_ptr<saccade::mcap::GraphRecorder> recorder;
  if (const int exit = attach_recording(args, executor, recorder); exit != 0) return exit;
  std::unique_ptr<saccade::view::ViewServer> view_server;  // stopped before the executor goes
  if (const int exit = attach_view(args, executor, view_server); exit != 0) return exit;
  if (args.progress) {
    progress = std::make_unique<saccade::cli::ProgressLine>(executor, options.max_frames, options.duration_s, stderr,
                                                            isatty(STDERR_FILENO) != 0);
    progress->start();
  }
  status = executor.run();
  if (progress) progress->stop();
  if (view_server) view_server->stop();
  status = report_run(args, stats, executor, recorder.get(), status);
  if (!status.ok()) {
    std::cerr << graph_args.file << ": error: " << status.message() << "\n";
    return 1;
  }
  // Stopped cleanly by Ctrl-C (or SIGTERM): 128 + the signal, as a shell reports a killed command.
  if (const int sig = g_signal.load(); sig != 0) {
    std::cerr << "stopped by "
              << (sig == SIGINT    ? "SIGINT"
                  : sig == SIGTERM ? "SIGTERM"
                  : sig == SIGHUP  ? "SIGHUP"
                                   : "a signal")
              << "\n";
    return 128 + sig;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  saccade::cli::CommandLine line;
  if (std::optional<int> status = saccade::cli::parse_command_line(line, argc, argv, std::cout, std::cerr))
    return *status;
  log().set_level(spdlog::level::from_str(line.common.log_level));
  // The DDS plugin reads it when it creates the process's participant.
  if (!line.run_args.security.empty()) setenv("SACCADE_DDS_SECURITY", line.run_args.security.c_str(), 1);
  if (line.completion->parsed()) return completion_command(line.app, line.completion_args);
  if (line.train->parsed()) return train_command(line.train_args);
  if (line.calibrate->parsed()) return calibrate_command(line.calibrate_args);
  if (line.plugins->parsed()) return plugins_command(line.common, line.plugins_args);
  if (line.plan->parsed()) return plan_command(line.common, line.graph);
  if (line.check->parsed()) return check_command(line.common, line.graph);
  if (line.dot->parsed()) return dot_command(line.common, line.graph);
  if (line.idl->parsed()) {
    std::cout << saccade::cdr::idl();
    return 0;
  }
  // Exactly one subcommand parsed: what is left is run.
  return run_command(line.common, line.graph, line.run_args);
}
