#include "saccade/registry.hpp"

#define BOOST_DLL_USE_STD_FS
#include <boost/dll/shared_library.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "saccade/log.hpp"
#include "saccade/plugin.hpp"

#ifndef SACCADE_PLUGIN_BUILD_DIR
#define SACCADE_PLUGIN_BUILD_DIR ""
#endif
#ifndef SACCADE_PLUGIN_INSTALL_DIR
#define SACCADE_PLUGIN_INSTALL_DIR ""
#endif

namespace saccade {

namespace fs = std::filesystem;

struct Registry::Library {
  boost::dll::shared_library handle;
  const PluginDescriptor* descriptor = nullptr;
  std::string path;
};

Registry::Registry() = default;
Registry::~Registry() = default;

namespace {

void split_path_list(const std::string& text, std::vector<std::string>& out) {
  std::size_t start = 0;
  while (start <= text.size()) {
    auto end = text.find(':', start);
    if (end == std::string::npos) end = text.size();
    if (end > start) out.push_back(text.substr(start, end - start));
    start = end + 1;
  }
}

// Boost's messages end in unrelated errno words; only the dlerror part means anything.
std::string dl_reason(const std::exception& e) {
  std::string what = e.what();
  auto colon = what.rfind(": ");
  if (colon != std::string::npos) {
    std::string tail = what.substr(colon + 2);
    if (tail == "Bad file descriptor" || tail == "Illegal seek" || tail == "Success" || tail == "No such file or directory")
      what = what.substr(0, colon);
  }
  return what;
}

std::string describe(const AbiStamp& s) {
  return "abi " + std::to_string(s.abi_version) + ", gcc " + std::to_string(s.compiler_major) + ", cxx11abi " +
         std::to_string(s.cxx11_abi) + ", sizes " + std::to_string(s.sizeof_contract) + "/" +
         std::to_string(s.sizeof_node_slot) + "/" + std::to_string(s.sizeof_image);
}

}  // namespace

std::vector<std::string> Registry::default_search_path(const std::string& extra) {
  std::vector<std::string> out;
  split_path_list(extra, out);
  if (const char* env = std::getenv("SACCADE_PLUGIN_PATH")) split_path_list(env, out);
  if (*SACCADE_PLUGIN_BUILD_DIR) out.emplace_back(SACCADE_PLUGIN_BUILD_DIR);
  if (*SACCADE_PLUGIN_INSTALL_DIR) out.emplace_back(SACCADE_PLUGIN_INSTALL_DIR);
  return out;
}

void Registry::load_folders(const std::vector<std::string>& folders) {
  for (const auto& folder : folders) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) continue;
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
      auto name = entry.path().filename().string();
      if (name.rfind("saccade_", 0) == 0 && entry.path().extension() == ".so") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      // The first folder that has a library of a given name wins.
      if (libraries_.count(f.filename().string())) continue;
      std::string error;
      if (!load_library(f.string(), &error)) load_errors_.push_back(error);
    }
  }
}

bool Registry::load_library(const std::string& path, std::string* error) {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!fs::exists(path)) return fail(path + ": no such plugin library");
  auto lib = std::make_shared<Library>();
  lib->path = path;
  try {
    // RTLD_NOW: a symbol the library needs but nobody provides is an error here,
    // not a crash at its first call.
    lib->handle.load(fs::path(path), boost::dll::load_mode::rtld_now | boost::dll::load_mode::rtld_local);
  } catch (const std::exception& e) {
    return fail(path + ": cannot load: " + dl_reason(e));
  }
  if (!lib->handle.has("saccade_plugin_entry"))
    return fail(path + ": no symbol 'saccade_plugin_entry' (not a saccade plugin? its source needs SACCADE_PLUGIN(...))");
  try {
    auto& entry = lib->handle.get_alias<const PluginDescriptor*()>("saccade_plugin_entry");
    lib->descriptor = entry();
  } catch (const std::exception& e) {
    return fail(path + ": symbol 'saccade_plugin_entry' unusable: " + dl_reason(e));
  }
  if (lib->descriptor == nullptr) return fail(path + ": 'saccade_plugin_entry' returned no descriptor");
  const AbiStamp host = current_abi_stamp();
  if (!(lib->descriptor->abi == host))
    return fail(path + ": symbol 'saccade_plugin_entry': ABI mismatch: library built with " +
                describe(lib->descriptor->abi) + ", host is " + describe(host) + "; rebuild the plugin");
  std::string library_name = lib->descriptor->library ? lib->descriptor->library : "";
  for (std::size_t i = 0; i < lib->descriptor->count; ++i) {
    const NodeFactory& f = lib->descriptor->factories[i];
    std::string short_name = f.name ? f.name : "";
    std::string type = short_name.empty() ? library_name : library_name + "." + short_name;
    if (entries_.count(type)) {
      log().warn("{}: node type '{}' already provided by {}; keeping the first", path, type, entries_[type].info.library);
      continue;
    }
    Entry e;
    e.info.type = type;
    e.info.library = path;
    e.info.contract = f.contract();
    if (!e.info.contract.problems().empty()) {
      for (const std::string& problem : e.info.contract.problems())
        load_errors_.push_back(path + ": node type '" + type + "': " + problem);
      continue;
    }
    e.library = lib;
    e.factory = i;
    entries_.emplace(type, std::move(e));
  }
  libraries_[fs::path(path).filename().string()] = lib;
  return true;
}

const NodeTypeInfo* Registry::find(const std::string& type) const {
  auto it = entries_.find(type);
  return it == entries_.end() ? nullptr : &it->second.info;
}

std::vector<std::string> Registry::types() const {
  std::vector<std::string> out;
  for (const auto& [type, e] : entries_) out.push_back(type);
  return out;
}

std::shared_ptr<Node> Registry::create(const std::string& type, std::string* error) const {
  auto it = entries_.find(type);
  if (it == entries_.end()) {
    if (error) *error = "unknown plugin '" + type + "'";
    return nullptr;
  }
  std::shared_ptr<Library> lib = it->second.library;
  const NodeFactory& f = lib->descriptor->factories[it->second.factory];
  std::string create_error;
  Node* raw = f.create(&create_error);
  if (raw == nullptr) {
    if (error) *error = "creating '" + type + "' failed: " + create_error;
    return nullptr;
  }
  // The deleter holds the library: the node's code stays mapped while it lives.
  auto destroy = f.destroy;
  return std::shared_ptr<Node>(raw, [lib, destroy](Node* n) { destroy(n); });
}

}  // namespace saccade
