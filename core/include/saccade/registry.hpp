#pragma once
// Finds plugin libraries, loads them with Boost.DLL and makes nodes from them.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "saccade/contract.hpp"
#include "saccade/diagnostics.hpp"
#include "saccade/node.hpp"

namespace saccade {

struct NodeTypeInfo {
  std::string type;     // "filters.bank"
  std::string library;  // path of the .so
  Contract contract;
};

class Registry {
 public:
  Registry();
  ~Registry();
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  // Folders searched in order: `extra` (from --plugin-path, ':'-separated), then
  // SACCADE_PLUGIN_PATH (the same), then bundled_plugin_dir().
  static std::vector<std::string> default_search_path(const std::string& extra = {});
  // The plugins that came with this libsaccade, found from where it is loaded,
  // never from a folder fixed at build time: <libdir>/saccade/plugins beside an
  // installed libsaccade.so (so <prefix>/bin/saccade finds
  // <prefix>/lib/saccade/plugins wherever the prefix was moved), the build
  // tree's plugins/ when it runs from the build tree. Empty when unknown.
  static std::string bundled_plugin_dir();

  // Loads every saccade_*.so in the folders (a folder named twice is read once);
  // a library that fails is recorded in load_errors() and does not stop the
  // others. A file that looks like a shared library but is skipped (not named
  // saccade_*.so, or a library of that name already loaded from an earlier
  // folder) is a warning: logged, and kept in warnings().
  void load_folders(const std::vector<std::string>& folders);
  // Loads one library; an error naming the file and the symbol on failure.
  Status load_library(const std::string& path);

  const NodeTypeInfo* find(const std::string& type) const;
  std::vector<std::string> types() const;
  const std::vector<std::string>& load_errors() const { return load_errors_; }
  const std::vector<std::string>& warnings() const { return warnings_; }
  // Where load_folders looked, in order, each with what it found:
  // "DIR (3 libraries)", "DIR (no such folder)". For "unknown plugin" errors.
  const std::vector<std::string>& searched() const { return searched_; }
  // The same as one line: "searched DIR (3 libraries), DIR (no such folder)",
  // or "no plugin folder was searched".
  std::string searched_summary() const;

  // A node instance that keeps its library loaded as long as it lives.
  Result<std::shared_ptr<Node>> create(const std::string& type) const;

 private:
  struct Library;
  struct Entry {
    NodeTypeInfo info;
    std::shared_ptr<Library> library;
    std::size_t factory = 0;
  };
  std::map<std::string, Entry> entries_;
  std::map<std::string, std::shared_ptr<Library>> libraries_;  // by file name
  std::vector<std::string> load_errors_;
  std::vector<std::string> warnings_;
  std::vector<std::string> searched_;
  std::vector<std::string> searched_canonical_;  // a folder named twice is read once
};

}  // namespace saccade
