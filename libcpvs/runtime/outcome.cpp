#include "libcpvs/runtime/outcome.h"

namespace cpvs {

const char* errorCategoryName(ErrorCategory category) {
  switch (category) {
    case ErrorCategory::InvalidArgument: return "invalid argument";
    case ErrorCategory::InvalidInput: return "invalid input";
    case ErrorCategory::OutputFailed: return "output failed";
    case ErrorCategory::RuntimeFailure: return "runtime failure";
    case ErrorCategory::NotSupported: return "not supported";
  }
  return "error";
}

}  // namespace cpvs
