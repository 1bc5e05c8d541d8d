#include "libcpvs/runtime/lookup_isa.h"

#include <cstdlib>
#include <optional>
#include <string>

#include "libcpvs/runtime/batch_cells.h"

namespace cpvs {

Outcome limitCellIsaFromEnvironment() {
  const char* name = std::getenv("CPVS_LOOKUP_ISA");
  if (!name || !*name) return Outcome::success();
  const std::optional<CellIsa> limit = parseCellIsa(name);
  if (!limit)
    return {ErrorCategory::InvalidArgument,
            "CPVS_LOOKUP_ISA='" + std::string(name) + "': expected scalar, neon, avx2 or avx512"};
  setCellIsaLimit(*limit);
  return Outcome::success();
}

}  // namespace cpvs
