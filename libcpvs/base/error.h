#pragma once
// The baker's errors: an exception that carries the runtime's ErrorCategory and a message naming the file and
// the element. The library never speaks of exit codes or command-line flags; tools map the category to their
// exit code (tools/common/exit_codes.h) and add their own flag names.
#include <stdexcept>
#include <string>
#include <utility>

#include "libcpvs/runtime/outcome.h"

namespace cpvs {

class Error : public std::runtime_error {
public:
  Error(ErrorCategory category, const std::string& message) : std::runtime_error(message), category_(category) {}
  explicit Error(const Outcome& failure) : Error(failure.category(), failure.message()) {}
  ErrorCategory category() const { return category_; }

private:
  ErrorCategory category_;
};

// A bake stopped before it would outgrow its memory budget (a RuntimeFailure; the Python module raises
// MemoryError for it).
class MemoryBudgetError : public Error {
public:
  explicit MemoryBudgetError(const std::string& message) : Error(ErrorCategory::RuntimeFailure, message) {}
};

// Throws Error for a failed Outcome (where the baker meets the runtime's non-throwing API).
inline void orThrow(const Outcome& status) {
  if (!status.ok()) throw Error(status);
}
template <class T>
T orThrow(Result<T>&& result) {
  if (!result.ok()) throw Error(result.outcome());
  return std::move(result).value();
}

}  // namespace cpvs
