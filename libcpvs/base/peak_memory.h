#pragma once
// Peak resident memory of this process, as the bake and query reports give it.
#include <cstdint>

namespace cpvs {

// Largest resident set size so far, in bytes (0 where the system does not say).
uint64_t peakRssBytes();

}  // namespace cpvs
