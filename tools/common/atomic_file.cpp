#include "tools/common/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>

#include "libcpvs/base/error.h"

namespace cpvs::tools {

namespace {

// The temporaries of the files being written, for the signal handler: fixed storage, because a handler may
// only call async-signal-safe functions (unlink, signal, raise) and must not allocate or lock.
constexpr int kSlots = 16;
constexpr size_t kPathCapacity = 4096;
char g_paths[kSlots][kPathCapacity];
std::atomic<bool> g_inUse[kSlots];
std::once_flag g_handlersInstalled;

extern "C" void removeTemporariesAndDie(int sig) {
  for (int i = 0; i < kSlots; ++i)
    if (g_inUse[i].load()) ::unlink(g_paths[i]);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

int registerTemporary(const std::string& temp) {
  if (temp.size() >= kPathCapacity) return -1;  // still atomic, only not cleaned up on a signal
  std::call_once(g_handlersInstalled, [] {
    for (int sig : {SIGINT, SIGTERM}) {
      struct sigaction action {};
      action.sa_handler = removeTemporariesAndDie;
      sigemptyset(&action.sa_mask);
      ::sigaction(sig, &action, nullptr);
    }
  });
  static std::mutex slotsMutex;  // threads may write files at once (the handler only reads the flags)
  std::lock_guard<std::mutex> lock(slotsMutex);
  for (int i = 0; i < kSlots; ++i) {
    if (g_inUse[i].load()) continue;
    std::memcpy(g_paths[i], temp.c_str(), temp.size() + 1);
    g_inUse[i].store(true);
    return i;
  }
  return -1;
}

void unregisterTemporary(int slot) {
  if (slot >= 0) g_inUse[slot].store(false);
}

}  // namespace

namespace {

std::string folderOf(const std::string& path) {
  const std::filesystem::path target(path);
  return target.has_parent_path() ? target.parent_path().string() : std::string(".");
}

// ".NAME.tmp-XXXXXX" beside the target.
std::string temporaryName(const std::string& path) {
  const std::filesystem::path target(path);
  std::string name = ".";  // appended piece by piece: GCC 12 misreports the concatenation (-Wrestrict)
  name += target.filename().string();
  name += ".tmp-XXXXXX";
  return (std::filesystem::path(folderOf(path)) / name).string();
}

}  // namespace

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw Error(ErrorCategory::OutputFailed, path + ": is a directory, not a file that can be written");
  struct stat target {};
  if (::stat(path.c_str(), &target) == 0 && !S_ISREG(target.st_mode)) {
    fd_ = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd_ < 0) throw Error(ErrorCategory::OutputFailed, path + ": cannot be written: " + std::strerror(errno));
    direct_ = true;
    return;
  }
  // An anonymous file in the target's folder: nothing with a name exists until commit(), so even SIGKILL
  // leaves no trace. File systems without O_TMPFILE get a named temporary, removed on errors and signals.
  fd_ = ::open(folderOf(path).c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0644);
  if (fd_ >= 0) return;
  if (errno != EOPNOTSUPP && errno != EISDIR && errno != EINVAL && errno != ENOENT)
    throw Error(ErrorCategory::OutputFailed, path + ": cannot write in its folder: " + std::strerror(errno));
  temp_ = temporaryName(path);
  fd_ = ::mkstemp(temp_.data());
  if (fd_ < 0)
    throw Error(ErrorCategory::OutputFailed, path + ": cannot create a temporary file beside it: " + std::strerror(errno));
  exists_ = true;
  slot_ = registerTemporary(temp_);
}

AtomicFile::~AtomicFile() { discard(); }

void AtomicFile::discard() {
  if (fd_ >= 0) ::close(fd_);
  if (exists_) ::unlink(temp_.c_str());
  fd_ = -1;
  exists_ = false;
  unregisterTemporary(slot_);
  slot_ = -1;
}

namespace {

// Writes all of `bytes` by `writeSome(data, size, done)` (a write or pwrite of what is left, after `done` bytes),
// again after a signal. Returns the reason of a failure, or an empty string.
template <class WriteSome>
std::string writeAll(std::string_view bytes, const WriteSome& writeSome) {
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = writeSome(bytes.data() + written, bytes.size() - written, written);
    if (n < 0) {
      if (errno == EINTR) continue;
      return std::strerror(errno);
    }
    written += size_t(n);
  }
  return {};
}

}  // namespace

void AtomicFile::write(std::string_view bytes) {
  if (fd_ < 0) throw Error(ErrorCategory::OutputFailed, path_ + ": write after the file was closed");
  const std::string reason =
      writeAll(bytes, [&](const char* data, size_t size, size_t) { return ::write(fd_, data, size); });
  if (reason.empty()) return;
  discard();
  throw Error(ErrorCategory::OutputFailed, path_ + ": write failed: " + reason);
}

void AtomicFile::writeAt(uint64_t offset, std::string_view bytes) {
  if (fd_ < 0) throw Error(ErrorCategory::OutputFailed, path_ + ": write after the file was closed");
  const std::string reason = writeAll(bytes, [&](const char* data, size_t size, size_t done) {
    return ::pwrite(fd_, data, size, off_t(offset + done));
  });
  if (reason.empty()) return;
  discard();
  throw Error(ErrorCategory::OutputFailed, path_ + ": write failed: " + reason);
}

void AtomicFile::commit() {
  prepare();
  publish();
}

void AtomicFile::prepare() {
  if (fd_ < 0) throw Error(ErrorCategory::OutputFailed, path_ + ": commit after the file was closed");
  if (direct_) {  // a device or a pipe: written already, nothing to flush or name
    ::close(fd_);
    fd_ = -1;
    return;
  }
  auto fail = [&](const std::string& what) {
    const std::string reason = std::strerror(errno);
    discard();
    throw Error(ErrorCategory::OutputFailed, path_ + ": " + what + ": " + reason);
  };
  ::fchmod(fd_, 0644);
  if (::fsync(fd_) != 0) fail("write failed");
  if (!exists_) {
    // Give the anonymous file a temporary name (linkat cannot replace an existing target), then rename it over
    // the target: only between these two calls does a name exist that a kill could leave behind.
    const std::string proc = "/proc/self/fd/" + std::to_string(fd_);
    for (int attempt = 0;; ++attempt) {
      temp_ = temporaryName(path_);
      const int probe = ::mkstemp(temp_.data());  // a fresh unique name...
      if (probe < 0) fail("cannot name the finished file");
      ::close(probe);
      ::unlink(temp_.c_str());  // ...that linkat then takes
      slot_ = registerTemporary(temp_);
      if (::linkat(AT_FDCWD, proc.c_str(), AT_FDCWD, temp_.c_str(), AT_SYMLINK_FOLLOW) == 0) break;
      unregisterTemporary(slot_);
      slot_ = -1;
      if (errno != EEXIST || attempt > 8) fail("cannot name the finished file");
    }
    exists_ = true;
  }
  const int closed = ::close(fd_);
  fd_ = -1;
  if (closed != 0) fail("write failed");
}

void AtomicFile::publish() {
  if (direct_ && fd_ < 0) return;
  if (!exists_ || fd_ >= 0) throw Error(ErrorCategory::OutputFailed, path_ + ": publish before prepare");
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    discard();
    throw Error(ErrorCategory::OutputFailed, path_ + ": cannot rename the finished file into place: " + reason);
  }
  exists_ = false;
  unregisterTemporary(slot_);
  slot_ = -1;
}

void commitTogether(std::initializer_list<AtomicFile*> files) {
  for (AtomicFile* f : files)
    if (f) f->prepare();  // an error here discards every file (their destructors), none is in place yet
  for (AtomicFile* f : files)
    if (f) f->publish();
}

void writeFileAtomically(const std::string& path, std::string_view bytes) {
  AtomicFile file(path);
  file.write(bytes);
  file.commit();
}

}  // namespace cpvs::tools
