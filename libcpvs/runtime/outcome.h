#pragma once
// What the runtime returns instead of throwing: an Outcome (ok, or an error category and a message naming the
// file and element) and Result<T> (a value or a failed Outcome). The categories say what went wrong, not what
// a tool should do about it: each tool maps them to its exit codes (docs/architecture.md, "Errors").
#include <cstdint>
#include <string>
#include <utility>
#include <variant>

namespace cpvs {

enum class ErrorCategory : uint8_t {
  InvalidArgument = 1,  // a parameter out of its documented range (a caller's mistake)
  InvalidInput = 2,     // an input file or record that is unreadable, malformed or inconsistent
  OutputFailed = 3,     // an output that cannot be written
  RuntimeFailure = 4,   // a resource ran out or a subsystem failed (memory, GL, a size limit of the format)
  NotSupported = 5,     // not available in this build or on this machine (e.g. no EGL)
};

// "invalid argument", "invalid input", ...
const char* errorCategoryName(ErrorCategory category);

class [[nodiscard]] Outcome {
public:
  Outcome() = default;  // ok
  Outcome(ErrorCategory category, std::string message) : ok_(false), category_(category), message_(std::move(message)) {}
  static Outcome success() { return {}; }

  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  ErrorCategory category() const { return category_; }
  const std::string& message() const { return message_; }

private:
  bool ok_ = true;
  ErrorCategory category_ = ErrorCategory::RuntimeFailure;
  std::string message_;
};

// A value, or the Outcome that says why there is none. Never throws: value() on a failed result is a
// precondition violation (check ok() first).
template <class T>
class [[nodiscard]] Result {
public:
  Result(T value) : state_(std::in_place_index<0>, std::move(value)) {}
  Result(Outcome failure) : state_(std::in_place_index<1>, std::move(failure)) {}

  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }
  T& value() & { return *std::get_if<0>(&state_); }
  const T& value() const& { return *std::get_if<0>(&state_); }
  T&& value() && { return std::move(*std::get_if<0>(&state_)); }
  // The failure (an ok Outcome when there is a value).
  Outcome outcome() const { return ok() ? Outcome() : *std::get_if<1>(&state_); }

private:
  std::variant<T, Outcome> state_;
};

}  // namespace cpvs
