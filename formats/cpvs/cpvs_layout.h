#pragma once
// Where each field of the .cpvs container lies: byte offsets inside the header, a section-table entry, a light
// record and a view record (the tables of formats/cpvs/format.md, by name). The writer stores and the reader
// loads through these names, so the two cannot disagree on a field. Standard library only; nothing of libcpvs.
#include <cstdint>

namespace cpvs::cpvsformat {

// The 64-byte header at offset 0.
struct HeaderLayout {
  static constexpr uint32_t kMagic = 0;           // u8[8]
  static constexpr uint32_t kMajor = 8;           // u16
  static constexpr uint32_t kMinor = 10;          // u16
  static constexpr uint32_t kHeaderSize = 12;     // u32
  static constexpr uint32_t kSectionCount = 16;   // u32
  static constexpr uint32_t kFlags = 20;          // u32
  static constexpr uint32_t kTableOffset = 24;    // u64
  static constexpr uint32_t kFileSize = 32;       // u64
  static constexpr uint32_t kTableChecksum = 40;  // u64
  static constexpr uint32_t kReserved = 48;       // u64
  static constexpr uint32_t kChecksum = 56;       // u64, XXH3-64 of bytes 0 .. kChecksum - 1
};

// One 32-byte entry of the section table.
struct SectionEntryLayout {
  static constexpr uint32_t kType = 0;         // u32, four ASCII characters
  static constexpr uint32_t kElementSize = 4;  // u32
  static constexpr uint32_t kOffset = 8;       // u64
  static constexpr uint32_t kSize = 16;        // u64
  static constexpr uint32_t kChecksum = 24;    // u64
};

// One 112-byte record of LGHT.
struct LightRecordLayout {
  static constexpr uint32_t kType = 0;            // u32: 0 directional, 1 spot, 2 point
  static constexpr uint32_t kNameOffset = 4;      // u32, in STRS
  static constexpr uint32_t kNameLength = 8;      // u32
  static constexpr uint32_t kFirstView = 12;      // u32, index in VIEW
  static constexpr uint32_t kViewCount = 16;      // u32
  static constexpr uint32_t kColor = 20;          // f32[3]
  static constexpr uint32_t kIntensity = 32;      // f32
  static constexpr uint32_t kReserved = 36;       // u32
  static constexpr uint32_t kRange = 40;          // f64
  static constexpr uint32_t kInnerCone = 48;      // f64
  static constexpr uint32_t kOuterCone = 56;      // f64
  static constexpr uint32_t kPosition = 64;       // f64[3]
  static constexpr uint32_t kDirection = 88;      // f64[3]
};

// One record of VIEW: 472 bytes in 1.0 and 2.0; 216 in 3.0, which ends before kNodesPerLevel, has no sections of
// its own (kNodeSection, kLeafSection and kLeafCount are reserved, zero) and holds kPoolRoot where 2.0 holds
// kNodeUnits.
struct ViewRecordLayout {
  static constexpr uint32_t kProjection = 0;      // u8
  static constexpr uint32_t kDepthMapping = 1;    // u8
  static constexpr uint32_t kFace = 2;            // i8
  static constexpr uint32_t kFlags = 3;           // u8
  static constexpr uint32_t kResolution = 4;      // u32
  static constexpr uint32_t kRootCode = 8;        // u8
  static constexpr uint32_t kLevels = 9;          // u8
  static constexpr uint32_t kReserved = 10;       // u16
  static constexpr uint32_t kLight = 12;          // u32
  static constexpr uint32_t kNodeSection = 16;    // u32, index in the section table
  static constexpr uint32_t kLeafSection = 20;    // u32
  static constexpr uint32_t kNodeUnits = 24;      // u64 (1.x: words)
  static constexpr uint32_t kLeafCount = 32;      // u64
  static constexpr uint32_t kViewFromWorld = 40;  // f64[16], column-major
  static constexpr uint32_t kXMin = 168;          // f64
  static constexpr uint32_t kXMax = 176;
  static constexpr uint32_t kYMin = 184;
  static constexpr uint32_t kYMax = 192;
  static constexpr uint32_t kNear = 200;
  static constexpr uint32_t kFar = 208;
  static constexpr uint32_t kNodesPerLevel = 216;  // u64[32], root level first (1.0, 2.0)
  static constexpr uint32_t kPoolRoot = 24;        // u64 (3.0): the root node's byte offset in its pool level
};

// One 40-byte record of POOL (3.0): a level of the pool, the nodes of one edge.
struct PoolLevelLayout {
  static constexpr uint32_t kEdge = 0;        // u32: 8, 16, 32, ... (records ascending, none missing)
  static constexpr uint32_t kShortBytes = 4;  // u8: 1..4, the width of a child code 2 reference
  static constexpr uint32_t kLongBytes = 5;   // u8: short..4, the width of a child code 3 reference
  static constexpr uint32_t kReserved = 6;    // u16
  static constexpr uint32_t kOffset = 8;      // u64: the level's first byte in NODE
  static constexpr uint32_t kSize = 16;       // u64: its bytes
  static constexpr uint32_t kNodes = 24;      // u64: its nodes
  static constexpr uint32_t kFirstHot = 32;   // u32: its hot table's first entry in HOTT
  static constexpr uint32_t kHotCount = 36;   // u32: its entries (0: no table, short references are offsets)
};

}  // namespace cpvs::cpvsformat
