#include "tools/common/file_watch.h"

#include <thread>

#include <sys/stat.h>

namespace cpvs::tools {

FileStamps stampsOf(const std::vector<std::string>& files) {
  FileStamps stamps(files.size());
  for (size_t i = 0; i < files.size(); ++i) {
    struct stat st {};
    if (::stat(files[i].c_str(), &st) != 0) continue;
    stamps[i] = {true, uint64_t(st.st_size), int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec};
  }
  return stamps;
}

FileStamps waitForChange(const std::vector<std::string>& files, const FileStamps& since,
                         std::chrono::milliseconds poll) {
  FileStamps now = stampsOf(files);
  while (now == since) {
    std::this_thread::sleep_for(poll);
    now = stampsOf(files);
  }
  for (;;) {  // settled: the same twice in a row
    std::this_thread::sleep_for(poll);
    FileStamps next = stampsOf(files);
    if (next == now) return next;
    now = std::move(next);
  }
}

}  // namespace cpvs::tools
