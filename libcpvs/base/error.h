#pragma once
// Errors that carry the exit code a tool should return (DESIGN.md §7).
#include <stdexcept>
#include <string>

namespace cpvs {

enum class ExitCode : int {
  Ok = 0,
  Usage = 1,          // bad command line
  InputInvalid = 2,   // input unreadable or invalid (glTF, .cpvs, points)
  OutputFailed = 3,   // output cannot be written
  RuntimeFailure = 4, // e.g. out of memory budget, GL failure
  NotSupported = 5,   // not supported in this build / on this machine (e.g. EGL missing)
};

// Thrown by the library; tools map it to the exit code. The message names the file and the element.
class Error : public std::runtime_error {
public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

private:
  ExitCode code_;
};

}  // namespace cpvs
