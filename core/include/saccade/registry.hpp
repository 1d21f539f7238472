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
  // SACCADE_PLUGIN_PATH, then the build tree's and the install tree's plugin folders.
  static std::vector<std::string> default_search_path(const std::string& extra = {});

  // Loads every saccade_*.so in the folders; a library that fails is recorded in
  // load_errors() and does not stop the others.
  void load_folders(const std::vector<std::string>& folders);
  // Loads one library; false (and an error naming the file and the symbol) on failure.
  bool load_library(const std::string& path, std::string* error = nullptr);

  const NodeTypeInfo* find(const std::string& type) const;
  std::vector<std::string> types() const;
  const std::vector<std::string>& load_errors() const { return load_errors_; }

  // A node instance that keeps its library loaded as long as it lives.
  std::shared_ptr<Node> create(const std::string& type, std::string* error) const;

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
};

}  // namespace saccade
