#pragma once
// The node pool of a 3.x .cpvs (formats/cpvs/format.md, "The node pool"): its POOL records read and checked
// against NODE and HOTT, the pool validated with every view's root (pool_validation.h) before any walk, then each
// view given its walk over the pool (ByteDagView) and, for the walks that read DagView, its DAG in the stored form
// of 2.0, converted. Part of CpvsFile's open (cpvs_reader.cpp).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"

namespace cpvs {

struct FilePoolSections {
  std::span<const uint8_t> records;  // POOL
  uint32_t recordSize = 0;           // its element size (at least kPoolLevelRecordSize)
  std::span<const uint8_t> nodes;    // NODE: the levels, then kPoolTailBytes zero bytes
  std::span<const uint32_t> hot;     // HOTT
  std::span<const uint64_t> leaves;  // LEAF
  bool strict = true;                // an x.0 file: reserved fields are zero
};

// Reads the pool into `levels`, validates it with the roots the views hold (View::bytes: its root code,
// resolution and root offset in its level, as read from the VIEW record), then completes each view: View::bytes
// walks the pool, View::dag its converted copy (owned by `converted`), View::nodesPerLevel its own counts. Fails
// (InvalidInput) with "<name>: <what is wrong>" naming the pool level, node, hot entry or view.
Outcome readFilePool(const FilePoolSections& sections, std::span<CpvsFile::View* const> views,
                     std::vector<CpvsFile::PoolLevel>& levels, std::vector<std::unique_ptr<ShadowDag>>& converted,
                     const std::string& name);

}  // namespace cpvs
