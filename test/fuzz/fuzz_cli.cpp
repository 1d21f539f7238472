// libFuzzer: the saccade command's line. The input is its arguments,
// NUL-separated; they go through the command's own definition and checks
// (parse_command_line, as main() parses them, its help, version and errors
// written to strings), then through what main() parses next from them: the
// --set overrides on a graph, train's recipe and network options, --view's
// address, --record-compression and the bash completion script. Nothing may
// crash, hang, leak or throw anything but CLI11's parse errors.
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "command_line.hpp"
#include "completion.hpp"
#include "mcap.hpp"
#include "saccade/diagnostics.hpp"
#include "saccade/graph.hpp"
#include "view_server.hpp"

namespace {

// The graph the --set overrides land on: a node of each kind of parameter.
const saccade::GraphDecl& graph() {
  static const saccade::GraphDecl decl = [] {
    saccade::Diagnostics diag;
    saccade::GraphDecl d = saccade::load_graph_string(
        R"(<graph name="g"><node name="camera" plugin="capture.video"><param name="path" value="a.avi"/></node>
           <node name="retina" plugin="retina"><param name="levels" value="5"/><param name="fovea" value="420,300"/></node>
           <edge from="camera.image" to="retina.image"/></graph>)",
        "fuzz.xml", diag);
    if (diag.has_errors()) __builtin_trap();  // the harness is miswired
    return d;
  }();
  return decl;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<std::string> args{"saccade"};
  std::string arg;
  for (std::size_t i = 0; i < size; ++i) {
    if (data[i] == 0) {
      args.push_back(arg);
      arg.clear();
    } else {
      arg += static_cast<char>(data[i]);
    }
  }
  if (!arg.empty() || size == 0) args.push_back(arg);
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());

  saccade::cli::CommandLine line;
  std::ostringstream out, err;
  if (saccade::cli::parse_command_line(line, static_cast<int>(argv.size()), argv.data(), out, err)) return 0;
  if (line.train->parsed()) (void)saccade::cli::parse_training_options(line.train_args);
  if (line.completion->parsed()) (void)saccade::cli::bash_completion(line.app);
  if (line.run->parsed()) {
    saccade::mcap::Compression compression;
    if (!saccade::mcap::parse_compression(line.run_args.record_compression, compression))
      __builtin_trap();  // CLI11 checked it
    if (!line.run_args.view.empty()) {
      saccade::view::ViewOptions options;
      (void)saccade::view::parse_view_address(line.run_args.view, options);
    }
  }
  if (!line.graph.sets.empty()) {
    saccade::GraphDecl decl = graph();
    saccade::Diagnostics diag;
    saccade::apply_overrides(decl, line.graph.sets, diag);
    (void)diag.format();
  }
  return 0;
}
