// libFuzzer target: the .cpvs reader and the lookups on whatever it accepts. Any input must either be refused
// with an Outcome or open into a file whose every lookup stays in bounds (ASan checks that).
// With CPVS_FUZZ_FIX_CHECKSUMS the checksums are recomputed before reading, so mutations get past the
// checksum test and reach the semantic checks of the records and the DAGs.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include <xxhash.h>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/file_shadows.h"

namespace {

uint64_t readU64(const std::vector<uint8_t>& b, size_t at) {
  uint64_t v = 0;
  std::memcpy(&v, b.data() + at, 8);
  return v;
}
uint32_t readU32(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
void writeU64(std::vector<uint8_t>& b, size_t at, uint64_t v) { std::memcpy(b.data() + at, &v, 8); }

// Recomputes every section checksum the table can locate, then the table's and the header's.
void fixChecksums(std::vector<uint8_t>& b) {
  using namespace cpvs::cpvsformat;
  if (b.size() < kHeaderSize) return;
  const uint64_t table = readU64(b, HeaderLayout::kTableOffset);
  const uint32_t count = readU32(b, HeaderLayout::kSectionCount);
  if (table > b.size() || count > (b.size() - table) / kSectionEntrySize) return;
  for (uint32_t i = 0; i < count; ++i) {
    const size_t e = size_t(table) + size_t(i) * kSectionEntrySize;
    const uint64_t offset = readU64(b, e + SectionEntryLayout::kOffset), size = readU64(b, e + SectionEntryLayout::kSize);
    if (offset <= b.size() && size <= b.size() - offset)
      writeU64(b, e + SectionEntryLayout::kChecksum, XXH3_64bits(b.data() + offset, size));
  }
  writeU64(b, HeaderLayout::kTableChecksum, XXH3_64bits(b.data() + table, size_t(count) * kSectionEntrySize));
  writeU64(b, HeaderLayout::kChecksum, XXH3_64bits(b.data(), HeaderLayout::kChecksum));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<uint8_t> bytes(data, data + size);
#ifdef CPVS_FUZZ_FIX_CHECKSUMS
  fixChecksums(bytes);
#endif
  const auto file = cpvs::CpvsFile::fromBytes(bytes, "fuzz.cpvs");
  if (!file) return 0;
  for (const cpvs::CpvsFile::LightEntry& entry : file.value()->lights()) {
    std::vector<cpvs::LightView> views;
    for (const cpvs::CpvsFile::View& v : entry.views) {
      views.push_back(v.view);
      // Every corner and the centre of the grid, straight from the integer coordinates.
      const uint32_t n = v.dag.resolution;
      if (n == 0) continue;
      // The walk over the file's bytes in place too: a 3.x file's pool, a 2.x view's own sections.
      for (uint32_t x : {0u, n / 2, n - 1})
        for (uint32_t z : {0u, n / 2, n - 1}) {
          (void)v.dag.shadowed(x, n - 1 - x, z);
          (void)v.bytes.shadowed(x, n - 1 - x, z);
          (void)v.bytes.tileMask(x, n - 1 - x, z);
        }
    }
    for (int grid : {0, cpvs::kAutomaticTopGrid}) {
      auto shadow = cpvs::lightShadowOf(entry, grid);
      if (!shadow) continue;
      // Points spread over the views' fitted boxes (the mapping, the bias, every walk), in one batch and one by one.
      std::vector<cpvs::SurfacePoint> points;
      for (const cpvs::LightView& view : views)
        for (int i = 0; i < 27; ++i) {
          const glm::dvec3 uvs(view.resolution * ((i % 3) * 0.45 + 0.05), view.resolution * ((i / 3 % 3) * 0.45 + 0.05),
                               view.resolution * ((i / 9) * 0.45 + 0.05));
          points.push_back({cpvs::gridToWorld(view, uvs), glm::dvec3(0, 1, 0)});
        }
      std::vector<float> out(points.size());
      for (int k : {1, 3, 9}) {
        (void)shadow.value().visibility(points, {k}, out);
        for (const cpvs::SurfacePoint& p : points) (void)shadow.value().visibility(p.position, p.normal, {k});
      }
    }
  }
  return 0;
}
