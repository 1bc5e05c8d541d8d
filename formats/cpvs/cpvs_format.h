#pragma once
// The .cpvs format's version and layout constants, shared by the reader (libcpvs/runtime/cpvs_file.h) and the
// writer (libcpvs/bake/cpvs_writer.h); each field's offset is in cpvs_layout.h. The byte-level spec is
// formats/cpvs/format.md. Like everything in formats/cpvs/, standard library only: an engine vendors this
// folder beside libcpvs/runtime/.
#include <cstdint>
#include <cstdio>
#include <string>

#include "formats/cpvs/cpvs_layout.h"

namespace cpvs {

// An XXH3-64 checksum or input hash as files, reports and messages write it: 16 lowercase hex digits.
inline std::string hex64(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

// Same-major rule: a reader of x.y opens every x.z file of its major versions. A minor version may add section
// types (readers skip the ones they do not know) and append fields to light and view records (readers read the
// prefix they know, the record size is in the section table); it never changes the meaning of an existing byte.
// Anything else bumps the major version, which readers reject with a message that says what to do.
// 1.0 stored node references in 32-bit words (this reader converts their DAGs on open); 2.0 stores each view's
// DAG in its own NODE and LEAF sections, references in 16 or 32 bits; 3.0 stores one pool of nodes and leaves
// per file that every view's root points into, two reference widths per level and hot tables (format.md).
inline constexpr uint16_t kCpvsOldestReadableMajor = 1;
inline constexpr uint16_t kCpvsNewestMajor = 3;         // the newest this build reads and can write
inline constexpr uint16_t kCpvsDefaultMajor = 2;        // what cpvs-bake writes unless told (--format-version)
inline constexpr uint16_t kCpvsMinorVersion = 0;        // of every major version this build writes
// Whether this build can write major version `major`.
inline constexpr bool canWriteMajor(uint32_t major) { return major == 2 || major == 3; }
// PNG-style magic: a high-bit byte, the name, CR LF, Ctrl-Z — catches 7-bit and text-mode corruption.
inline constexpr uint8_t kCpvsMagic[8] = {0x89, 'C', 'P', 'V', 'S', '\r', '\n', 0x1A};

// Layout constants of version 2.0, the same as 1.0 but for the NODE element (formats/cpvs/format.md has the tables).
namespace cpvsformat {
inline constexpr uint32_t kHeaderSize = 64;
inline constexpr uint32_t kSectionEntrySize = 32;
inline constexpr uint32_t kAlignment = 64;          // of the section table and of every section
inline constexpr uint32_t kLightRecordSize = 112;   // LGHT record, every version
inline constexpr uint32_t kViewRecordSize = 472;    // VIEW record, 1.0 and 2.0
inline constexpr uint32_t kPooledViewRecordSize = 216;  // VIEW record, 3.0: no per-view counts
inline constexpr uint32_t kPoolLevelRecordSize = 40;    // POOL record, 3.0
// NODE of a 3.0 file ends with this many zero bytes after its last level, so that a walk may read any reference
// (at most 4 bytes) with one 4-byte load.
inline constexpr uint32_t kPoolTailBytes = 3;
inline constexpr uint32_t kMaxLevels = 32;          // nodesPerLevel slots in a VIEW record
inline constexpr uint32_t kMaxResolution = 1u << 20;
// Largest magnitude of a view bound (lateral extent, near, far) a reader accepts; matrix elements up to twice it.
// Far beyond any level (1e18 scene units), far below where the mapping's arithmetic would overflow.
inline constexpr double kMaxViewCoordinate = 1e18;
// Section types, as the four bytes in the file (first character in the lowest byte).
inline constexpr uint32_t fourcc(char a, char b, char c, char d) {
  return uint32_t(uint8_t(a)) | uint32_t(uint8_t(b)) << 8 | uint32_t(uint8_t(c)) << 16 | uint32_t(uint8_t(d)) << 24;
}
inline constexpr uint32_t kBake = fourcc('B', 'A', 'K', 'E');  // bake settings, UTF-8 JSON text
inline constexpr uint32_t kStrs = fourcc('S', 'T', 'R', 'S');  // string pool (light names)
inline constexpr uint32_t kLght = fourcc('L', 'G', 'H', 'T');  // light records
inline constexpr uint32_t kView = fourcc('V', 'I', 'E', 'W');  // view records
inline constexpr uint32_t kNode = fourcc('N', 'O', 'D', 'E');  // 2.x: one view's node units (u16; 1.x: u32 words);
                                                                // 3.x: the pool's node bytes, every level
inline constexpr uint32_t kLeaf = fourcc('L', 'E', 'A', 'F');  // one view's leaf masks (3.x: the pool's), u64
inline constexpr uint32_t kPool = fourcc('P', 'O', 'O', 'L');  // 3.x: one record per pool level
inline constexpr uint32_t kHott = fourcc('H', 'O', 'T', 'T');  // 3.x: the levels' hot tables, u32 entries

// The records end where their last field ends (cpvs_layout.h): a field added without its size fails here.
static_assert(LightRecordLayout::kDirection + 3 * 8 == kLightRecordSize);
static_assert(ViewRecordLayout::kNodesPerLevel + kMaxLevels * 8 == kViewRecordSize);
static_assert(ViewRecordLayout::kNodesPerLevel == kPooledViewRecordSize);
static_assert(PoolLevelLayout::kHotCount + 4 == kPoolLevelRecordSize);
static_assert(HeaderLayout::kChecksum + 8 == kHeaderSize);
static_assert(SectionEntryLayout::kChecksum + 8 == kSectionEntrySize);
}  // namespace cpvsformat

}  // namespace cpvs
