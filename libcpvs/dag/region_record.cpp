#include "libcpvs/dag/region_record.h"

#include <algorithm>

#include <xxhash.h>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

// The record's coding. An event starts with a 16-bit little-endian word: 0xffff for a leaf (no node header has
// a code 3), followed by its mask (8 bytes, little-endian); else a node's build-form header, followed by its level
// (an unsigned LEB128 number) only when it has no reference child (otherwise the level is its children's minus
// one), then per reference child how many events back it is (LEB128: children are mostly the events just before
// their parent, so one byte). Then the column count, per column its code and (for a reference) how many events
// back from the end, and the counts, all LEB128.
constexpr uint32_t kLeafMark = 0xffff;

void putWord16(std::string& out, uint32_t value) {
  out.push_back(char(uint8_t(value)));
  out.push_back(char(uint8_t(value >> 8)));
}

bool hasReference(uint32_t header) { return (header & 0xAAAAu) != 0; }

void putNumber(std::string& out, uint64_t value) {
  while (value >= 0x80) {
    out.push_back(char(uint8_t(value) | 0x80));
    value >>= 7;
  }
  out.push_back(char(value));
}

class Reader {
public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}
  uint64_t number(const char* what) {
    uint64_t value = 0;
    for (unsigned shift = 0; shift < 64; shift += 7) {
      if (at_ == bytes_.size()) fail(std::string("ends inside ") + what);
      const uint8_t byte = uint8_t(bytes_[at_++]);
      value |= uint64_t(byte & 0x7f) << shift;
      if (!(byte & 0x80)) return value;
    }
    fail(std::string("has a number longer than 64 bits in ") + what);
  }
  uint32_t word16() {
    if (bytes_.size() - at_ < 2) fail("ends inside an event");
    const uint32_t value = uint32_t(uint8_t(bytes_[at_])) | uint32_t(uint8_t(bytes_[at_ + 1])) << 8;
    at_ += 2;
    return value;
  }
  uint64_t word64() {
    if (bytes_.size() - at_ < 8) fail("ends inside a leaf mask");
    uint64_t value = 0;
    for (unsigned b = 0; b < 8; ++b) value |= uint64_t(uint8_t(bytes_[at_ + b])) << (8 * b);
    at_ += 8;
    return value;
  }
  bool done() const { return at_ == bytes_.size(); }
  [[noreturn]] static void fail(const std::string& why) {
    throw Error(ErrorCategory::InvalidInput, "region record " + why);
  }

private:
  std::string_view bytes_;
  size_t at_ = 0;
};

// Whether the builder could have interned a node with this header: codes Lit, Shadowed or Ref, and not eight
// equal non-reference children (the builder answers those with the code itself).
bool internableHeader(uint64_t header) {
  if (header > 0xffff) return false;
  bool same = true;
  for (unsigned c = 0; c < 8; ++c) {
    const uint32_t code = wordCodeOf(uint32_t(header), c);
    if (code > uint32_t(ChildCode::Ref)) return false;
    same = same && code == wordCodeOf(uint32_t(header), 0);
  }
  return !same || wordCodeOf(uint32_t(header), 0) == uint32_t(ChildCode::Ref);
}

}  // namespace

void RegionRecorder::begin() {
  bytes_.clear();
  levelOf_.clear();
  headerOf_.clear();
  valueOf_.clear();
  firstChild_.clear();
  childEvents_.clear();
  columns_.clear();
  leafIndex_.clear();
  nodeIndex_.clear();
  leaves_ = nodes_ = 0;
}

uint32_t RegionRecorder::leaf(uint64_t mask) {
  const uint32_t id = uint32_t(levelOf_.size());
  const uint64_t hash = XXH3_64bits(&mask, sizeof mask);
  if (leafIndex_.full(leaves_, id))
    leafIndex_.rebuild(leaves_, id, [&](auto&& add) {
      for (uint32_t e = 0; e < id; ++e)
        if (levelOf_[e] == leafLevel_ + 1) add(e, XXH3_64bits(&valueOf_[e], sizeof(uint64_t)));
    });
  const uint32_t found = leafIndex_.findOrInsert(hash, id, [&](uint32_t e) { return valueOf_[e] == mask; });
  if (found != id) return found;  // asked before: the call changed nothing
  ++leaves_;
  putWord16(bytes_, kLeafMark);
  for (unsigned b = 0; b < 8; ++b) bytes_.push_back(char(uint8_t(mask >> (8 * b))));
  levelOf_.push_back(leafLevel_ + 1);
  headerOf_.push_back(0);
  valueOf_.push_back(mask);
  firstChild_.push_back(uint32_t(childEvents_.size()));
  return id;
}

uint32_t RegionRecorder::node(uint32_t level, uint32_t header, const uint32_t* childEvents, unsigned childCount) {
  uint32_t content[10] = {level, header};
  std::copy(childEvents, childEvents + childCount, content + 2);
  const uint64_t hash = XXH3_64bits(content, (2 + childCount) * sizeof(uint32_t));
  const uint32_t id = uint32_t(levelOf_.size());
  if (nodeIndex_.full(nodes_, id))
    nodeIndex_.rebuild(nodes_, id, [&](auto&& add) {
      for (uint32_t e = 0; e < id; ++e)
        if (levelOf_[e] <= leafLevel_) add(e, valueOf_[e]);
    });
  // The header says how many children there are.
  const uint32_t found = nodeIndex_.findOrInsert(hash, id, [&](uint32_t e) {
    return valueOf_[e] == hash && levelOf_[e] == level && headerOf_[e] == header &&
           std::equal(childEvents, childEvents + childCount, childEvents_.begin() + firstChild_[e]);
  });
  if (found != id) return found;
  ++nodes_;
  putWord16(bytes_, header);
  if (!hasReference(header)) putNumber(bytes_, level);
  for (unsigned k = 0; k < childCount; ++k) putNumber(bytes_, id - childEvents[k]);
  levelOf_.push_back(level);
  headerOf_.push_back(header);
  valueOf_.push_back(hash);
  firstChild_.push_back(uint32_t(childEvents_.size()));
  childEvents_.insert(childEvents_.end(), childEvents, childEvents + childCount);
  return id;
}

void RegionRecorder::column(ChildCode code, uint32_t event) {
  columns_.push_back({code, code == ChildCode::Ref ? event : 0});
}

std::string RegionRecorder::finish(const RegionCounts& counts) {
  const uint32_t events = uint32_t(levelOf_.size());
  std::string record;
  putNumber(record, events);
  record += bytes_;
  putNumber(record, columns_.size());
  for (const auto& [code, id] : columns_) {
    putNumber(record, uint32_t(code));
    if (code == ChildCode::Ref) putNumber(record, events - id);
  }
  putNumber(record, counts.nodesBuilt);
  putNumber(record, counts.nodesReused);
  putNumber(record, counts.homogeneous);
  return record;
}

namespace {

// Reads a record event by event, checking each, and hands them to `visitor`; returns the counts.
RegionCounts walk(std::string_view record, uint32_t regionLevel, uint32_t leafLevel, uint32_t columnCount,
                  std::vector<uint8_t>& levels, RegionEventVisitor& visitor) {
  Reader in(record);
  const uint64_t eventCount = in.number("the event count");
  if (eventCount > record.size()) Reader::fail("counts more events than it has bytes");
  levels.resize(eventCount);
  uint32_t children[8];
  for (uint32_t id = 0; id < eventCount; ++id) {
    const uint32_t header = in.word16();
    if (header == kLeafMark) {
      levels[id] = uint8_t(leafLevel + 1);
      visitor.leaf(id, in.word64());
      continue;
    }
    if (!internableHeader(header)) Reader::fail("has a node header the builder does not make");
    uint32_t level = 0;
    if (!hasReference(header)) {
      const uint64_t given = in.number("a node's level");
      if (given < regionLevel || given > leafLevel) Reader::fail("has a node of level " + std::to_string(given));
      level = uint32_t(given);
    }
    unsigned count = 0;
    for (unsigned c = 0; c < 8; ++c) {
      if (wordCodeOf(header, c) != uint32_t(ChildCode::Ref)) continue;
      const uint64_t back = in.number("a child reference");
      if (back == 0 || back > id) Reader::fail("has a child reference outside the region");
      const uint32_t child = uint32_t(id - back);
      const uint32_t childLevel = levels[child];
      if (count == 0) {  // the first child says the level
        if (childLevel <= regionLevel || childLevel > leafLevel + 1) Reader::fail("has a child of the wrong level");
        level = childLevel - 1;
      } else if (childLevel != level + 1) {
        Reader::fail("has a child of the wrong level");
      }
      children[count++] = child;
    }
    levels[id] = uint8_t(level);
    visitor.node(id, level, header, children, count);
  }
  if (in.number("the column count") != columnCount) Reader::fail("has a column count other than the view's");
  for (uint32_t z = 0; z < columnCount; ++z) {
    const uint64_t code = in.number("a column");
    if (code > uint64_t(ChildCode::Ref)) Reader::fail("has a column code of " + std::to_string(code));
    uint32_t event = 0;
    if (ChildCode(code) == ChildCode::Ref) {
      const uint64_t back = in.number("a column reference");
      if (back == 0 || back > eventCount) Reader::fail("has a column reference outside the region");
      event = uint32_t(eventCount - back);
      if (levels[event] != regionLevel) Reader::fail("has a column of the wrong level");
    }
    visitor.column(z, ChildCode(code), event);
  }
  RegionCounts counts;
  counts.nodesBuilt = in.number("the counts");
  counts.nodesReused = in.number("the counts");
  counts.homogeneous = in.number("the counts");
  if (!in.done()) Reader::fail("has bytes after its end");
  return counts;
}

struct NoVisitor final : RegionEventVisitor {
  void leaf(uint32_t, uint64_t) override {}
  void node(uint32_t, uint32_t, uint32_t, const uint32_t*, unsigned) override {}
  void column(uint32_t, ChildCode, uint32_t) override {}
};

}  // namespace

RegionEvents decodeRegionRecord(std::string_view record, uint32_t regionLevel, uint32_t leafLevel,
                                uint32_t columnCount, std::vector<uint8_t>& levels) {
  NoVisitor none;
  const RegionCounts counts = walk(record, regionLevel, leafLevel, columnCount, levels, none);
  return {record, regionLevel, leafLevel, columnCount, uint32_t(levels.size()), counts};
}

void walkRegionEvents(const RegionEvents& events, std::vector<uint8_t>& levels, RegionEventVisitor& visitor) {
  walk(events.record, events.regionLevel, events.leafLevel, events.columnCount, levels, visitor);
}

}  // namespace cpvs
