#pragma once
// Errors are values. One convention, inside algorithms as at every plugin
// boundary: a function that can fail returns a Status (ok, or the error in
// words), or a Result<T> when it makes a value. No error out-parameters, no
// "empty string means ok", no exceptions for bad input (third-party code that
// throws is caught where it is called). Buffers a caller reuses stay
// out-parameters of a function that returns a Status.
#include <optional>
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

// The value a function made, or the Status saying why it made none.
//   Result<Model> m = Model::load(path);
//   if (!m.ok()) return m.status();
//   use(*m);
template <class T>
class Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT: a value converts, as in `return model;`
  // An error. An ok Status carries no value, so it reads as the error "no value".
  Result(Status status)  // NOLINT: so does an error, as in `return Status::error("...");`
      : status_(status.ok() ? Status::error("no value") : std::move(status)) {}

  bool ok() const { return value_.has_value(); }
  const Status& status() const { return status_; }
  // The error's words; empty when ok.
  const std::string& error() const { return status_.message(); }

  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T& operator*() & { return *value_; }
  const T& operator*() const& { return *value_; }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  // The value, or `fallback` when there is none (as std::optional's).
  T value_or(T fallback) && { return value_ ? std::move(*value_) : std::move(fallback); }

 private:
  std::optional<T> value_;
  Status status_;
};

}  // namespace saccade
