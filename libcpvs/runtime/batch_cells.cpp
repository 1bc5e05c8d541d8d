#include "libcpvs/runtime/batch_cells.h"

#include <algorithm>
#include <cstdlib>
#include <string>

#include "libcpvs/runtime/lane_loop.h"

namespace cpvs {

namespace {

CellIsa detectCellIsa() {
#if defined(__x86_64__) && defined(__GNUC__)
  if (__builtin_cpu_supports("avx512f")) return CellIsa::Avx512;
  if (__builtin_cpu_supports("avx2")) return CellIsa::Avx2;
#endif
  return CellIsa::Scalar;
}

}  // namespace

CellIsa bestCellIsa() {
  static const CellIsa best = [] {
    const CellIsa detected = detectCellIsa();
    // CPVS_LOOKUP_ISA=scalar|avx2|avx512 lowers it (to compare the paths, or to rule one out); a path the CPU
    // lacks, or any other value, is ignored.
    const char* wanted = std::getenv("CPVS_LOOKUP_ISA");
    if (!wanted) return detected;
    const std::string name(wanted);
    const CellIsa limit = name == "scalar" ? CellIsa::Scalar
                          : name == "avx2" ? CellIsa::Avx2
                                           : CellIsa::Avx512;
    return std::min(limit, detected);
  }();
  return best;
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
  static uint64_t cells(const CellVerdict<double, bool>& v, int32_t* xs, int32_t* ys, int32_t* zs) {
    xs[0] = int32_t(v.x);
    ys[0] = int32_t(v.y);
    zs[0] = int32_t(v.z);
    return v.voxel ? kCellVoxel : (v.lit ? kCellLit : kCellZero);
  }
};

void mapCellsScalar(const CellBatchInput& in, const CellBatchOutput& out) {
  detail::withFixedShape(*in.mapping, [&](auto shape) { mapCellsShaped<ScalarLanes, decltype(shape)>(in, out); });
}

}  // namespace

void mapCells(const CellBatchInput& in, const CellBatchOutput& out, CellIsa isa) {
#if defined(__x86_64__) && defined(__GNUC__)
  const CellIsa best = bestCellIsa();
  if (isa == CellIsa::Avx512 && best == CellIsa::Avx512) return detail::mapCellsAvx512(in, out);
  if (isa >= CellIsa::Avx2 && best >= CellIsa::Avx2) return detail::mapCellsAvx2(in, out);
#endif
  (void)isa;
  mapCellsScalar(in, out);
}

}  // namespace cpvs
