#pragma once
// util.jsonl: every message of one port as a line of JSON (saccade/schema.hpp),
// for per-frame results that any tool can read (a tracker's states, a
// fixation's disparity, a classifier's labels).
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>

#include "saccade/plugin.hpp"
#include "saccade/schema.hpp"

namespace saccade::util {

// Appends JSON lines to a file; the line buffer keeps its capacity, so
// steady-state writes allocate nothing.
class JsonLinesWriter {
 public:
  // Ok, or an error saying why the file cannot be written.
  // Creates the file's folder when missing, as the snapshot sink does.
  Status open(const std::string& path) {
    const std::filesystem::path folder = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!folder.empty()) std::filesystem::create_directories(folder, ec);
    if (ec) return Status::error("cannot create the folder of '" + path + "': " + ec.message());
    file_.reset(std::fopen(path.c_str(), "w"));
    if (!file_) return Status::error("cannot write '" + path + "': " + std::strerror(errno));
    line_.reserve(4096);
    return {};
  }
  // False when the line could not be written whole (disk full, ...).
  bool write(const Message& message, bool flush) {
    line_.clear();
    append_json(line_, message);
    line_ += '\n';
    const bool whole = std::fwrite(line_.data(), 1, line_.size(), file_.get()) == line_.size();
    return whole && (!flush || std::fflush(file_.get()) == 0);
  }
  // False when what was buffered could not be written.
  bool close() {
    if (!file_) return true;
    const bool ok = std::fflush(file_.get()) == 0 && !std::ferror(file_.get());
    file_.reset();
    return ok;
  }

 private:
  struct Closer {
    void operator()(std::FILE* f) const { std::fclose(f); }
  };
  std::unique_ptr<std::FILE, Closer> file_;
  std::string line_;
};

class JsonLines final : public Node {
 public:
  static constexpr const char* kName = "jsonl";
  static constexpr In<Message> kIn{"in", "any message"};

  static Contract contract() {
    return Contract(
               "Writes every message it receives as one line of JSON: {\"type\", \"frame\", \"stamp_ns\", "
               "\"origin_ns\", then the type's fields} (schemas: docs/plugins.md). Matrices appear by shape.")
        .ports(kIn)
        .required_string("path", "file to write (created or truncated)")
        .param_bool("flush", false, "flush after every line (a reader tailing the file sees each at once)");
  }
  Status open(OpenContext& ctx) override {
    path_ = ctx.params().get_string("path");
    flush_ = ctx.params().get_bool("flush");
    write_errors_ = &ctx.counter("write_errors");
    return writer_.open(path_);
  }
  Status process(ProcessContext& ctx) override {
    if (!writer_.write(*ctx.get(kIn), flush_)) write_errors_->fetch_add(1, std::memory_order_relaxed);
    return {};
  }
  void close() override {
    if (!writer_.close()) write_errors_->fetch_add(1, std::memory_order_relaxed);
  }

 private:
  JsonLinesWriter writer_;
  std::string path_;
  bool flush_ = false;
  std::atomic<uint64_t>* write_errors_ = nullptr;
};

}  // namespace saccade::util
