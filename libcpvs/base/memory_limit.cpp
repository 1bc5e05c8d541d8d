#include "libcpvs/base/memory_limit.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

// A limit at or above this is "no limit" (cgroup v1 writes 2^63 rounded down to a page).
constexpr uint64_t kUnlimited = uint64_t(1) << 62;

struct CgroupMount {
  std::string mountPoint;  // where the hierarchy is mounted
  std::string root;        // which of its cgroups the mount shows (not "/" inside some containers)
  bool v2 = false;
};

std::vector<std::string> splitOn(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream in(text);
  while (std::getline(in, part, separator)) parts.push_back(part);
  return parts;
}

bool hasOption(const std::string& options, const std::string& name) {
  for (const std::string& o : splitOn(options, ','))
    if (o == name) return true;
  return false;
}

// /proc/self/mountinfo: "id parent dev root mountpoint options [optional...] - fstype source superoptions".
std::vector<CgroupMount> memoryCgroupMounts() {
  std::vector<CgroupMount> mounts;
  std::ifstream in("/proc/self/mountinfo");
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string id, parent, dev, root, mountPoint, options, field;
    fields >> id >> parent >> dev >> root >> mountPoint >> options;
    while (fields >> field && field != "-") {
    }
    std::string type, source, superOptions;
    fields >> type >> source >> superOptions;
    if (type == "cgroup2") mounts.push_back({mountPoint, root, true});
    if (type == "cgroup" && hasOption(superOptions, "memory")) mounts.push_back({mountPoint, root, false});
  }
  return mounts;
}

// The process's cgroup path in the v2 hierarchy ("0::/path") or the v1 memory hierarchy ("N:...memory...:/path").
std::string cgroupPath(bool v2) {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  while (std::getline(in, line)) {
    const size_t first = line.find(':'), second = line.find(':', first + 1);
    if (first == std::string::npos || second == std::string::npos) continue;
    const std::string controllers = line.substr(first + 1, second - first - 1);
    if (v2 ? (line.compare(0, first, "0") == 0 && controllers.empty()) : hasOption(controllers, "memory"))
      return line.substr(second + 1);
  }
  return "";
}

uint64_t readLimitFile(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text == "max") return 0;
  char* end = nullptr;
  const unsigned long long value = std::strtoull(text.c_str(), &end, 10);
  if (!end || *end != '\0' || value == 0 || value >= kUnlimited) return 0;
  return uint64_t(value);
}

// The tightest limit from the process's cgroup up to the mount's root.
MemoryLimit cgroupLimit() {
  MemoryLimit best;
  for (const CgroupMount& mount : memoryCgroupMounts()) {
    std::string path = cgroupPath(mount.v2);
    // The process's cgroup must lie at or below the mount's root (a whole path component, not "/a/bc" for "/a/b").
    if (path.empty() || path.compare(0, mount.root.size(), mount.root) != 0) continue;
    if (mount.root != "/" && path.size() > mount.root.size() && path[mount.root.size()] != '/') continue;
    path = path.substr(mount.root == "/" ? 0 : mount.root.size());
    const char* file = mount.v2 ? "memory.max" : "memory.limit_in_bytes";
    while (true) {
      const std::string at = mount.mountPoint + (path == "/" ? "" : path) + "/" + file;
      const uint64_t bytes = readLimitFile(at);
      if (bytes && (best.bytes == 0 || bytes < best.bytes)) best = {bytes, "cgroup limit", at};
      if (path.empty() || path == "/") break;
      const size_t slash = path.find_last_of('/');
      path = slash == 0 || slash == std::string::npos ? "/" : path.substr(0, slash);
    }
  }
  return best;
}

MemoryLimit physicalMemory() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || pageSize <= 0) return {};
  return {uint64_t(pages) * uint64_t(pageSize), "physical memory", ""};
}

// A soft resource limit in bytes, 0 when unlimited or unknown.
uint64_t softLimit(int resource) {
  struct rlimit limit {};
  if (::getrlimit(resource, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return 0;
  return uint64_t(limit.rlim_cur);
}

// The budget left under `limit` once the margin is kept, with a source that says both.
MemoryLimit lessMargin(const MemoryLimit& limit) {
  if (limit.bytes == 0) return {};
  const uint64_t margin = memoryMargin(limit.bytes);
  // A limit at or below the margin leaves a token budget: the bake then stops at its first check.
  const uint64_t budget = limit.bytes > margin ? limit.bytes - margin : uint64_t(1) << 20;
  return {budget,
          limit.source + " " + formatMemorySize(limit.bytes) + (limit.file.empty() ? "" : " in " + limit.file) +
              " less " + formatMemorySize(margin),
          limit.file, limit.measure};
}

}  // namespace

uint64_t parseMemorySize(const std::string& text) {
  static const std::string kUnits = "KMGT";
  if (text.empty()) return 0;
  std::string number = text;
  double multiplier = 1;
  const size_t unit = kUnits.find(char(std::toupper(static_cast<unsigned char>(number.back()))));
  if (unit != std::string::npos) {
    multiplier = std::ldexp(1.0, 10 * int(unit + 1));
    number.pop_back();
  }
  char* end = nullptr;
  const double value = number.empty() ? -1 : std::strtod(number.c_str(), &end);
  const double bytes = value * multiplier;
  if (!end || *end != '\0' || !(bytes >= 1) || !(bytes < 0x1p62)) return 0;
  return uint64_t(bytes);
}

std::string formatMemorySize(uint64_t bytes) {
  char text[32];
  if (bytes >= (uint64_t(1) << 30))
    std::snprintf(text, sizeof text, "%.1f GiB", double(bytes) / double(uint64_t(1) << 30));
  else
    std::snprintf(text, sizeof text, "%.0f MiB", double(bytes) / double(1 << 20));
  return text;
}

MemoryLimit processMemoryLimit() {
  MemoryLimit best = physicalMemory();
  const auto tighter = [&](const MemoryLimit& limit) {
    if (limit.bytes && (best.bytes == 0 || limit.bytes < best.bytes)) best = limit;
  };
  tighter(cgroupLimit());
  if (const char* env = std::getenv("CPVS_MEMORY_LIMIT"); env && *env) {  // set but empty: as unset
    const uint64_t bytes = parseMemorySize(env);
    if (bytes == 0)
      throw Error(ErrorCategory::InvalidArgument,
                  std::string("CPVS_MEMORY_LIMIT='") + env + "': expected a size such as 512M or 8G");
    tighter({bytes, "CPVS_MEMORY_LIMIT", ""});
  }
  return best;
}

uint64_t memoryMargin(uint64_t limitBytes) {
  return std::clamp<uint64_t>(limitBytes / 8, uint64_t(64) << 20, uint64_t(4) << 30);
}

MemoryLimit defaultMemoryBudget() { return lessMargin(processMemoryLimit()); }

MemoryLimit mappedMemoryLimit() {
  const uint64_t addressSpace = softLimit(RLIMIT_AS), data = softLimit(RLIMIT_DATA);
  // The data a process maps is part of its address space: the smaller limit is the one reached first.
  if (data && (!addressSpace || data < addressSpace))
    return {data, "data limit (ulimit -d)", "", MemoryMeasure::Data};
  if (addressSpace) return {addressSpace, "address-space limit (ulimit -v)", "", MemoryMeasure::AddressSpace};
  return {};
}

MemoryLimit defaultMappedBudget() { return lessMargin(mappedMemoryLimit()); }

}  // namespace cpvs
