#pragma once
// The .cpvs container, versions 1.x to 3.x (byte-level spec: formats/cpvs/format.md). Little-endian, pointer-free,
// memory-mappable; a 64-byte header, a section table, 64-byte aligned sections each with an XXH3-64 checksum,
// zero padding; no timestamps or random ids (same content, same bytes).
//
// This header and its .cpp files belong to the engine-side runtime (cpvs_runtime): no GL, Embree, glTF or
// JSON library. Little-endian hosts only (the node units and leaf masks are used in place).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "formats/cpvs/cpvs_format.h"
#include "libcpvs/runtime/byte_dag.h"
#include "libcpvs/runtime/shadow_dag.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/outcome.h"
#include "libcpvs/runtime/portability.h"

namespace cpvs {

class FilePool;

// A validated, read-only .cpvs in memory (mapped, owned or borrowed). Everything is checked at open time,
// in time linear in the file size: after open() succeeds, DagView traversal of any voxel of any view stays
// inside the buffers and terminates.
class CpvsFile {
public:
  struct View {
    LightView view;
    // The DAG in the stored form of 2.0: spans into the view's NODE and LEAF sections (1.x: a copy converted on
    // open; 3.x: the file's node pool converted once on open, shared with the other views, DagView::sharedNodes).
    // The file object owns what was converted.
    DagView dag;
    // The DAG where the file holds it, read in place: the view's own sections (2.x, 1.x: the converted copy) or
    // the file's node pool (3.x).
    ByteDagView bytes;
    std::vector<uint64_t> nodesPerLevel;  // one count per level, root level first (3.x: zeros; ownDag counts)
    uint64_t nodeBytes = 0;               // size of the view's NODE section in the file (3.x: 0, it has none)
  };
  // One level of a 3.x file's node pool (formats/cpvs/format.md, "POOL").
  struct PoolLevel {
    uint32_t edge = 0;
    uint8_t shortBytes = 0, longBytes = 0;
    uint64_t offset = 0, bytes = 0, nodes = 0;  // in NODE
    uint64_t hotEntries = 0;                    // 0: short references are byte offsets
  };
  struct LightEntry {
    Light light;
    std::vector<View> views;
  };
  struct SectionInfo {
    std::string type;   // four characters
    uint32_t elementSize = 0;
    uint64_t offset = 0, size = 0;
    uint64_t checksum = 0;
    bool checksumOk = false;  // always true once open() has succeeded
  };

  // Opens and validates a file (memory-mapped, read-only). Fails (InvalidInput) with a message naming the file
  // and what is wrong: not a .cpvs file, text-mode damage, unknown major version (with what to do), truncated,
  // bad section table, checksum mismatch in a named section, a malformed record or DAG. Never throws.
  // The file must not be truncated by another process while it is open (SIGBUS, as with any mapping).
  static Result<std::unique_ptr<CpvsFile>> open(const std::string& path);
  // Same from bytes in memory (copied); `name` is used in messages.
  static Result<std::unique_ptr<CpvsFile>> fromBytes(std::span<const uint8_t> bytes, const std::string& name);
  // Same without a copy: `bytes` must be 8-byte aligned and outlive the returned object.
  static Result<std::unique_ptr<CpvsFile>> fromBorrowedBytes(std::span<const uint8_t> bytes, const std::string& name);
  ~CpvsFile();
  CpvsFile(const CpvsFile&) = delete;
  CpvsFile& operator=(const CpvsFile&) = delete;

  uint16_t majorVersion() const { return major_; }
  uint16_t minorVersion() const { return minor_; }
  const std::vector<LightEntry>& lights() const { return lights_; }
  const std::string& settingsJson() const { return settingsJson_; }
  const std::vector<SectionInfo>& sections() const { return sections_; }
  uint64_t fileSize() const { return size_; }
  std::span<const uint8_t> bytes() const { return {data_, size_t(size_)}; }
  // 3.x: the node pool's levels, ascending edge, and its leaves (empty and 0 in 1.x and 2.x files).
  const std::vector<PoolLevel>& poolLevels() const;
  uint64_t poolLeaves() const;
  // A view's DAG by itself in the stored form of 2.0, with its node counts: a copy of a 1.x or 2.x view's; a
  // 3.x view's nodes and leaves converted out of the pool, as a 2.0 file would store them. For reports, merges
  // and caches; walks read View::dag. Safe from several threads. Fails (InvalidInput) only for a 3.x file whose
  // views would convert to more than 64 times the file and 256 MiB, all calls together.
  Result<ShadowDag> ownDag(const View& view) const;

private:
  CpvsFile() = default;
  // The same, reporting a failure by throwing the reader's own exception (caught by the three above).
  static std::unique_ptr<CpvsFile> openOrThrow(const std::string& path);
  static std::unique_ptr<CpvsFile> fromBytesOrThrow(std::span<const uint8_t> bytes, const std::string& name);
  static std::unique_ptr<CpvsFile> fromBorrowedBytesOrThrow(std::span<const uint8_t> bytes, const std::string& name);
  void parse(const std::string& name);

  const uint8_t* data_ = nullptr;
  uint64_t size_ = 0;
  portable::ReadOnlyFile mapped_;  // open(): the file mapped (portability.h)
  std::vector<uint64_t> owned_;    // when built from bytes (uint64_t: 8-byte aligned for the leaf masks)
  uint16_t major_ = 0, minor_ = 0;
  std::vector<LightEntry> lights_;
  std::string settingsJson_;
  std::vector<SectionInfo> sections_;
  std::vector<std::unique_ptr<ShadowDag>> converted_;  // 1.x DAGs in the stored form of format 2
  std::unique_ptr<FilePool> pool_;                     // 3.x
};

// Validates one view's DAG in the stored form exactly as open() validates a view of a file (every node fits,
// every reference points to the start of a node of the next level or to a leaf, the per-level counts tile the
// units), without the file around it: the writer checks a DAG it is about to write in place instead of
// copying it into a test file. nodesPerLevel holds one count per level of `resolution` (missing ones are 0).
// Fails (InvalidInput) with a message that starts with `what`.
Outcome validateStoredDag(const std::string& what, uint32_t resolution, ChildCode rootCode,
                          std::span<const uint16_t> nodes, uint64_t leafCount, std::span<const uint64_t> nodesPerLevel);

}  // namespace cpvs
