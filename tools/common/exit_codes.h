#pragma once
// The exit codes every cpvs tool documents in --help and docs/cli.md, and how the library's error categories
// map onto them.
#include "libcpvs/runtime/outcome.h"

namespace cpvs::tools {

enum class ExitCode : int {
  Ok = 0,
  Usage = 1,           // bad command line
  InputInvalid = 2,    // input unreadable or invalid (glTF, .cpvs, points)
  OutputFailed = 3,    // output cannot be written
  RuntimeFailure = 4,  // e.g. out of memory, GL failure
  NotSupported = 5,    // not supported in this build / on this machine (e.g. EGL missing)
};

constexpr ExitCode exitCodeFor(ErrorCategory category) {
  switch (category) {
    case ErrorCategory::InvalidArgument: return ExitCode::Usage;
    case ErrorCategory::InvalidInput: return ExitCode::InputInvalid;
    case ErrorCategory::OutputFailed: return ExitCode::OutputFailed;
    case ErrorCategory::RuntimeFailure: return ExitCode::RuntimeFailure;
    case ErrorCategory::NotSupported: return ExitCode::NotSupported;
  }
  return ExitCode::RuntimeFailure;
}

}  // namespace cpvs::tools
