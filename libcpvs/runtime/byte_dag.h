#pragma once
// One walk for a shadow DAG stored as bytes with a coding per level: a 2.x view read in place (its 16-bit units
// as bytes; references of 2 or 4 bytes that count units) and the pooled form a format 3.0 is to store (two
// reference widths per level in bytes, optional hot tables, slice or octant leaves; docs/format-3-study.md,
// libcpvs/dag/node_pool.h). What DagView's walks are to become once 3.0 exists; for now the scalar walk, its
// tile masks, and the proof that both forms read alike (tests/byte_dag_test.cpp). A 2.x view takes a path
// specialized for its form (unitForm) and reads at DagView's speed; the general path of the pooled form costs
// 5-25 % on one view (docs/format-3-study.md, "Lookups"), to be specialized per coding before DagView becomes it.
//
// A node is a 16-bit little-endian header, 2 bits per child (0 lit, 1 shadowed, 2 short, 3 long reference),
// then its references in child order, each in its level's short or long width. The child a reference names
// starts at childBase + (value << shift) in `bytes`, or, where the level has a hot table and the reference is
// short, at childBase + hot[value]; below a leaf parent the value is a leaf index. Reads are exactly a
// reference's width: nothing past the last byte is touched, so a 2.x view needs no padding.
#include <cstdint>
#include <span>

#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

// What the leaves below a leaf parent (an 8^3 block) are. Slices: eight 8x8x1 slices, child z & 7, bit
// (y & 7) * 8 + (x & 7), as in format 2.0. Octants: the block's eight 4^3 octants, child c from bit 2 of z, y
// and x as at every other level, leaf bit (z & 3) * 16 + (y & 3) * 4 + (x & 3).
enum class LeafShape : uint8_t { Slices, Octants };

// A reference of `width` bytes (1 to 4), little-endian, read exactly: nothing past it is touched.
inline uint32_t readLittleEndian(const uint8_t* p, unsigned width) {
  uint32_t v = 0;
  for (unsigned b = 0; b < width; ++b) v |= uint32_t(p[b]) << (8 * b);
  return v;
}

// How the references held by the nodes of one edge read.
struct LevelCoding {
  uint64_t childBase = 0;           // where the children's level starts in `bytes` (0 below leaf parents)
  uint8_t shortBytes = 2, longBytes = 4;
  uint8_t shift = 1;                // a value << shift is the child's byte offset from childBase (2.x: units)
  std::span<const uint32_t> hot;    // not empty: a short reference is a rank, hot[rank] the child's offset
};

struct ByteDagView {
  uint32_t resolution = 0;
  ChildCode rootCode = ChildCode::Lit;
  uint64_t root = 0;  // the root node's first byte
  std::span<const uint8_t> bytes;
  std::span<const uint64_t> leaves;
  LeafShape leafShape = LeafShape::Slices;
  bool unitForm = false;  // a 2.x view in place: widths 2 and 4 and shift 1 everywhere, read as DagView reads them
  LevelCoding coding[kMaxDagLevels];  // by log2 of the edge of the node holding the references

  // A 2.x view's DAG read in place: the same bytes, widths 2 and 4, references in units.
  static ByteDagView inPlace(const DagView& dag);

  // Voxel (x, y, z), all in [0, N): true when shadowed. Assumes a validated DAG (pool_validation.h for the
  // pooled form, the reader for 2.x).
  bool shadowed(uint32_t x, uint32_t y, uint32_t z) const;
  // The 8x8 mask (bit (y & 7) * 8 + (x & 7) set = shadowed) of the tile holding (x, y) at slice z, as a PCF
  // footprint reads it: one slice, or the rows of four octants at that depth.
  uint64_t tileMask(uint32_t x, uint32_t y, uint32_t z) const;

  // The header of the node at byte `at`, and where its child c (a reference) is: the child node's first byte, or
  // below a leaf parent (log2Edge 3) its leaf index. For walks written outside this class (file_pool.cpp).
  uint32_t headerAt(uint64_t at) const { return uint32_t(bytes[at]) | uint32_t(bytes[at + 1]) << 8; }
  uint64_t childAt(uint64_t at, uint32_t header, unsigned c, unsigned log2Edge) const;

private:
  uint32_t toLeafParent(uint32_t x, uint32_t y, uint32_t z, uint64_t& at) const;
  uint64_t leafMask(uint64_t at, uint32_t header, unsigned c) const;
};

}  // namespace cpvs
