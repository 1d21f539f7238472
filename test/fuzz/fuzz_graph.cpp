// libFuzzer: a graph file, from XML to a checked graph (parsing, --set
// overrides taken from the input's last line, resolution against the util
// plugin's node types). Nothing may crash, hang or leak, whatever the bytes.
#include <cstdint>
#include <string>
#include <vector>

#include "saccade/diagnostics.hpp"
#include "saccade/graph.hpp"
#include "saccade/registry.hpp"

namespace {
saccade::Registry* registry = nullptr;
}

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  registry = new saccade::Registry();
  if (!registry->load_library(SACCADE_FUZZ_UTIL_PLUGIN).ok()) __builtin_trap();  // the harness is miswired
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string xml(reinterpret_cast<const char*>(data), size);
  // Lines after a "\n#set " marker are overrides, as --set gives them.
  std::vector<std::string> sets;
  for (auto at = xml.find("\n#set "); at != std::string::npos; at = xml.find("\n#set ")) {
    auto end = xml.find('\n', at + 1);
    sets.push_back(xml.substr(at + 6, end == std::string::npos ? std::string::npos : end - at - 6));
    xml.erase(at, end == std::string::npos ? std::string::npos : end - at);
  }
  saccade::Diagnostics diag;
  saccade::GraphDecl decl = saccade::load_graph_string(xml, "fuzz.xml", diag);
  if (!diag.has_errors()) saccade::apply_overrides(decl, sets, diag);
  if (!diag.has_errors()) (void)saccade::resolve_graph(decl, *registry, diag);
  (void)diag.format();
  return 0;
}
