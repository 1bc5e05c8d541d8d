// Atomic outputs (docs/cli.md): a committed file holds exactly its bytes; an abandoned one, an error or a
// Ctrl-C leaves neither a partial target nor a stray temporary beside it.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "libcpvs/base/error.h"
#include "support/test_support.h"
#include "tools/common/atomic_file.h"

namespace cpvs {
namespace {

namespace fs = std::filesystem;

std::string readAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

size_t entries(const fs::path& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

TEST(AtomicFile, CommitPutsTheBytesInPlaceAndNothingElse) {
  const fs::path dir = test::tempDir();
  const fs::path target = dir / "out.bin";
  {
    tools::AtomicFile file(target.string());
    EXPECT_EQ(entries(dir), 0u);  // anonymous (O_TMPFILE): nothing with a name before commit
    EXPECT_EQ(file.temporaryPath(), "");
    file.write("first ");
    file.write(std::string(100000, 'x'));
    file.commit();
  }
  EXPECT_EQ(readAll(target), "first " + std::string(100000, 'x'));
  EXPECT_EQ(entries(dir), 1u);
  struct stat st {};
  ASSERT_EQ(::stat(target.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u);
  tools::writeFileAtomically(target.string(), "second");
  EXPECT_EQ(readAll(target), "second");
  EXPECT_EQ(entries(dir), 1u);
}

TEST(AtomicFile, AnAbandonedFileLeavesTheOldTargetAndNoTemporary) {
  const fs::path dir = test::tempDir();
  const fs::path target = dir / "out.bin";
  tools::writeFileAtomically(target.string(), "old");
  {
    tools::AtomicFile file(target.string());
    file.write("new but unfinished");
  }  // an exception unwinding looks the same
  EXPECT_EQ(readAll(target), "old");
  EXPECT_EQ(entries(dir), 1u);
}

// Runs `body` in a child process (which is expected to die of a signal) and returns its wait status.
template <class Fn>
int statusOfChild(Fn&& body) {
  const pid_t child = ::fork();
  if (child == 0) {
    body();
    ::_exit(0);
  }
  int status = 0;
  if (child < 0 || ::waitpid(child, &status, 0) != child) return -1;
  return status;
}

TEST(AtomicFile, CtrlCWhileWritingRemovesTheTemporary) {
  for (int sig : {SIGINT, SIGTERM}) {
    const fs::path dir = test::tempDir();
    const fs::path target = dir / "out.bin";
    tools::writeFileAtomically(target.string(), "old");
    const int status = statusOfChild([&] {
      tools::AtomicFile file(target.string());
      tools::AtomicFile second((dir / "other.bin").string());
      file.write("partial");
      std::raise(sig);  // the handler removes the temporaries and dies of the signal
    });
    EXPECT_TRUE(WIFSIGNALED(status)) << "signal " << sig;
    if (WIFSIGNALED(status)) {
      EXPECT_EQ(WTERMSIG(status), sig);
    }
    EXPECT_EQ(readAll(target), "old");
    EXPECT_EQ(entries(dir), 1u) << "signal " << sig << ": a temporary was left in " << dir;
  }
}

// SIGKILL cannot be caught: with an anonymous temporary there is nothing to clean up, at any moment.
TEST(AtomicFile, SigkillAtAnyMomentLeavesNothing) {
  for (int moment = 0; moment < 3; ++moment) {
    const fs::path dir = test::tempDir();
    const fs::path target = dir / "out.bin";
    tools::writeFileAtomically(target.string(), "old");
    const int status = statusOfChild([&] {
      tools::AtomicFile file(target.string());  // moment 0: right after the temporary appears
      if (moment >= 1) file.write(std::string(1 << 20, 'x'));
      if (moment == 2) ::fsync(1);
      ::kill(::getpid(), SIGKILL);
    });
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
    EXPECT_EQ(readAll(target), "old");
    EXPECT_EQ(entries(dir), 1u) << "moment " << moment << ": something was left in " << dir;
  }
}

TEST(AtomicFile, ANamedPipeIsWrittenInPlaceNotReplaced) {
  // What `cpvs-query ... -o /dev/null` needs: a target that is a device or a pipe stays one (renaming a
  // finished file over /dev/null made it a regular file). A pipe stands in for the device, so that a broken
  // build replaces nothing of the machine's.
  const fs::path dir = test::tempDir();
  const fs::path pipe = dir / "out.fifo";
  ASSERT_EQ(::mkfifo(pipe.c_str(), 0644), 0);
  // The read end first, without blocking (so that opening for writing does not wait); the bytes fit the pipe.
  const int readEnd = ::open(pipe.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(readEnd, 0);
  {
    tools::AtomicFile out(pipe.string());
    out.write("visibility\n1\n");
    out.commit();
  }
  char buffer[64] = {};
  const ssize_t n = ::read(readEnd, buffer, sizeof buffer);
  ::close(readEnd);
  EXPECT_EQ(std::string(buffer, size_t(std::max<ssize_t>(n, 0))), "visibility\n1\n");
  struct stat st {};
  ASSERT_EQ(::stat(pipe.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode)) << "the pipe was replaced";
  EXPECT_EQ(entries(dir), 1u);  // no temporary beside it
}

TEST(AtomicFile, ADirectoryAsTheTargetIsAnOutputErrorAtOnce) {
  const fs::path dir = test::tempDir();
  try {
    tools::AtomicFile file(dir.string());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::OutputFailed);
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos) << e.what();
  }
}

TEST(AtomicFile, AFolderThatCannotBeWrittenIsAnOutputError) {
  const fs::path target = fs::path(test::tempDir()) / "missing" / "out.bin";
  try {
    tools::writeFileAtomically(target.string(), "x");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::OutputFailed);
    EXPECT_NE(std::string(e.what()).find(target.string()), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cpvs
