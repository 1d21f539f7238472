#include "saccade/registry.hpp"

#define BOOST_DLL_USE_STD_FS
#include <boost/dll/shared_library.hpp>

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "saccade/log.hpp"
#include "saccade/plugin.hpp"

// The build tree's library and plugin folders: a libsaccade loaded from the
// first uses the second. Anywhere else, its plugins are <its folder>/saccade/plugins.
#ifndef SACCADE_LIB_BUILD_DIR
#define SACCADE_LIB_BUILD_DIR ""
#endif
#ifndef SACCADE_PLUGIN_BUILD_DIR
#define SACCADE_PLUGIN_BUILD_DIR ""
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
    if (tail == "Bad file descriptor" || tail == "Illegal seek" || tail == "Success" ||
        tail == "No such file or directory")
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
  if (std::string bundled = bundled_plugin_dir(); !bundled.empty()) out.push_back(std::move(bundled));
  return out;
}

std::string Registry::bundled_plugin_dir() {
  Dl_info info{};
  // Any function of this library tells where the library was loaded from.
  if (dladdr(reinterpret_cast<void*>(&Registry::bundled_plugin_dir), &info) == 0 || info.dli_fname == nullptr)
    return {};
  std::error_code ec;
  const fs::path lib_dir = fs::weakly_canonical(fs::path(info.dli_fname), ec).parent_path();
  if (ec || lib_dir.empty()) return {};
  if (*SACCADE_LIB_BUILD_DIR && fs::equivalent(lib_dir, SACCADE_LIB_BUILD_DIR, ec)) return SACCADE_PLUGIN_BUILD_DIR;
  return (lib_dir / "saccade" / "plugins").string();
}

std::string Registry::searched_summary() const {
  if (searched_.empty()) return "no plugin folder was searched";
  std::string out = "searched ";
  for (std::size_t i = 0; i < searched_.size(); ++i) out += (i ? ", " : "") + searched_[i];
  return out;
}

namespace {

// A file a user may have meant as a plugin: name.so or name.so.N.
bool looks_like_shared_library(const fs::path& p) {
  const std::string name = p.filename().string();
  return p.extension() == ".so" || name.find(".so.") != std::string::npos;
}

}  // namespace

void Registry::load_folders(const std::vector<std::string>& folders) {
  for (const auto& folder : folders) {
    std::error_code ec;
    if (!fs::is_directory(folder, ec)) {
      searched_.push_back(folder + (fs::exists(folder, ec) ? " (not a folder)" : " (no such folder)"));
      continue;
    }
    const std::string canonical = fs::weakly_canonical(folder, ec).string();
    if (std::find(searched_canonical_.begin(), searched_canonical_.end(), canonical) != searched_canonical_.end())
      continue;
    searched_canonical_.push_back(canonical);
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder, ec)) {
      std::error_code type_ec;
      if (entry.is_directory(type_ec) || !looks_like_shared_library(entry.path())) continue;
      auto name = entry.path().filename().string();
      if (name.rfind("saccade_", 0) == 0 && entry.path().extension() == ".so") {
        files.push_back(entry.path());
      } else {
        warnings_.push_back(entry.path().string() +
                            ": skipped: a plugin library's file name must be saccade_<name>.so");
        log().warn("{}", warnings_.back());
      }
    }
    std::sort(files.begin(), files.end());
    std::size_t loaded = 0, shadowed = 0;
    for (const auto& f : files) {
      // The first folder that has a library of a given name wins.
      if (auto it = libraries_.find(f.filename().string()); it != libraries_.end()) {
        warnings_.push_back(f.string() + ": skipped: " + f.filename().string() + " was already loaded from " +
                            it->second->path);
        log().warn("{}", warnings_.back());
        ++shadowed;
        continue;
      }
      if (Status status = load_library(f.string()); status.ok())
        ++loaded;
      else
        load_errors_.push_back(status.message());
    }
    const std::size_t failed = files.size() - loaded - shadowed;
    std::string found = std::to_string(loaded) + (loaded == 1 ? " library" : " libraries");
    if (failed) found += ", " + std::to_string(failed) + " failed";
    if (shadowed) found += ", " + std::to_string(shadowed) + " skipped";
    searched_.push_back(folder + " (" + found + ")");
  }
}

Status Registry::load_library(const std::string& path) {
  auto fail = [](const std::string& message) { return Status::error(message); };
  if (!fs::exists(path)) return fail(path + ": no such plugin library");
  auto lib = std::make_shared<Library>();
  lib->path = path;
  try {
    // RTLD_NOW: a symbol the library needs but nobody provides is an error here,
    // not a crash at its first call.
    lib->handle.load(fs::path(path), boost::dll::load_mode::rtld_now | boost::dll::load_mode::rtld_local);
  } catch (const std::exception& e) { return fail(path + ": cannot load: " + dl_reason(e)); }
  if (!lib->handle.has("saccade_plugin_entry"))
    return fail(path +
                ": no symbol 'saccade_plugin_entry' (not a saccade plugin? its source needs SACCADE_PLUGIN(...))");
  try {
    auto& entry = lib->handle.get_alias<const PluginDescriptor*()>("saccade_plugin_entry");
    lib->descriptor = entry();
  } catch (const std::exception& e) { return fail(path + ": symbol 'saccade_plugin_entry' unusable: " + dl_reason(e)); }
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
      log().warn("{}: node type '{}' already provided by {}; keeping the first", path, type,
                 entries_[type].info.library);
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
  return {};
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

Result<std::shared_ptr<Node>> Registry::create(const std::string& type) const {
  auto it = entries_.find(type);
  if (it == entries_.end()) return Status::error("unknown plugin '" + type + "' (" + searched_summary() + ")");
  std::shared_ptr<Library> lib = it->second.library;
  const NodeFactory& f = lib->descriptor->factories[it->second.factory];
  Result<Node*> raw = f.create();
  if (!raw.ok()) return Status::error("creating '" + type + "' failed: " + raw.error());
  // The deleter holds the library: the node's code stays mapped while it lives.
  auto destroy = f.destroy;
  return std::shared_ptr<Node>(*raw, [lib, destroy](Node* n) { destroy(n); });
}

}  // namespace saccade
