#include "completion.hpp"

#include <CLI/CLI.hpp>

#include <set>

namespace saccade::cli {

namespace {

// Every long and short name of the app's own options (not positionals).
std::string option_words(const CLI::App& app) {
  std::string out;
  for (const CLI::Option* opt : app.get_options()) {
    if (!opt->nonpositional()) continue;
    for (const std::string& l : opt->get_lnames()) out += " --" + l;
    for (const std::string& s : opt->get_snames()) out += " -" + s;
  }
  return out;
}

// Names of the options that take a value, as a case pattern ("--a|--b|-c").
void value_options(const CLI::App& app, std::set<std::string>& out) {
  for (const CLI::Option* opt : app.get_options()) {
    if (!opt->nonpositional() || opt->get_type_size_max() == 0 || opt->get_expected_max() == 0) continue;
    if (opt->get_expected_min() == 0) continue;  // an optional value (--stats[=N]) is given with '='
    for (const std::string& l : opt->get_lnames()) out.insert("--" + l);
    for (const std::string& s : opt->get_snames()) out.insert("-" + s);
  }
}

std::string join(const std::set<std::string>& words, const char* sep) {
  std::string out;
  for (const std::string& w : words) out += (out.empty() ? "" : sep) + w;
  return out;
}

}  // namespace

std::string bash_completion(const CLI::App& app) {
  std::string subcommands;
  std::set<std::string> takes_value;
  value_options(app, takes_value);
  std::string per_command;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    subcommands += " " + sub->get_name();
    value_options(*sub, takes_value);
    per_command += "    " + sub->get_name() + ") opts=\"" + option_words(*sub) + "\" ;;\n";
  }
  // Options whose value is a folder; the other values are files, or free text
  // (no completion) for these.
  const std::set<std::string> folders = {"--plugin-path", "--security"};
  const std::set<std::string> free_text = {
      "--frames",        "--duration",   "--threads",  "--set",        "--process",      "--domain",
      "--topic-prefix",  "--levels",     "--features", "--size",       "--hidden",       "--epochs",
      "--learning-rate", "--validation", "--seed",     "--video-step", "--report-every", "--board",
      "--square",        "--charuco",    "--marker",   "--min-pairs",  "--pixels"};
  std::set<std::string> folder_values, free_values, file_values;
  for (const std::string& o : takes_value) {
    if (o == "--log-level" || o == "--method") continue;
    if (folders.count(o))
      folder_values.insert(o);
    else if (free_text.count(o))
      free_values.insert(o);
    else
      file_values.insert(o);
  }
  std::string s;
  s += "# bash completion for saccade (made by `saccade completion bash`)\n";
  s += "_saccade() {\n";
  s += "  local cur=\"${COMP_WORDS[COMP_CWORD]}\" prev=\"\" cmd=\"\" i opts\n";
  s += "  (( COMP_CWORD > 0 )) && prev=\"${COMP_WORDS[COMP_CWORD-1]}\"\n";
  s += "  for (( i = 1; i < COMP_CWORD; i++ )); do\n";
  s += "    case \"${COMP_WORDS[i]}\" in" + std::string() + "\n";
  {
    std::string alts;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
      alts += (alts.empty() ? "" : "|") + sub->get_name();
    s += "      " + alts + ") cmd=\"${COMP_WORDS[i]}\"; break ;;\n";
  }
  s += "    esac\n  done\n";
  s += "  COMPREPLY=()\n";
  s += "  case \"$prev\" in\n";
  s += "    --log-level) COMPREPLY=($(compgen -W \"trace debug info warn error off\" -- \"$cur\")); return ;;\n";
  s += "    --method) COMPREPLY=($(compgen -W \"backprop rprop\" -- \"$cur\")); return ;;\n";
  if (!folder_values.empty())
    s += "    " + join(folder_values, "|") + ") COMPREPLY=($(compgen -d -- \"$cur\")); return ;;\n";
  if (!free_values.empty()) s += "    " + join(free_values, "|") + ") return ;;\n";
  if (!file_values.empty())
    s += "    " + join(file_values, "|") + ") COMPREPLY=($(compgen -f -- \"$cur\")); return ;;\n";
  s += "  esac\n";
  s += "  if [[ -z \"$cmd\" ]]; then\n";
  s += "    if [[ \"$cur\" == -* ]]; then COMPREPLY=($(compgen -W \"" + option_words(app) + "\" -- \"$cur\"));\n";
  s += "    else COMPREPLY=($(compgen -W \"" + subcommands + "\" -- \"$cur\")); fi\n";
  s += "    return\n  fi\n";
  s += "  case \"$cmd\" in\n" + per_command + "  esac\n";
  s += "  if [[ \"$cur\" == -* ]]; then\n";
  s += "    COMPREPLY=($(compgen -W \"$opts" + option_words(app) + "\" -- \"$cur\"))\n";
  s += "    return\n  fi\n";
  s += "  case \"$cmd\" in\n";
  s += "    run|check|plan|dot) COMPREPLY=($(compgen -f -X '!*.xml' -- \"$cur\") $(compgen -d -- \"$cur\")) ;;\n";
  s +=
      "    plugins) COMPREPLY=($(compgen -W \"$(\"${COMP_WORDS[0]}\" plugins --names 2>/dev/null)\" -- \"$cur\")) ;;\n";
  s += "    completion) COMPREPLY=($(compgen -W \"bash\" -- \"$cur\")) ;;\n";
  s += "    *) COMPREPLY=($(compgen -f -- \"$cur\")) ;;\n";
  s += "  esac\n";
  s += "}\n";
  s += "complete -o filenames -F _saccade saccade\n";
  return s;
}

}  // namespace saccade::cli
