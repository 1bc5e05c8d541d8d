#include "libcpvs/base/peak_memory.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>

namespace cpvs {

uint64_t peakRssBytes() {
  struct rusage usage {};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

uint64_t currentRssBytes() {
  // /proc/self/statm: total and resident size in pages.
  FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  unsigned long long total = 0, resident = 0;
  const int read = std::fscanf(f, "%llu %llu", &total, &resident);
  std::fclose(f);
  return read == 2 ? uint64_t(resident) * uint64_t(::sysconf(_SC_PAGESIZE)) : 0;
}

}  // namespace cpvs
