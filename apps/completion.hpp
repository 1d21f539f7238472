#pragma once
// `saccade completion bash`: a bash completion script made from the command
// line's own definition, so it never lags behind an option.
#include <string>

namespace CLI {
class App;
}

namespace saccade::cli {

// The script: `source <(saccade completion bash)`, or installed as
// share/bash-completion/completions/saccade. Completes subcommands, each
// one's options (and the global ones, accepted anywhere), graph files (*.xml)
// where a graph is expected, folders for --plugin-path and other folder
// options, plugin types for `saccade plugins` (from the plugins the command
// finds), and the choices of --log-level.
std::string bash_completion(const CLI::App& app);

}  // namespace saccade::cli
