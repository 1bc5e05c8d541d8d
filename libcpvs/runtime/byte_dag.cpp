#include "libcpvs/runtime/byte_dag.h"

#include <bit>
#include <cstring>

namespace cpvs {

ByteDagView ByteDagView::inPlace(const DagView& dag) {
  ByteDagView v;
  v.resolution = dag.resolution;
  v.rootCode = dag.rootCode;
  v.root = 0;
  v.bytes = {reinterpret_cast<const uint8_t*>(dag.nodes.data()), dag.nodes.size_bytes()};
  v.leaves = dag.leaves;
  v.unitForm = true;
  for (uint32_t log2 = 0; log2 < kMaxDagLevels; ++log2) {
    // Above the leaf parents a reference counts units from childBase (a unit offset); below them it is a leaf.
    const bool leafParent = log2 == 3;
    v.coding[log2] = {leafParent ? 0 : uint64_t(dag.childBase[log2]) * 2, 2, 4, uint8_t(leafParent ? 0 : 1), {}};
  }
  return v;
}

uint64_t ByteDagView::childAt(uint64_t at, uint32_t header, unsigned c, unsigned log2Edge) const {
  const LevelCoding& level = coding[log2Edge];
  if (unitForm) {  // the widths and the shift known: one popcount and unit reads, as readRef does
    const uint64_t units = at / 2 + 1 + popcount32(refUnitBits(header) & ((1u << (2 * c)) - 1u));
    uint16_t low, high = 0;
    std::memcpy(&low, bytes.data() + 2 * units, 2);
    if (isWideRef(header, c)) std::memcpy(&high, bytes.data() + 2 * units + 2, 2);
    const uint64_t value = uint32_t(low) | uint32_t(high) << 16;
    return level.childBase + (value << level.shift);
  }
  const uint32_t below = (1u << (2 * c)) - 1u;
  const uint32_t refs = header & 0xAAAAu, wide = refs & (header << 1);
  // popcount32, not std::popcount: without -mpopcnt the latter is a call into libgcc.
  const uint64_t skip = uint64_t(level.shortBytes) * popcount32(refs & below) +
                        uint64_t(level.longBytes - level.shortBytes) * popcount32(wide & below);
  const bool isLong = (wide >> (2 * c + 1)) & 1u;
  const uint32_t value = readLittleEndian(bytes.data() + at + 2 + skip, isLong ? level.longBytes : level.shortBytes);
  if (!isLong && !level.hot.empty()) return level.childBase + level.hot[value];
  return level.childBase + (uint64_t(value) << level.shift);
}

uint32_t ByteDagView::toLeafParent(uint32_t x, uint32_t y, uint32_t z, uint64_t& at) const {
  uint32_t code = uint32_t(rootCode);
  at = root;
  for (uint32_t half = resolution >> 1; half >= 8 && code == uint32_t(ChildCode::Ref); half >>= 1) {
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = headerAt(at);
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) at = childAt(at, header, c, unsigned(std::countr_zero(half)) + 1);
  }
  return code;
}

uint64_t ByteDagView::leafMask(uint64_t at, uint32_t header, unsigned c) const {
  const uint32_t code = childCodeOf(header, c);
  return code == uint32_t(ChildCode::Ref) ? leaves[childAt(at, header, c, 3)] : 0 - uint64_t(code);
}

bool ByteDagView::shadowed(uint32_t x, uint32_t y, uint32_t z) const {
  uint64_t at;
  const uint32_t code = toLeafParent(x, y, z, at);
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const uint32_t header = headerAt(at);
  if (leafShape == LeafShape::Slices) return (leafMask(at, header, z & 7u) >> ((y & 7u) * 8u + (x & 7u))) & 1u;
  const unsigned c = (z & 4u) | ((y & 4u) >> 1) | ((x & 4u) >> 2);
  return (leafMask(at, header, c) >> ((z & 3u) * 16u + (y & 3u) * 4u + (x & 3u))) & 1u;
}

uint64_t ByteDagView::tileMask(uint32_t x, uint32_t y, uint32_t z) const {
  uint64_t at;
  const uint32_t code = toLeafParent(x, y, z, at);
  if (code != uint32_t(ChildCode::Ref)) return 0 - uint64_t(code == uint32_t(ChildCode::Shadowed));
  const uint32_t header = headerAt(at);
  if (leafShape == LeafShape::Slices) return leafMask(at, header, z & 7u);
  uint64_t mask = 0;
  for (unsigned q = 0; q < 4; ++q) {  // octants (x half, y half) = (q & 1, q >> 1) at z's half
    const uint64_t rows = (leafMask(at, header, (z & 4u) | q) >> ((z & 3u) * 16u)) & 0xFFFFu;
    // Its 4 rows at the slice (4 bits each) spread to the low nibbles of 4 bytes, then placed in the tile.
    const uint64_t spread = (rows & 0xFu) | ((rows & 0xF0u) << 4) | ((rows & 0xF00u) << 8) | ((rows & 0xF000u) << 12);
    mask |= spread << ((q >> 1) * 32 + (q & 1u) * 4);
  }
  return mask;
}

}  // namespace cpvs
