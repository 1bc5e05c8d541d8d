#pragma once
// Memory of this process: the resident peak, as the bake and query reports give it, and the current resident and
// mapped sizes, as the bake's memory budgets check them.
#include <cstdint>

#include "libcpvs/base/memory_limit.h"

namespace cpvs {

// Largest resident set size so far, in bytes (0 where the system does not say).
uint64_t peakRssBytes();
// Resident set size now, in bytes (0 where the system does not say).
uint64_t currentRssBytes();
// What `measure` counts now, in bytes: the resident set, the whole address space (as RLIMIT_AS counts it) or the
// private writable mappings and the stack (at least what RLIMIT_DATA counts). 0 where the system does not say.
uint64_t currentMemoryBytes(MemoryMeasure measure);

}  // namespace cpvs
