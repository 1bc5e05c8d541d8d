#include "libcpvs/lookup/batch_cells.h"

#include <algorithm>
#include <cstdlib>
#include <string>

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

template <class Shape>
void mapCellsShaped(const CellBatchInput& in, const CellBatchOutput& out) {
  // Local copies, as in the AVX2 path (the byte stores to out.state could alias the constants).
  const ViewMapping mapping = *in.mapping;
  const CellSettings settings = in.settings;
  const SpotInfluence spot = in.spot ? *in.spot : SpotInfluence{};
  const SpotInfluence* spotOrNull = in.spot ? &spot : nullptr;
  for (size_t j = 0; j < in.count; ++j) {
    const double* p = in.points + 6 * size_t(in.indices ? in.indices[j] : j);
    const CellVerdict<double, bool> v =
        cellVerdict<double, bool, Shape>(mapping, settings, spotOrNull, p[0], p[1], p[2], p[3], p[4], p[5]);
    out.x[j] = int32_t(v.x);
    out.y[j] = int32_t(v.y);
    out.z[j] = int32_t(v.z);
    out.state[j] = v.voxel ? kCellVoxel : (v.lit ? kCellLit : kCellZero);
  }
}

void mapCellsScalar(const CellBatchInput& in, const CellBatchOutput& out) {
  detail::withFixedShape(*in.mapping, [&](auto shape) { mapCellsShaped<decltype(shape)>(in, out); });
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
