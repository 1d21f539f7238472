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

#include <unistd.h>

#include "calibrate_command.hpp"
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
#include "saccade/schema.hpp"
#include "view_server.hpp"

namespace {

using namespace saccade;

#ifndef SACCADE_VERSION
#define SACCADE_VERSION "unknown"
#endif

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

struct Common {
  std::string plugin_path;
  std::string log_level = "info";
};

void load_registry(Registry& registry, const Common& common, bool show_errors) {
  registry.load_folders(Registry::default_search_path(common.plugin_path));
  if (show_errors)
    for (const auto& e : registry.load_errors()) std::cerr << "warning: " << e << "\n";
}

// Graph attributes the command line may override.
struct GraphOverrides {
  int domain = -1;
  std::string topic_prefix;
};

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
  std::printf("# Messages as JSON\n\nWhat `util.jsonl` writes: one object per message, `type`, `frame` (the frame id), "
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
      std::printf("| `%s` | %s | %s | %s |\n", p.name.c_str(), p.type.c_str(), kind_name(p.kind).c_str(), p.doc.c_str());
    std::printf("\n");
  }
  if (!c.outputs().empty()) {
    std::printf("| output | type | doc |\n|---|---|---|\n");
    for (const auto& p : c.outputs()) std::printf("| `%s` | %s | %s |\n", p.name.c_str(), p.type.c_str(), p.doc.c_str());
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

// The options of run, plan, check and dot: each reads and resolves a graph.
struct GraphArgs {
  std::string file;
  std::vector<std::string> sets;
  std::string process;
  GraphOverrides overrides;
  bool open = false;  // check: also open every node, as run would
};

// run's options: one field here and one line in add_run_command per option.
struct RunArgs {
  ExecutorOptions options;
  double stats_interval = 0;
  CLI::Option* stats = nullptr;  // given at all: print the table at exit
  std::string stats_json;
  std::string security;
  bool progress = isatty(STDERR_FILENO) != 0;  // the progress line: on a terminal unless told
  std::string record;                          // an MCAP file of every edge
  std::string record_compression = "zstd";
  bool record_lossless = false;
  std::string view;                            // [ADDR:]PORT of the live view
};

struct PluginsArgs {
  std::string name;
  bool markdown = false;
  bool names = false;
};

struct CompletionArgs {
  std::string shell = "bash";
  std::string out;
};

struct TrainArgs {
  classifier::FolderTraining training;
  std::string levels = "0", features = "gray,grad_hist", hidden = "128", method = "backprop";
  std::string size = "8x6";
  std::string samples;
};

// Accepted before or after the subcommand (the subcommands fall through to them).
void add_global_options(CLI::App& app, Common& common) {
  app.set_version_flag("--version", std::string("saccade ") + SACCADE_VERSION + " (plugin ABI " +
                                        std::to_string(kAbiVersion) + ")");
  app.add_option("--plugin-path", common.plugin_path, "extra plugin folders, ':'-separated (searched first)");
  app.add_option("--log-level", common.log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
}

// A number that must be finite and above `min` (or at least it): NaN passes
// CLI11's own range checks, and their messages print DBL_MAX in full.
CLI::Validator finite_above(double min, bool or_equal, const std::string& what) {
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        const bool ok = end != text.c_str() && *end == '\0' && std::isfinite(v) && (or_equal ? v >= min : v > min);
        return ok ? std::string() : "expected " + what + ", got '" + text + "'";
      },
      what);
}

CLI::App* add_run_command(CLI::App& app, GraphArgs& graph, RunArgs& args) {
  auto* run = app.add_subcommand("run", "run a graph");
  run->add_option("graph", graph.file, "graph file (XML)")->required();
  run->add_option("--frames", args.options.max_frames, "stop each source after N frames")
      ->check(finite_above(0, false, "a positive number of frames"));
  // NaN and -1 ran forever.
  run->add_option("--duration", args.options.duration_s, "stop after S seconds")
      ->check(finite_above(0, false, "a positive number of seconds"));
  run->add_option("--threads", args.options.threads, "worker threads (default: one per core)")->check(CLI::Range(0, 256));
  run->add_flag("--deterministic", args.options.deterministic, "one thread, fixed order: same input, bit-identical output");
  args.stats = run->add_option("--stats", args.stats_interval, "print per-node stats at exit, and every INTERVAL seconds if given")
                   ->expected(0, 1)
                   ->default_val(0)
                   ->check(finite_above(0, true, "an interval of 0 or more seconds"));
  run->add_option("--stats-json", args.stats_json, "write the final stats as JSON to FILE");
  run->add_option("--record", args.record, "record every edge to FILE (MCAP; docs/recording.md)");
  run->add_option("--record-compression", args.record_compression, "the recording's chunks: zstd, lz4 or none")
      ->check(CLI::IsMember({"zstd", "lz4", "none"}));
  run->add_flag("--record-lossless", args.record_lossless,
                "the recorder never drops: a full queue makes the graph wait (default: drop and count)");
  run->add_option("--view", args.view,
                  "[ADDR:]PORT: a live view, Foxglove's WebSocket protocol and a page (loopback unless ADDR; "
                  "docs/view.md)");
  run->add_option("--set", graph.sets, "override a parameter: node.param=value (repeatable)");
  run->add_option("--process", graph.process,
                  "run only this process's part of the graph; its edges to other processes become DDS topics");
  run->add_option("--domain", graph.overrides.domain, "DDS domain of the edges between processes (default: the graph's)")
      ->check(CLI::Range(0, 232));
  run->add_option("--topic-prefix", graph.overrides.topic_prefix,
                  "prefix of their DDS topics (default: the graph's topic_prefix, else its name)");
  run->add_option("--security", args.security,
                  "DDS Security: this participant's folder made by scripts/make-security.sh (sets SACCADE_DDS_SECURITY)")
      ->check(CLI::ExistingDirectory);
  run->add_flag("--progress,!--no-progress", args.progress,
                "a progress line on stderr: frames (of how many), rate, ETA (default: when stderr is a terminal)");
  return run;
}

CLI::App* add_plan_command(CLI::App& app, GraphArgs& graph) {
  auto* plan = app.add_subcommand("plan", "print which node runs in which process and how each edge travels");
  plan->add_option("graph", graph.file, "graph file (XML)")->required();
  plan->add_option("--set", graph.sets, "override a parameter: node.param=value (repeatable)");
  plan->add_option("--process", graph.process, "show this process's part, with its DDS bridge nodes");
  plan->add_option("--domain", graph.overrides.domain, "DDS domain")->check(CLI::Range(0, 232));
  plan->add_option("--topic-prefix", graph.overrides.topic_prefix, "prefix of the DDS topics");
  return plan;
}

CLI::App* add_check_command(CLI::App& app, GraphArgs& graph) {
  auto* check = app.add_subcommand("check", "validate a graph without running it");
  check->add_option("graph", graph.file, "graph file (XML)")->required();
  check->add_option("--set", graph.sets, "override a parameter: node.param=value (repeatable)");
  check->add_flag("--open", graph.open,
                  "also open every node as run would (files, models, calibrations; and devices, DDS participants "
                  "and sockets, which must then be there), then close them");
  return check;
}

CLI::App* add_plugins_command(CLI::App& app, PluginsArgs& args) {
  auto* plugins = app.add_subcommand("plugins", "list plugins with their ports and parameters");
  plugins->add_option("name", args.name, "one plugin type, or a library prefix such as 'capture'");
  plugins->add_flag("--markdown", args.markdown, "print the reference as Markdown");
  plugins->add_flag("--names", args.names, "print only the plugin types, one a line");
  return plugins;
}

CLI::App* add_completion_command(CLI::App& app, CompletionArgs& args) {
  auto* completion = app.add_subcommand("completion", "print a shell completion script: source <(saccade completion bash)");
  completion->add_option("shell", args.shell, "the shell (bash)")->check(CLI::IsMember({"bash"}));
  completion->add_option("-o,--output", args.out, "write it to FILE instead");
  return completion;
}

CLI::App* add_dot_command(CLI::App& app, GraphArgs& graph) {
  auto* dot = app.add_subcommand("dot", "print a graph as Graphviz");
  dot->add_option("graph", graph.file, "graph file (XML)")->required();
  dot->add_option("--set", graph.sets, "override a parameter: node.param=value (repeatable)");
  return dot;
}

CLI::App* add_train_command(CLI::App& app, TrainArgs& args) {
  classifier::FolderTraining& training = args.training;
  auto* train = app.add_subcommand("train", "train a classifier model from a folder with one sub-folder per class");
  train->add_option("data", training.data, "folder with one sub-folder of images or videos per class");
  train->add_option("--samples", args.samples, "instead of a folder: samples a graph collected (classifier.collect)");
  train->add_option("--out", training.out, "model file to write (OpenCV FileStorage: .yml, .yml.gz, .xml)")->required();
  train->add_option("--levels", args.levels, "retina levels of the vector, 0 = the fovea (e.g. 0,1)");
  train->add_option("--features", args.features, "gray, grad_hist and/or filter-bank maps (e.g. gray,grad_hist)");
  train->add_option("--size", args.size, "each map reduced to WxH (grad_hist: its cell grid)");
  train->add_option("--hidden", args.hidden, "hidden layer sizes, e.g. 64 or 128,32");
  train->add_option("--epochs", training.train.epochs, "training epochs")->check(CLI::Range(1, 1000000));
  train->add_option("--method", args.method, "backprop (online; the default) or rprop (batch; each epoch restarts its steps)")->check(CLI::IsMember({"rprop", "backprop"}));
  train->add_option("--learning-rate", training.train.learning_rate, "backprop: learning rate");
  train->add_option("--validation", training.validation, "share of each class kept for validation (the last files)")
      ->check(CLI::Range(0.0, 0.9));
  train->add_option("--seed", training.train.seed,
                    "seed of the order samples are presented in (OpenCV fixes the initial weights itself)");
  train->add_option("--video-step", training.video_step, "videos: use every Nth frame")->check(CLI::Range(1, 100000));
  train->add_option("--report-every", training.report_every, "epochs between progress lines")->check(CLI::Range(1, 100000));
  return train;
}

// Parses the recipe and network options into args.training; the first error, if any.
std::string parse_training_options(TrainArgs& args) {
  std::string error;
  auto levels = classifier::parse_levels(args.levels, &error);
  auto features = levels ? classifier::parse_features(args.features, &error) : std::nullopt;
  auto hidden = features ? classifier::parse_int_list(args.hidden, "--hidden", &error) : std::nullopt;
  int w = 0, h = 0;
  char tail = 0;
  if (hidden && std::find(hidden->begin(), hidden->end(), 0) != hidden->end())
    error = "--hidden: every layer needs at least one neuron, got '" + args.hidden + "'";
  else if (hidden && (std::sscanf(args.size.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 1 || h < 1))
    error = "--size: expected WxH, got '" + args.size + "'";
  if (!error.empty()) return error;
  classifier::FolderTraining& training = args.training;
  training.recipe.levels = *levels;
  training.recipe.features = *features;
  training.recipe.size = cv::Size(w, h);
  training.train.hidden = *hidden;
  training.train.method = args.method == "backprop" ? classifier::TrainConfig::Method::kBackprop
                                                    : classifier::TrainConfig::Method::kRprop;
  return {};
}

int train_command(TrainArgs& args) {
  if (std::string error = parse_training_options(args); !error.empty()) {
    std::cerr << "saccade train: " << error << "\n";
    return 2;
  }
  if (args.training.data.empty() == args.samples.empty()) {
    std::cerr << "saccade train: give either a data folder or --samples FILE\n";
    return 2;
  }
  classifier::TrainingResult result;
  if (!args.samples.empty()) {
    // The recipe is the one the graph collected with.
    classifier::SampleSet samples;
    if (std::string e = samples.load(args.samples); !e.empty()) {
      std::cerr << "saccade train: " << e << "\n";
      return 2;
    }
    result = classifier::train_rows(samples, args.training, std::cout);
  } else {
    result = classifier::train_folder(args.training, std::cout);
  }
  if (!result.error.empty()) {
    std::cerr << "saccade train: " << result.error << "\n";
    return 2;
  }
  return 0;
}

int plugins_command(const Common& common, const PluginsArgs& args) {
  Registry registry;
  load_registry(registry, common, true);
  const bool reference = args.markdown && args.name.empty();
  if (reference)
    std::printf("# Plugin reference\n\nGenerated from the plugins' own contracts by `saccade plugins --markdown`; a test "
                "fails when\nthis file and the built plugins disagree (regenerate with `make docs`).\n\n");
  int shown = 0;
  for (const auto& type : registry.types()) {
    if (!args.name.empty() && type != args.name && type.rfind(args.name + ".", 0) != 0) continue;
    const NodeTypeInfo* info = registry.find(type);
    if (args.names) std::printf("%s\n", type.c_str());
    else if (args.markdown) print_plugin_markdown(*info);
    else print_plugin_text(*info);
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
    if (progress) progress->print_above(table + "\n");
    else std::fprintf(stderr, "%s\n", table.c_str());
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
  if (!args.record.empty()) {
    saccade::mcap::RecorderOptions ro;
    saccade::mcap::parse_compression(args.record_compression, ro.writer.compression);
    ro.lossless = args.record_lossless;
    std::string error;
    recorder = saccade::mcap::attach_recorder(executor, args.record, ro, error);
    if (!recorder) {
      std::cerr << "saccade run: --record: " << error << "\n";
      return 1;
    }
  }
  std::unique_ptr<saccade::view::ViewServer> view_server;  // stopped before the executor goes
  if (!args.view.empty()) {
    saccade::view::ViewOptions vo;
    std::string error;
    if (!saccade::view::parse_view_address(args.view, vo, error)) {
      std::cerr << "saccade run: " << error << "\n";
      return 2;
    }
    view_server = saccade::view::start_view(executor, vo, error);
    if (!view_server) {
      std::cerr << "saccade run: " << error << "\n";
      return 1;
    }
    std::cerr << "view: " << view_server->url() << " (Foxglove: ws://" << vo.address << ":" << view_server->port()
              << ")\n";
  }
  if (args.progress) {
    progress = std::make_unique<saccade::cli::ProgressLine>(executor, options.max_frames, options.duration_s, stderr,
                                                            isatty(STDERR_FILENO) != 0);
    progress->start();
  }
  status = executor.run();
  if (progress) progress->stop();
  if (view_server) view_server->stop();
  if (recorder) {
    if (std::string why = recorder->finish(); !why.empty()) {
      std::cerr << "saccade run: --record: " << why << "\n";
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
  if (!status.ok()) {
    std::cerr << graph_args.file << ": error: " << status.message() << "\n";
    return 1;
  }
  // Stopped cleanly by Ctrl-C (or SIGTERM): 128 + the signal, as a shell reports a killed command.
  if (const int sig = g_signal.load(); sig != 0) {
    std::cerr << "stopped by "
              << (sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : sig == SIGHUP ? "SIGHUP" : "a signal") << "\n";
    return 128 + sig;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"saccade: dataflow graphs for real-time active vision"};
  app.require_subcommand(1);
  // The global options may follow the subcommand too: `saccade run g.xml --plugin-path X`.
  app.fallthrough();
  Common common;
  GraphArgs graph;
  RunArgs run_args;
  PluginsArgs plugins_args;
  TrainArgs train_args;
  CalibrateArgs calibrate_args;
  CompletionArgs completion_args;
  add_global_options(app, common);
  // Added in the order `saccade --help` lists them.
  add_run_command(app, graph, run_args);
  auto* plan = add_plan_command(app, graph);
  auto* check = add_check_command(app, graph);
  auto* plugins = add_plugins_command(app, plugins_args);
  auto* dot = add_dot_command(app, graph);
  auto* train = add_train_command(app, train_args);
  auto* calibrate = add_calibrate_command(app, calibrate_args);
  auto* completion = add_completion_command(app, completion_args);

  CLI11_PARSE(app, argc, argv);
  log().set_level(spdlog::level::from_str(common.log_level));
  // The DDS plugin reads it when it creates the process's participant.
  if (!run_args.security.empty()) setenv("SACCADE_DDS_SECURITY", run_args.security.c_str(), 1);
  if (completion->parsed()) return completion_command(app, completion_args);
  if (train->parsed()) return train_command(train_args);
  if (calibrate->parsed()) return calibrate_command(calibrate_args);
  if (plugins->parsed()) return plugins_command(common, plugins_args);
  if (plan->parsed()) return plan_command(common, graph);
  if (check->parsed()) return check_command(common, graph);
  if (dot->parsed()) return dot_command(common, graph);
  // Exactly one subcommand parsed: what is left is run.
  return run_command(common, graph, run_args);
}
