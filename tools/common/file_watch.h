#pragma once
// The live loop's watch (cpvs-bake --watch, cpvs-view --window): which files changed since a moment, by each
// file's size and modification time, polled. Polling rather than inotify: a DCC's save may replace the file
// (a rename over it), write it in place, or write it in several pieces, and a network share may not deliver
// inotify events at all; a stat of a few files every 200 ms costs nothing.
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace cpvs::tools {

// What a file looked like: missing, or its size and modification time (ns).
struct FileStamp {
  bool exists = false;
  uint64_t size = 0;
  int64_t modifiedNs = 0;
  bool operator==(const FileStamp&) const = default;
};
using FileStamps = std::vector<FileStamp>;

FileStamps stampsOf(const std::vector<std::string>& files);

// Polls `files` every `poll` until their stamps differ from `since`, then until they hold still for one more poll
// (a save still being written is not read half-way); returns the stamps they settled at. Returns at once when
// they already differ and hold still.
FileStamps waitForChange(const std::vector<std::string>& files, const FileStamps& since,
                         std::chrono::milliseconds poll = std::chrono::milliseconds(200));

}  // namespace cpvs::tools
