#pragma once
// The saccade command's line: every subcommand's options and their checks,
// parsed without leaving the process (main() and the fuzz_cli harness share it).
#include <CLI/CLI.hpp>

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <unistd.h>

#include "calibrate_command.hpp"
#include "recognition.hpp"
#include "saccade/executor.hpp"

namespace saccade::cli {

// Options of every command.
struct Common {
  std::string plugin_path;
  std::string log_level = "info";
};

// Graph attributes the command line may override.
struct GraphOverrides {
  int domain = -1;
  std::string topic_prefix;
};

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
  std::string view;        // [ADDR:]PORT of the live view
  double view_cpu = 0.04;  // the share of a core the live view may take
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

// The whole command line: the CLI11 definition and where each option lands.
struct CommandLine {
  CommandLine();
  CommandLine(const CommandLine&) = delete;
  CommandLine& operator=(const CommandLine&) = delete;

  CLI::App app{"saccade: dataflow graphs for real-time active vision"};
  Common common;
  GraphArgs graph;
  RunArgs run_args;
  PluginsArgs plugins_args;
  TrainArgs train_args;
  CalibrateArgs calibrate_args;
  CompletionArgs completion_args;
  CLI::App *run = nullptr, *plan = nullptr, *check = nullptr, *plugins = nullptr, *dot = nullptr, *train = nullptr,
           *calibrate = nullptr, *completion = nullptr, *idl = nullptr;
};

// Parses argv into `line`. nullopt: go on with the subcommand parsed; else the
// exit status, after CLI11 printed the help, the version or the error to
// `out` or `err` (as CLI11_PARSE does to stdout and stderr).
std::optional<int> parse_command_line(CommandLine& line, int argc, const char* const* argv, std::ostream& out,
                                      std::ostream& err);

// train's recipe and network options into args.training; the first error, if any.
Status parse_training_options(TrainArgs& args);

}  // namespace saccade::cli
