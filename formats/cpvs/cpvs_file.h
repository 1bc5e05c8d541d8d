#pragma once
// The .cpvs container, version 2.0 (byte-level spec: docs/format.md). Little-endian, pointer-free,
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

#include "libcpvs/dag/shadow_dag.h"
#include "libcpvs/light_view.h"
#include "libcpvs/scene.h"

namespace cpvs {

// Same-major rule: a reader of 2.x opens every 2.y file. A minor version may add section types (readers skip
// the ones they do not know) and append fields to light and view records (readers read the prefix they know,
// the record size is in the section table); it never changes the meaning of an existing byte. Anything else
// bumps the major version, which readers reject with a message that says what to do.
// Format 2.0 stores node references in 16 or 32 bits (1.0: always 32); this reader still opens 1.x files,
// converting their DAGs on open.
inline constexpr uint16_t kCpvsMajorVersion = 2;
inline constexpr uint16_t kCpvsMinorVersion = 0;
inline constexpr uint16_t kCpvsOldestReadableMajor = 1;
// PNG-style magic: a high-bit byte, the name, CR LF, Ctrl-Z — catches 7-bit and text-mode corruption.
inline constexpr uint8_t kCpvsMagic[8] = {0x89, 'C', 'P', 'V', 'S', '\r', '\n', 0x1A};

// Layout constants of version 2.0, the same as 1.0 but for the NODE element (docs/format.md has the tables).
namespace cpvsformat {
inline constexpr uint32_t kHeaderSize = 64;
inline constexpr uint32_t kSectionEntrySize = 32;
inline constexpr uint32_t kAlignment = 64;          // of the section table and of every section
inline constexpr uint32_t kLightRecordSize = 112;   // LGHT record, 1.0 and 2.0
inline constexpr uint32_t kViewRecordSize = 472;    // VIEW record, 1.0 and 2.0
inline constexpr uint32_t kMaxLevels = 32;          // nodesPerLevel slots in a VIEW record
inline constexpr uint32_t kMaxResolution = 1u << 20;
// Section types, as the four bytes in the file (first character in the lowest byte).
inline constexpr uint32_t fourcc(char a, char b, char c, char d) {
  return uint32_t(uint8_t(a)) | uint32_t(uint8_t(b)) << 8 | uint32_t(uint8_t(c)) << 16 | uint32_t(uint8_t(d)) << 24;
}
inline constexpr uint32_t kBake = fourcc('B', 'A', 'K', 'E');  // bake settings, UTF-8 JSON text
inline constexpr uint32_t kStrs = fourcc('S', 'T', 'R', 'S');  // string pool (light names)
inline constexpr uint32_t kLght = fourcc('L', 'G', 'H', 'T');  // light records
inline constexpr uint32_t kView = fourcc('V', 'I', 'E', 'W');  // view records
inline constexpr uint32_t kNode = fourcc('N', 'O', 'D', 'E');  // one view's node units (u16; 1.x: u32 words)
inline constexpr uint32_t kLeaf = fourcc('L', 'E', 'A', 'F');  // one view's leaf masks (u64)
}  // namespace cpvsformat

// What the baker hands to the writer.
struct BakedView {
  LightView view;
  // dag.resolution must equal view.resolution (or be 0 for an all-lit / all-shadowed DAG with no nodes);
  // dag.nodesPerLevel has one count per level (log2(N) - 2 of them), or is empty when there are no nodes.
  ShadowDag dag;
};
struct BakedLight {
  Light light;
  std::vector<BakedView> views;
};
struct CpvsContent {
  std::vector<BakedLight> lights;
  std::string settingsJson;  // bake-settings block: resolution, modes, tool version, input content hash
};

// Serialises deterministically (same content, same bytes). The result is validated as a reader would before
// it is returned: content that would not read back (a malformed DAG, a non-finite view parameter, a
// resolution that is not a power of two) throws Error(RuntimeFailure) naming the light and view.
std::string writeCpvs(const CpvsContent& content);

// A validated, read-only .cpvs in memory (mapped, owned or borrowed). Everything is checked at open time,
// in time linear in the file size: after open() succeeds, DagView traversal of any voxel of any view stays
// inside the buffers and terminates.
class CpvsFile {
public:
  struct View {
    LightView view;
    DagView dag;                          // spans into the file's NODE and LEAF sections (format 1: a converted copy)
    std::vector<uint64_t> nodesPerLevel;  // one count per level, root level first
    uint64_t nodeBytes = 0;               // size of the view's NODE section in the file
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

  // Opens and validates a file (memory-mapped, read-only). Throws Error(InputInvalid) naming the file and
  // what is wrong: not a .cpvs file, text-mode damage, unknown major version (with what to do), truncated,
  // bad section table, checksum mismatch in a named section, a malformed record or DAG.
  // The file must not be truncated by another process while it is open (SIGBUS, as with any mapping).
  static std::unique_ptr<CpvsFile> open(const std::string& path);
  // Same from bytes in memory (copied); `name` is used in messages.
  static std::unique_ptr<CpvsFile> fromBytes(std::span<const uint8_t> bytes, const std::string& name);
  // Same without a copy: `bytes` must be 8-byte aligned and outlive the returned object.
  static std::unique_ptr<CpvsFile> fromBorrowedBytes(std::span<const uint8_t> bytes, const std::string& name);
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

private:
  CpvsFile() = default;
  void parse(const std::string& name);

  const uint8_t* data_ = nullptr;
  uint64_t size_ = 0;
  void* mapping_ = nullptr;        // mmap'd region, or null
  std::vector<uint64_t> owned_;    // when built from bytes (uint64_t: 8-byte aligned for the leaf masks)
  uint16_t major_ = 0, minor_ = 0;
  std::vector<LightEntry> lights_;
  std::string settingsJson_;
  std::vector<SectionInfo> sections_;
  std::vector<std::unique_ptr<ShadowDag>> converted_;  // format-1 DAGs in the stored form of format 2
};

}  // namespace cpvs
