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

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string name = ".";  // appended piece by piece: GCC 12 misreports the concatenation (-Wrestrict)
  name += target.filename().string();
  name += ".tmp-XXXXXX";
  temp_ = (dir / name).string();
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

void AtomicFile::write(std::string_view bytes) {
  if (fd_ < 0) throw Error(ErrorCategory::OutputFailed, path_ + ": write after the file was closed");
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + written, bytes.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      const std::string reason = std::strerror(errno);
      discard();
      throw Error(ErrorCategory::OutputFailed, path_ + ": write failed: " + reason);
    }
    written += size_t(n);
  }
}

void AtomicFile::commit() {
  if (fd_ < 0) throw Error(ErrorCategory::OutputFailed, path_ + ": commit after the file was closed");
  ::fchmod(fd_, 0644);
  const bool flushed = ::fsync(fd_) == 0;
  const int closed = ::close(fd_);
  fd_ = -1;
  if (!flushed || closed != 0) {
    const std::string reason = std::strerror(errno);
    discard();
    throw Error(ErrorCategory::OutputFailed, path_ + ": write failed: " + reason);
  }
  if (std::rename(temp_.c_str(), path_.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    discard();
    throw Error(ErrorCategory::OutputFailed, path_ + ": cannot rename the finished file into place: " + reason);
  }
  exists_ = false;
  unregisterTemporary(slot_);
  slot_ = -1;
}

void writeFileAtomically(const std::string& path, std::string_view bytes) {
  AtomicFile file(path);
  file.write(bytes);
  file.commit();
}

}  // namespace cpvs::tools
