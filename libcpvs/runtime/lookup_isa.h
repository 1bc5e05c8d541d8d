#pragma once
// The lookups' instruction set as a user picks it: the environment variable CPVS_LOOKUP_ISA, read the same way
// by every tool, the Python module and the example (batch_cells.h has the paths and the limit itself; this
// header is apart because the vector files include that one inside their target regions).
#include "libcpvs/runtime/outcome.h"

namespace cpvs {

// CPVS_LOOKUP_ISA, when set and not empty, passed to setCellIsaLimit. Fails (InvalidArgument, naming the value)
// when it names no path: "scalar", "neon", "avx2" or "avx512".
Outcome limitCellIsaFromEnvironment();

}  // namespace cpvs
