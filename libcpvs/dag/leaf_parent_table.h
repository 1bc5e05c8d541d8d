#pragma once
// Hash-consing of the leaf parents (the last node level), which hold most of a view's node words: 8.7 words a
// node on a forest's sun, where every leaf edge is a silhouette. They are kept byte-coded instead of as words:
// the u16 header, then the first leaf reference as a LEB128 varint and each further one as the varint of its
// zigzag difference to the one before. The leaves of one leaf parent were mostly interned one after the other
// (the slices of one tile), so the differences are small: on the foliage sun at 64k the level takes 601 MB
// instead of 1,194 MB of words (a one-off measurement: docs/construction.md, "Memory that follows the file").
// The code is canonical and prefix-free, so two nodes are equal exactly when their bytes are, and the table
// (interned_records.h) compares bytes.
#include <cstdint>

#include "libcpvs/dag/interned_records.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

// A stored leaf parent's length in bytes, found by decoding it (the code is prefix-free).
struct LeafParentLength {
  uint32_t operator()(const uint8_t* node) const;
};

// Leaf parents interned by their bytes; records() are the bytes.
class LeafParentTable : public InternedRecords<uint8_t, LeafParentLength> {
public:
  using InternedRecords::intern;

  static constexpr unsigned kMaxNodeBytes = 2 + 8 * 5;  // header, eight 33-bit varints

  // Writes the node (a build-form header, codes 0..2, and its leaf references in child order) to `out`;
  // returns its length.
  static unsigned encode(uint32_t header, const uint32_t* refs, unsigned count, uint8_t* out) {
    out[0] = uint8_t(header);
    out[1] = uint8_t(header >> 8);
    unsigned at = 2;
    int64_t previous = 0;
    for (unsigned k = 0; k < count; ++k) {
      const int64_t delta = int64_t(refs[k]) - previous;
      uint64_t v = k == 0 ? refs[k] : delta < 0 ? (uint64_t(-delta) << 1) - 1 : uint64_t(delta) << 1;
      previous = refs[k];
      for (; v >= 0x80; v >>= 7) out[at++] = uint8_t(v | 0x80);
      out[at++] = uint8_t(v);
    }
    return at;
  }
  // Reads the node at `in` into its header and references; returns its length.
  static unsigned decode(const uint8_t* in, uint32_t& header, uint32_t (&refs)[8]) {
    header = uint32_t(in[0]) | (uint32_t(in[1]) << 8);
    const unsigned count = nodeWordCount(header) - 1;
    unsigned at = 2;
    int64_t previous = 0;
    for (unsigned k = 0; k < count; ++k) {
      uint64_t v = 0;
      for (unsigned shift = 0;; shift += 7) {
        const uint8_t byte = in[at++];
        v |= uint64_t(byte & 0x7F) << shift;
        if (!(byte & 0x80)) break;
      }
      const int64_t value = k == 0 ? int64_t(v) : previous + ((v & 1) ? -int64_t((v + 1) >> 1) : int64_t(v >> 1));
      refs[k] = uint32_t(value);
      previous = value;
    }
    return at;
  }

  // Returns the byte offset of a node equal to the given one, appending it when new.
  uint32_t intern(uint32_t header, const uint32_t* refs, unsigned count) {
    uint8_t node[kMaxNodeBytes];
    const unsigned length = encode(header, refs, count, node);
    return intern(node, length);
  }
};

inline uint32_t LeafParentLength::operator()(const uint8_t* node) const {
  uint32_t header, refs[8];
  return LeafParentTable::decode(node, header, refs);
}

}  // namespace cpvs
