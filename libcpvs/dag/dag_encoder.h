#pragma once
// Turns the builder's node tables into the stored form, most referenced first: the bytes of
// encodeDag(..., NodeOrder::MostReferencedFirst) (libcpvs/runtime/shadow_dag.h), with a memory peak near the
// larger of the tables and the result rather than their sum (docs/construction.md, "Memory"). It consumes the
// tables: each level's words are rewritten in place and given back to the kernel as soon as the stored level
// has them.
#include <cstdint>
#include <vector>

#include "libcpvs/dag/mapped_array.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

// levelWords: one array of build-form words per level above the leaf parents, root level first, whose
// references are offsets into the next level's array; leafParents: the last level, byte-coded
// (leaf_parent_table.h), whose references are indices into `leaves`. Throws Error (RuntimeFailure) where encodeDag
// fails — a level or the whole DAG too large for 32-bit unit offsets — and on a reference that does not start a
// node or names no leaf.
ShadowDag encodeBuiltDag(uint32_t resolution, ChildCode rootCode, std::vector<MappedArray<uint32_t>> levelWords,
                         MappedArray<uint8_t> leafParents, std::vector<uint64_t> leaves);

}  // namespace cpvs
