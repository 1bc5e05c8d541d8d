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

uint64_t currentRssBytes() { return currentMemoryBytes(MemoryMeasure::Resident); }

uint64_t currentMemoryBytes(MemoryMeasure measure) {
  // /proc/self/statm, in pages: size (the address space), resident, shared, text, lib (0), data (data + stack).
  FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  unsigned long long size = 0, resident = 0, shared = 0, text = 0, lib = 0, data = 0;
  const int read = std::fscanf(f, "%llu %llu %llu %llu %llu %llu", &size, &resident, &shared, &text, &lib, &data);
  std::fclose(f);
  if (read != 6) return 0;
  const unsigned long long pages = measure == MemoryMeasure::Resident ? resident
                                   : measure == MemoryMeasure::AddressSpace ? size
                                                                            : data;
  return uint64_t(pages) * uint64_t(::sysconf(_SC_PAGESIZE));
}

}  // namespace cpvs
