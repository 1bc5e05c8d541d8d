#pragma once
// Output files that never exist half-written (docs/cli.md): bytes go to an anonymous file in the target's
// folder (O_TMPFILE), which commit() flushes to disk, names and renames over the target; a killed process
// (even SIGKILL) leaves nothing. Where the file system has no O_TMPFILE, a hidden `.NAME.tmp-XXXXXX` beside
// the target takes its place, removed when the object is destroyed (an error unwinding) and, on Ctrl-C or
// SIGTERM, by a signal handler before the process dies with that signal.
// Creating the object checks that the target can be written (not a directory, its folder writable), so a
// tool can open all its outputs before the work and fail at once. A target that exists and is not a regular
// file (/dev/null, /dev/stdout, a named pipe) is written directly: there is nothing to keep whole, and renaming
// over it would replace the device or pipe with a file.
#include <initializer_list>
#include <string>
#include <string_view>

namespace cpvs::tools {

class AtomicFile {
public:
  // Opens the temporary in the target's folder. Throws Error(OutputFailed) naming `path`.
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(std::string_view bytes);  // Throws Error(OutputFailed).
  // Writes at an offset (pwrite), for files written out of order. Throws Error(OutputFailed).
  void writeAt(uint64_t offset, std::string_view bytes);
  void commit();                       // prepare() then publish(). Throws Error(OutputFailed).
  // The two halves of commit: prepare flushes the bytes to disk (mode 0644) and gives the file a hidden
  // temporary name; publish renames it over the target (which cannot fail for want of space).
  void prepare();
  void publish();
  // The named temporary ("" while the file is anonymous).
  const std::string& temporaryPath() const { return temp_; }

private:
  void discard();

  std::string path_, temp_;
  int fd_ = -1;
  bool exists_ = false;  // the temporary is on disk
  int slot_ = -1;  // where the signal handler finds the temporary's name (-1: not registered)
  bool direct_ = false;  // the target is a device or a pipe, written in place
};

// Commits several outputs of one run together: all are flushed and named first, then all renamed into place,
// so a failure (a full disk) leaves none of them changed. Null entries are skipped.
void commitTogether(std::initializer_list<AtomicFile*> files);

// The whole file at once.
void writeFileAtomically(const std::string& path, std::string_view bytes);

}  // namespace cpvs::tools
