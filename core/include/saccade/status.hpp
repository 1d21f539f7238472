#pragma once
// Errors are values at every plugin boundary: a node returns a Status, never throws
// into the host.
#include <string>
#include <utility>

namespace saccade {

class Status {
 public:
  enum class Code { kOk, kError, kEndOfStream };

  Status() = default;
  static Status error(std::string message) { return Status(Code::kError, std::move(message)); }
  // A source has nothing more to give; the executor propagates it downstream.
  static Status end_of_stream() { return Status(Code::kEndOfStream, {}); }

  bool ok() const { return code_ == Code::kOk; }
  bool is_error() const { return code_ == Code::kError; }
  bool is_end_of_stream() const { return code_ == Code::kEndOfStream; }
  Code code() const { return code_; }
  const std::string& message() const { return message_; }

 private:
  Status(Code code, std::string message) : code_(code), message_(std::move(message)) {}
  Code code_ = Code::kOk;
  std::string message_;
};

}  // namespace saccade
