#include "libcpvs/base/peak_memory.h"

#include <sys/resource.h>

namespace cpvs {

uint64_t peakRssBytes() {
  struct rusage usage {};
  if (::getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

}  // namespace cpvs
