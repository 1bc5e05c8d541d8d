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
  // The most the views' converted DAGs may take together. Views share the pool, so a small file can name a DAG
  // many times over; its copies are bounded so that no file can make an open take unbounded memory or time.
  uint64_t maxConvertedBytes = UINT64_MAX;
};
// What CpvsFile gives maxConvertedBytes for a file of `fileBytes`: 64 times the file, and 256 MiB more. The
// benchmark bakes convert to 1.1-1.7 times their size (their 2.0 files against 3.0: docs/format3.md).
inline uint64_t convertedBytesAllowed(uint64_t fileBytes) {
  return fileBytes > (UINT64_MAX - (uint64_t(256) << 20)) / 64 ? UINT64_MAX : 64 * fileBytes + (uint64_t(256) << 20);
}

// Reads the pool into `levels`, validates it with the roots the views hold (View::bytes: its root code,
// resolution and root offset in its level, as read from the VIEW record), then completes each view: View::bytes
// walks the pool, View::dag its converted copy (owned by `converted`), View::nodesPerLevel its own counts. Fails
// (InvalidInput) with "<name>: <what is wrong>" naming the pool level, node, hot entry or view, or saying that the
// converted DAGs would pass maxConvertedBytes.
Outcome readFilePool(const FilePoolSections& sections, std::span<CpvsFile::View* const> views,
                     std::vector<CpvsFile::PoolLevel>& levels, std::vector<std::unique_ptr<ShadowDag>>& converted,
                     const std::string& name);

}  // namespace cpvs
