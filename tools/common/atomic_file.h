#pragma once
// Output files that never exist half-written (docs/cli.md): bytes go to a hidden temporary beside the target,
// which commit() flushes to disk and renames over it. Until then the temporary is removed when the object is
// destroyed (an error unwinding) and, on Ctrl-C or SIGTERM, by a signal handler before the process dies with
// that signal — so an interrupted tool leaves neither a partial file nor a stray `.NAME.tmp-XXXXXX`.
#include <string>
#include <string_view>

namespace cpvs::tools {

class AtomicFile {
public:
  // Creates `.NAME.tmp-XXXXXX` in the target's folder. Throws Error(OutputFailed) naming `path`.
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(std::string_view bytes);  // Throws Error(OutputFailed).
  void commit();                       // fsync, mode 0644, rename into place. Throws Error(OutputFailed).
  const std::string& temporaryPath() const { return temp_; }

private:
  void discard();

  std::string path_, temp_;
  int fd_ = -1;
  bool exists_ = false;  // the temporary is on disk
  int slot_ = -1;  // where the signal handler finds the temporary's name (-1: not registered)
};

// The whole file at once.
void writeFileAtomically(const std::string& path, std::string_view bytes);

}  // namespace cpvs::tools
