#include "libcpvs/runtime/batch_cells.h"

#include <algorithm>
#include <atomic>
#include <optional>
#include <string>

#include "libcpvs/runtime/lane_loop.h"
#include "libcpvs/runtime/portability.h"

namespace cpvs {

namespace {

CellIsa detectCellIsa() {
#if CPVS_X86_VECTOR_PATHS
  if (portable::cpuHasAvx512f()) return CellIsa::Avx512;
  if (portable::cpuHasAvx2()) return CellIsa::Avx2;
#endif
#if CPVS_ARM_NEON_PATHS
  return CellIsa::Neon;  // every AArch64 CPU has it
#endif
  return CellIsa::Scalar;
}

}  // namespace

namespace {
std::atomic<uint8_t> gCellIsaLimit{uint8_t(CellIsa::Avx512)};
}  // namespace

std::optional<CellIsa> parseCellIsa(const char* name) {
  if (!name) return std::nullopt;
  const std::string n(name);
  if (n == "scalar") return CellIsa::Scalar;
  if (n == "neon") return CellIsa::Neon;
  if (n == "avx2") return CellIsa::Avx2;
  if (n == "avx512") return CellIsa::Avx512;
  return std::nullopt;
}

void setCellIsaLimit(CellIsa limit) { gCellIsaLimit.store(uint8_t(limit), std::memory_order_relaxed); }

CellIsa bestCellIsa() {
  static const CellIsa detected = detectCellIsa();
  return std::min(detected, CellIsa(gCellIsaLimit.load(std::memory_order_relaxed)));
}

namespace {

// One point at a time: a double and a bool per lane.
struct ScalarLanes {
  using Real = double;
  using Mask = bool;
  static constexpr size_t kWidth = 1;
  static void load(const double* const (&p)[1], double (&c)[6]) {
    for (int i = 0; i < 6; ++i) c[i] = p[0][i];
  }
  static void loadSplit(const double* const (&p)[1], const double* const (&n)[1], double (&c)[6]) {
    for (int i = 0; i < 3; ++i) {
      c[i] = p[0][i];
      c[3 + i] = n[0][i];
    }
  }
  static uint64_t cells(const CellVerdict<double, bool>& v, int32_t* xs, int32_t* ys, int32_t* zs) {
    xs[0] = int32_t(v.x);
    ys[0] = int32_t(v.y);
    zs[0] = int32_t(v.z);
    return v.voxel ? kCellVoxel : (v.lit ? kCellLit : kCellZero);
  }
};

void mapCellsScalar(const CellBatchInput& in, const CellBatchOutput& out) {
  mapCellsLanes<ScalarLanes>(in, out);
}

}  // namespace

void mapCells(const CellBatchInput& in, const CellBatchOutput& out, CellIsa isa) {
#if CPVS_X86_VECTOR_PATHS
  const CellIsa best = bestCellIsa();
  if (isa == CellIsa::Avx512 && best == CellIsa::Avx512) return detail::mapCellsAvx512(in, out);
  if (isa >= CellIsa::Avx2 && best >= CellIsa::Avx2) return detail::mapCellsAvx2(in, out);
#endif
#if CPVS_ARM_NEON_PATHS
  if (isa >= CellIsa::Neon && bestCellIsa() >= CellIsa::Neon) return detail::mapCellsNeon(in, out);
#endif
  (void)isa;
  mapCellsScalar(in, out);
}

}  // namespace cpvs
