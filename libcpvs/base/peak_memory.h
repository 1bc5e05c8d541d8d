#pragma once
// Resident memory of this process: the peak, as the bake and query reports give it, and the current size, as
// the bake's memory budget checks it.
#include <cstdint>

namespace cpvs {

// Largest resident set size so far, in bytes (0 where the system does not say).
uint64_t peakRssBytes();
// Resident set size now, in bytes (0 where the system does not say).
uint64_t currentRssBytes();

}  // namespace cpvs
