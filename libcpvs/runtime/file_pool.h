#pragma once
// The node pool of a 3.x .cpvs (formats/cpvs/format.md, "The node pool"): its POOL records read and checked
// against NODE and HOTT, the pool validated with every view's root (pool_validation.h) before any walk, then
// turned once, for all views together, into the stored form of 2.0 that the batch walks, the PCF footprints,
// the top grid and the GLSL twin read: one array of 16-bit units, levels from the largest edge down, that every
// view's DagView reads from its root on, so that views still share their subtrees (and their cache lines).
// Each view also gets its walk over the pool in place (ByteDagView). Part of CpvsFile's open (cpvs_reader.cpp).
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/pool_validation.h"

namespace cpvs {

struct FilePoolSections {
  std::span<const uint8_t> records;  // POOL
  uint32_t recordSize = 0;           // its element size (at least kPoolLevelRecordSize)
  std::span<const uint8_t> nodes;    // NODE: the levels, then kPoolTailBytes zero bytes
  std::span<const uint32_t> hot;     // HOTT
  std::span<const uint64_t> leaves;  // LEAF
  bool strict = true;                // an x.0 file: reserved fields are zero
  uint64_t maxConvertedBytes = UINT64_MAX;  // what FilePool::ownDag may convert, all calls together
};

// What CpvsFile gives maxConvertedBytes for a file of `fileBytes`: 64 times the file and
// 256 MiB more. Views share the pool, so a small file can name one large subtree from many views; copying it
// for each would let a crafted file take any amount of time and memory. The benchmark bakes' own DAGs take 1.1-1.7
// times their pool (their 2.0 files against 3.0: docs/format3.md).
inline uint64_t convertedBytesAllowed(uint64_t fileBytes) {
  return fileBytes > (UINT64_MAX - (uint64_t(256) << 20)) / 64 ? UINT64_MAX : 64 * fileBytes + (uint64_t(256) << 20);
}

// A read pool: what CpvsFile keeps of it.
class FilePool {
public:
  // Reads the pool into levels(), validates it with the roots the views hold (View::bytes: its root code,
  // resolution and root offset in its level, as read from the VIEW record), then completes each view:
  // View::bytes walks the pool in place, View::dag the pool's units from the view's root on. Fails (InvalidInput)
  // with "<name>: <what is wrong>" naming the pool level, node, hot entry or view.
  static Result<std::unique_ptr<FilePool>> read(const FilePoolSections& sections,
                                                std::span<CpvsFile::View* const> views, const std::string& name);
  ~FilePool();

  const std::vector<CpvsFile::PoolLevel>& levels() const { return levels_; }
  uint64_t leaves() const { return leaves_.size(); }
  // The pool in the stored form of 2.0 that the views' DagViews share.
  std::span<const uint16_t> units() const { return units_; }

  // One view's DAG by itself in the stored form of 2.0 (the nodes and leaves its root reaches, each once, most
  // referenced first, as a 2.0 file stores it), with its node counts: for reports, merges and caches. Safe to
  // call from several threads. Fails (InvalidInput) once the calls together would pass maxConvertedBytes.
  Result<ShadowDag> ownDag(const ByteDagView& view) const;

private:
  FilePool() = default;
  struct Conversion;

  std::vector<CpvsFile::PoolLevel> levels_;
  std::vector<PoolLevelView> levelViews_;  // spans into the file
  std::span<const uint64_t> leaves_;
  std::vector<uint16_t> units_;
  std::string name_;
  uint64_t maxConvertedBytes_ = UINT64_MAX;
  mutable std::mutex mutex_;
  mutable std::unique_ptr<Conversion> conversion_;  // built at the first ownDag
  mutable uint64_t convertedBytes_ = 0;
};

}  // namespace cpvs
