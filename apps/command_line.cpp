#include "command_line.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string_view>

#include "saccade/plugin.hpp"

namespace saccade::cli {
namespace {

#ifndef SACCADE_VERSION
#define SACCADE_VERSION "unknown"
#endif

// Accepted before or after the subcommand (the subcommands fall through to them).
void add_global_options(CLI::App& app, Common& common) {
  app.set_version_flag("--version",
                       std::string("saccade ") + SACCADE_VERSION + " (plugin ABI " + std::to_string(kAbiVersion) + ")");
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
  run->add_option("--threads", args.options.threads, "worker threads (default: one per core)")
      ->check(CLI::Range(0, 256));
  run->add_flag("--deterministic", args.options.deterministic,
                "one thread, fixed order: same input, bit-identical output");
  args.stats = run->add_option("--stats", args.stats_interval,
                               "print per-node stats at exit, and every INTERVAL seconds if given")
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
  run->add_option("--view-cpu", args.view_cpu,
                  "the share of one core the live view's encoding and sending may take; past it pictures come less "
                  "often, the graph is not slowed (0: no limit)")
      ->capture_default_str()
      ->check(finite_above(0, true, "a share of 0 or more"));
  run->add_option("--set", graph.sets, "override a parameter: node.param=value (repeatable)");
  run->add_option("--process", graph.process,
                  "run only this process's part of the graph; its edges to other processes become DDS topics");
  run->add_option("--domain", graph.overrides.domain,
                  "DDS domain of the edges between processes (default: the graph's)")
      ->check(CLI::Range(0, 232));
  run->add_option("--topic-prefix", graph.overrides.topic_prefix,
                  "prefix of their DDS topics (default: the graph's topic_prefix, else its name)");
  run->add_option(
         "--security", args.security,
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
  auto* completion =
      app.add_subcommand("completion", "print a shell completion script: source <(saccade completion bash)");
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
  train
      ->add_option("--method", args.method,
                   "backprop (online; the default) or rprop (batch; each epoch restarts its steps)")
      ->check(CLI::IsMember({"rprop", "backprop"}));
  train->add_option("--learning-rate", training.train.learning_rate, "backprop: learning rate");
  train->add_option("--validation", training.validation, "share of each class kept for validation (the last files)")
      ->check(CLI::Range(0.0, 0.9));
  train->add_option("--seed", training.train.seed,
                    "seed of the order samples are presented in (OpenCV fixes the initial weights itself)");
  train->add_option("--video-step", training.video_step, "videos: use every Nth frame")->check(CLI::Range(1, 100000));
  train->add_option("--report-every", training.report_every, "epochs between progress lines")
      ->check(CLI::Range(1, 100000));
  return train;
}

}  // namespace

CommandLine::CommandLine() {
  app.require_subcommand(1);
  // The global options may follow the subcommand too: `saccade run g.xml --plugin-path X`.
  app.fallthrough();
  add_global_options(app, common);
  // Added in the order `saccade --help` lists them.
  run = add_run_command(app, graph, run_args);
  plan = add_plan_command(app, graph);
  check = add_check_command(app, graph);
  plugins = add_plugins_command(app, plugins_args);
  dot = add_dot_command(app, graph);
  idl = app.add_subcommand("idl", "print the IDL of saccade's messages as they travel in CDR (idl/saccade.idl)");
  train = add_train_command(app, train_args);
  calibrate = add_calibrate_command(app, calibrate_args);
  completion = add_completion_command(app, completion_args);
}

std::optional<int> parse_command_line(CommandLine& line, int argc, const char* const* argv, std::ostream& out,
                                      std::ostream& err) {
  // CLI11 2.1 reads a number given to a negated flag (--no-progress=N) with
  // std::stoll, lets its out_of_range through (the command aborted: found by
  // fuzz_cli) and negates it (undefined for the smallest long long). Such a
  // number counts by its sign, as CLI11 counts one given to a plain flag
  // (--progress=N): it is handed over as 1 or -1.
  std::vector<const char*> args(argv, argv + argc);
  const std::string flag = "--no-progress=";
  for (int i = 1; i < argc; ++i) {
    // Every one, even after "--": CLI11 reads options after it again once a subcommand follows.
    const std::string_view arg = argv[i];
    if (arg.substr(0, flag.size()) != flag || arg.size() <= flag.size() + 1) continue;
    const std::string value(arg.substr(flag.size()));
    bool huge = false;
    try {
      huge = std::stoll(value) == std::numeric_limits<long long>::min();
    } catch (const std::out_of_range&) { huge = true; } catch (const std::invalid_argument&) {
      // not a number: CLI11's own error
    }
    if (huge) {
      const bool negative = value[value.find_first_not_of(" \t\n\v\f\r")] == '-';
      args[static_cast<std::size_t>(i)] = negative ? "--no-progress=-1" : "--no-progress=1";
    }
  }
  try {
    line.app.parse(argc, args.data());
  } catch (const CLI::ParseError& e) { return line.app.exit(e, out, err); }
  return std::nullopt;
}

Status parse_training_options(TrainArgs& args) {
  Result<std::vector<int>> levels = classifier::parse_levels(args.levels);
  if (!levels.ok()) return levels.status();
  Result<std::vector<std::string>> features = classifier::parse_features(args.features);
  if (!features.ok()) return features.status();
  Result<std::vector<int>> hidden = classifier::parse_int_list(args.hidden, "--hidden");
  if (!hidden.ok()) return hidden.status();
  if (std::find(hidden->begin(), hidden->end(), 0) != hidden->end())
    return Status::error("--hidden: every layer needs at least one neuron, got '" + args.hidden + "'");
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(args.size.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 1 || h < 1)
    return Status::error("--size: expected WxH, got '" + args.size + "'");
  classifier::FolderTraining& training = args.training;
  training.recipe.levels = *levels;
  training.recipe.features = *features;
  training.recipe.size = cv::Size(w, h);
  training.train.hidden = *hidden;
  training.train.method =
      args.method == "backprop" ? classifier::TrainConfig::Method::kBackprop : classifier::TrainConfig::Method::kRprop;
  return {};
}

}  // namespace saccade::cli
