// Reads and validates the .cpvs container, versions 1.x to 3.x (formats/cpvs/format.md). The input is untrusted: every count
// is checked against the file size before it sizes anything, every offset before it is followed, and every
// DAG is validated level by level so that traversal stays in bounds and terminates. Linear in the file size.
#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <initializer_list>

#include <xxhash.h>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/file_pool.h"

static_assert(std::endian::native == std::endian::little, "cpvs: the .cpvs format is little-endian; "
                                                          "big-endian hosts are not supported");

namespace cpvs {

using namespace cpvsformat;
using H = HeaderLayout;
using E = SectionEntryLayout;
using L = LightRecordLayout;
using V = ViewRecordLayout;

namespace {

// What every check below throws; the public entry points catch it and return it as an Outcome, so nothing
// is thrown across the runtime's API.
struct ReadFailure {
  std::string message;
};

std::string typeName(uint32_t type) {
  std::string s(4, ' ');
  for (int i = 0; i < 4; ++i) s[i] = char(uint8_t(type >> (8 * i)));
  return s;
}

bool printable(uint32_t type) {
  for (int i = 0; i < 4; ++i) {
    const uint8_t c = uint8_t(type >> (8 * i));
    if (c < 0x20 || c > 0x7E) return false;
  }
  return true;
}

std::string readableMajors() {
  std::string text;
  for (uint32_t m = kCpvsOldestReadableMajor; m <= kCpvsNewestMajor; ++m)
    text += (text.empty() ? "" : m == kCpvsNewestMajor ? " and " : ", ") + std::to_string(m) + ".x";
  return text;
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

class Reader {
public:
  Reader(const uint8_t* data, uint64_t size, const std::string& name) : d_(data), size_(size), name_(name) {}

  [[noreturn]] void fail(const std::string& what) const { throw ReadFailure{name_ + ": " + what}; }

  // Loads at absolute offsets the caller has already bounds-checked.
  uint8_t u8(uint64_t at) const { return d_[at]; }
  uint16_t u16(uint64_t at) const { return uint16_t(load(at, 2)); }
  uint32_t u32(uint64_t at) const { return uint32_t(load(at, 4)); }
  uint64_t u64(uint64_t at) const { return load(at, 8); }
  float f32(uint64_t at) const { return std::bit_cast<float>(u32(at)); }
  double f64(uint64_t at) const { return std::bit_cast<double>(u64(at)); }

  const uint8_t* data() const { return d_; }
  uint64_t size() const { return size_; }
  const std::string& name() const { return name_; }

private:
  uint64_t load(uint64_t at, int n) const {
    uint64_t v = 0;
    std::memcpy(&v, d_ + at, size_t(n));  // little-endian host (static_assert above)
    return v;
  }
  const uint8_t* d_;
  uint64_t size_;
  const std::string& name_;
};

struct Entry {
  uint32_t type = 0, elementSize = 0;
  uint64_t offset = 0, size = 0;
};

void checkMagic(const Reader& r) {
  const uint8_t* d = r.data();
  const uint64_t size = r.size();
  if (size == 0) r.fail("empty file — not a .cpvs file");
  const size_t n = size_t(std::min<uint64_t>(size, 8));
  if (std::memcmp(d, kCpvsMagic, n) == 0) {
    if (n == 8) return;
    r.fail("truncated: " + std::to_string(size) + " bytes (a .cpvs header alone is " + std::to_string(kHeaderSize) +
           ")");
  }
  // The name is there but the bytes around it are not: the signature of a text-mode (ASCII) transfer.
  bool hasName = false;
  for (size_t p = 0; p + 4 <= n; ++p) hasName = hasName || std::memcmp(d + p, "CPVS", 4) == 0;
  if (hasName) {
    std::string how = "line endings translated or high bit stripped";
    if (n >= 7 && d[0] == 0x89 && d[5] == '\n' && d[6] == 0x1A) how = "CR LF became LF";
    else if (n >= 8 && d[0] == 0x89 && d[5] == '\r' && d[6] == '\r' && d[7] == '\n') how = "LF became CR LF";
    else if (d[0] == 0x09) how = "the high bit of byte 0 was stripped";
    else if (d[0] != 0x89) how = "byte 0 was re-encoded as text";
    r.fail("the file was damaged by a text-mode transfer (" + how +
           ") — copy or download it again in binary mode, or re-bake");
  }
  r.fail("not a .cpvs file (it does not start with the .cpvs magic bytes 89 43 50 56 53 0D 0A 1A)");
}

// Structural validation of one view's DAG (shadow_dag.h), in the stored form of format 2 (Unit = uint16_t:
// references relative to the next level, either width) or the build form of format 1 (Unit = uint32_t: codes
// 0..2 in the header's 16 low bits, absolute word references). Level by level from the root: every node fits,
// every reference points to the start of a node of the next level (or, from the leaf-parent level, to a leaf),
// and the per-level node counts tile the node units exactly. Returns the unit where each level starts.
template <class Unit>
std::vector<uint64_t> validateDag(const Reader& r, const std::string& what, ChildCode rootCode, uint32_t levels,
                                  std::span<const Unit> nodes, uint64_t leafCount,
                                  std::span<const uint64_t> nodesPerLevel) {
  constexpr bool buildForm = sizeof(Unit) == 4;
  const std::string unit = buildForm ? "word" : "unit";
  const auto unitCount = [](uint32_t header) { return buildForm ? nodeWordCount(header) : nodeUnitCount(header); };
  const uint64_t units = nodes.size();
  std::vector<uint64_t> levelStart(levels + 1, 0);
  std::vector<uint64_t> isStart((units + 63) / 64, 0);  // bitmap of node starts (units <= file size / 2)
  uint64_t offset = 0;
  for (uint32_t l = 0; l < levels; ++l) {
    levelStart[l] = offset;
    const uint64_t count = nodesPerLevel[l];
    if (count > units - offset)
      r.fail(what + ": DAG level " + std::to_string(l) + " claims " + std::to_string(count) + " nodes but only " +
             std::to_string(units - offset) + " node " + unit + "s are left");
    for (uint64_t i = 0; i < count; ++i) {
      if (offset >= units)
        r.fail(what + ": DAG level " + std::to_string(l) + " node " + std::to_string(i) + " starts past the " +
               std::to_string(units) + " node " + unit + "s");
      const uint32_t header = nodes[offset];
      if (buildForm && ((header >> 16) != 0 || (header & (header >> 1) & 0x5555u) != 0))
        r.fail(what + ": DAG level " + std::to_string(l) + " node at word " + std::to_string(offset) +
               ": invalid header 0x" + hex64(header).substr(8) + " (child codes must be 0..2, high bits zero)");
      const unsigned k = unitCount(header);
      if (k > units - offset)
        r.fail(what + ": DAG level " + std::to_string(l) + " node at " + unit + " " + std::to_string(offset) +
               " runs past the end of the node " + unit + "s");
      isStart[offset >> 6] |= uint64_t(1) << (offset & 63);
      offset += k;
    }
  }
  levelStart[levels] = offset;
  if (offset != units)
    r.fail(what + ": the DAG's per-level node counts cover " + std::to_string(offset) + " of its " +
           std::to_string(units) + " node " + unit + "s");
  const uint64_t rootLevelNodes = levels > 0 ? nodesPerLevel[0] : 0;
  if (rootCode == ChildCode::Ref ? rootLevelNodes != 1 : rootLevelNodes != 0)
    r.fail(what + ": the root level holds " + std::to_string(rootLevelNodes) + " nodes (expected " +
           (rootCode == ChildCode::Ref ? "1, the root" : "0: the root code is not a reference") + ")");

  for (uint32_t l = 0; l < levels; ++l) {
    const bool leafParent = l + 1 == levels;
    const uint64_t lo = leafParent ? 0 : levelStart[l + 1], hi = leafParent ? 0 : levelStart[l + 1 + 1];
    for (uint64_t at = levelStart[l]; at < levelStart[l + 1];) {
      const uint32_t header = nodes[at];
      uint64_t next = at + 1;  // the next reference's first unit, in child order
      for (unsigned c = 0; c < 8; ++c) {
        const uint32_t code = (header >> (2 * c)) & 3u;
        if (code < 2) continue;
        uint64_t ref = nodes[next++];
        if constexpr (!buildForm) {
          if (code == 3) ref |= uint64_t(nodes[next++]) << 16;
          ref += lo;  // relative to the next level
        }
        if (leafParent) {
          if (ref >= leafCount)
            r.fail(what + ": DAG leaf-parent node at " + unit + " " + std::to_string(at) + " references leaf " +
                   std::to_string(ref) + " of " + std::to_string(leafCount));
        } else if (ref < lo || ref >= hi || !((isStart[ref >> 6] >> (ref & 63)) & 1))
          r.fail(what + ": DAG level " + std::to_string(l) + " node at " + unit + " " + std::to_string(at) +
                 " references " + unit + " " + std::to_string(ref) + ", which is not the start of a level-" +
                 std::to_string(l + 1) + " node");
      }
      at += unitCount(header);
    }
  }
  return levelStart;
}

// A format-1 DAG (validated) in the stored form of format 2: references made relative to their level, then
// encoded as the baker does.
Result<ShadowDag> convertFormat1Dag(uint32_t resolution, ChildCode rootCode, std::span<const uint32_t> words,
                                             std::span<const uint64_t> levelStart, std::span<const uint64_t> leaves,
                                             std::span<const uint64_t> nodesPerLevel) {
  const size_t levels = nodesPerLevel.size();
  std::vector<std::vector<uint32_t>> local(levels);
  for (size_t l = 0; l < levels; ++l) {
    const uint64_t base = l + 1 < levels ? levelStart[l + 1] : 0;
    local[l].assign(words.begin() + levelStart[l], words.begin() + levelStart[l + 1]);
    for (size_t i = 0; i < local[l].size();) {
      const unsigned count = nodeWordCount(local[l][i]);
      for (unsigned k = 1; k < count; ++k) local[l][i + k] -= uint32_t(base);
      i += count;
    }
  }
  const std::vector<std::span<const uint32_t>> spans(local.begin(), local.end());
  return encodeDag(resolution, rootCode, spans, nodesPerLevel, std::vector<uint64_t>(leaves.begin(), leaves.end()));
}

}  // namespace

CpvsFile::~CpvsFile() = default;

namespace {

template <class Fn>
Result<std::unique_ptr<CpvsFile>> catchReadFailure(Fn&& open) {
  try {
    return open();
  } catch (const ReadFailure& f) {
    return Outcome(ErrorCategory::InvalidInput, f.message);
  } catch (const std::bad_alloc&) {
    return Outcome(ErrorCategory::RuntimeFailure, "out of memory while reading a .cpvs file");
  }
}

}  // namespace

Outcome validateStoredDag(const std::string& what, uint32_t resolution, ChildCode rootCode,
                          std::span<const uint16_t> nodes, uint64_t leafCount, std::span<const uint64_t> nodesPerLevel) {
  if (resolution < 8 || resolution > kMaxResolution || !std::has_single_bit(resolution))
    return Outcome(ErrorCategory::InvalidInput, what + ": resolution " + std::to_string(resolution));
  const uint32_t levels = uint32_t(std::countr_zero(resolution)) - 2;
  if (nodesPerLevel.size() > levels)
    return Outcome(ErrorCategory::InvalidInput, what + ": node counts for " + std::to_string(nodesPerLevel.size()) +
                                                    " levels, the DAG has " + std::to_string(levels));
  std::vector<uint64_t> counts(nodesPerLevel.begin(), nodesPerLevel.end());
  counts.resize(levels, 0);
  try {
    const std::string name = "DAG";
    validateDag(Reader(nullptr, 0, name), what, rootCode, levels, nodes, leafCount, counts);
  } catch (const ReadFailure& f) {
    return Outcome(ErrorCategory::InvalidInput, f.message);
  } catch (const std::bad_alloc&) {
    return Outcome(ErrorCategory::RuntimeFailure, "out of memory while validating a DAG");
  }
  return Outcome();
}

Result<std::unique_ptr<CpvsFile>> CpvsFile::open(const std::string& path) {
  return catchReadFailure([&] { return openOrThrow(path); });
}

Result<std::unique_ptr<CpvsFile>> CpvsFile::fromBytes(std::span<const uint8_t> bytes, const std::string& name) {
  return catchReadFailure([&] { return fromBytesOrThrow(bytes, name); });
}

Result<std::unique_ptr<CpvsFile>> CpvsFile::fromBorrowedBytes(std::span<const uint8_t> bytes, const std::string& name) {
  return catchReadFailure([&] { return fromBorrowedBytesOrThrow(bytes, name); });
}

std::unique_ptr<CpvsFile> CpvsFile::openOrThrow(const std::string& path) {
  std::unique_ptr<CpvsFile> file(new CpvsFile());
  std::string error;
  if (!file->mapped_.open(path, error)) throw ReadFailure{path + ": " + error};
  file->data_ = file->mapped_.data();
  file->size_ = file->mapped_.size();
  file->parse(path);
  return file;
}

std::unique_ptr<CpvsFile> CpvsFile::fromBytesOrThrow(std::span<const uint8_t> bytes, const std::string& name) {
  std::unique_ptr<CpvsFile> file(new CpvsFile());
  file->owned_.resize((bytes.size() + 7) / 8);
  if (!bytes.empty()) std::memcpy(file->owned_.data(), bytes.data(), bytes.size());
  file->data_ = reinterpret_cast<const uint8_t*>(file->owned_.data());
  file->size_ = bytes.size();
  file->parse(name);
  return file;
}

std::unique_ptr<CpvsFile> CpvsFile::fromBorrowedBytesOrThrow(std::span<const uint8_t> bytes, const std::string& name) {
  if (reinterpret_cast<uintptr_t>(bytes.data()) % 8 != 0)
    throw ReadFailure{name + ": bytes are not 8-byte aligned (use fromBytes)"};
  std::unique_ptr<CpvsFile> file(new CpvsFile());
  file->data_ = bytes.data();
  file->size_ = bytes.size();
  file->parse(name);
  return file;
}

namespace {

// What the header and the section table say, as CpvsFile::parse's steps find it.
struct FileLayout {
  uint16_t major = 0, minor = 0;
  bool strict = true;    // x.0: reserved fields are zero (later minors may give them meaning)
  bool format1 = false;  // 32-bit node words, converted on open
  bool pooled = false;   // 3.x: one node pool per file (converted once on open, shared by the views)
  std::string dotZero;   // "major.0", for messages
  uint64_t tableOffset = 0, tableSize = 0;
  std::vector<Entry> entries;
  int64_t bake = -1, strs = -1, lght = -1, view = -1;  // the singleton sections' indices
  int64_t pool = -1, hott = -1, node = -1, leaf = -1;  // 3.x: the pool's, also singletons
};

// Step 1: the header (magic, version before anything whose layout a later major version may change, checksum,
// sizes).
FileLayout readHeader(const Reader& r) {
  const uint64_t size = r.size();
  checkMagic(r);
  if (size < kHeaderSize)
    r.fail("truncated: " + std::to_string(size) + " bytes (a .cpvs header alone is " + std::to_string(kHeaderSize) +
           ")");
  FileLayout f;
  f.major = r.u16(H::kMajor);
  f.minor = r.u16(H::kMinor);
  const bool headerOk = XXH3_64bits(r.data(), H::kChecksum) == r.u64(H::kChecksum);
  if (f.major < kCpvsOldestReadableMajor || f.major > kCpvsNewestMajor)
    r.fail("written by format version " + std::to_string(f.major) + "." + std::to_string(f.minor) +
           "; this build reads " + readableMajors() + " — update cpvs or re-bake" +
           (headerOk ? "" : " (or the header is corrupt: its checksum does not match)"));
  if (!headerOk) r.fail("header checksum mismatch — the file is corrupt");
  f.strict = f.minor == 0;
  f.format1 = f.major == 1;
  f.pooled = f.major >= 3;
  f.dotZero = std::to_string(f.major) + ".0";
  const bool strict = f.strict;
  const std::string& dotZero = f.dotZero;
  if (r.u32(H::kHeaderSize) != kHeaderSize)
    r.fail("header size " + std::to_string(r.u32(H::kHeaderSize)) + " (expected " + std::to_string(kHeaderSize) + ")");
  if (strict && (r.u32(H::kFlags) != 0 || r.u64(H::kReserved) != 0))
    r.fail("reserved header fields are not zero in a " + dotZero + " file");
  const uint64_t declared = r.u64(H::kFileSize);
  if (declared > size)
    r.fail("truncated: the header says " + std::to_string(declared) + " bytes, the file has " + std::to_string(size));
  if (declared < size)
    r.fail(std::to_string(size - declared) + " bytes of trailing data after the " + std::to_string(declared) +
           " bytes the header gives");
  return f;
}

// Step 2: the section table, each section's place and checksum (into `sections` as cpvs-info lists them).
void readSectionTable(const Reader& r, FileLayout& f, std::vector<CpvsFile::SectionInfo>& sections) {
  const uint64_t size = r.size();
  const uint64_t count = r.u32(H::kSectionCount);
  const uint64_t tableOffset = r.u64(H::kTableOffset);
  f.tableOffset = tableOffset;
  if (count == 0) r.fail("the section table is empty");
  if (tableOffset % kAlignment != 0 || tableOffset < kHeaderSize || tableOffset > size ||
      count > (size - tableOffset) / kSectionEntrySize)
    r.fail("section table (" + std::to_string(count) + " entries at offset " + std::to_string(tableOffset) +
           ") does not lie inside the file after the header, 64-byte aligned");
  const uint64_t tableSize = count * kSectionEntrySize;
  f.tableSize = tableSize;
  if (XXH3_64bits(r.data() + tableOffset, tableSize) != r.u64(H::kTableChecksum))
    r.fail("section table checksum mismatch — the file is corrupt");

  std::vector<Entry>& entries = f.entries;
  entries.assign(count, Entry{});
  sections.clear();
  sections.reserve(count);
  for (uint64_t i = 0; i < count; ++i) {
    const uint64_t e = tableOffset + i * kSectionEntrySize;
    Entry& s = entries[i];
    s.type = r.u32(e + E::kType);
    s.elementSize = r.u32(e + E::kElementSize);
    s.offset = r.u64(e + E::kOffset);
    s.size = r.u64(e + E::kSize);
    const std::string label = "section " + std::to_string(i) + " '" + (printable(s.type) ? typeName(s.type) : "?") + "'";
    if (!printable(s.type)) r.fail(label + ": type is not four printable characters");
    if (s.offset % kAlignment != 0) r.fail(label + ": offset " + std::to_string(s.offset) + " is not 64-byte aligned");
    if (s.offset > size || s.size > size - s.offset)
      r.fail(label + ": " + std::to_string(s.size) + " bytes at offset " + std::to_string(s.offset) +
             " run past the end of the file (" + std::to_string(size) + " bytes)");
    const uint64_t checksum = XXH3_64bits(r.data() + s.offset, size_t(s.size));
    if (checksum != r.u64(e + E::kChecksum)) r.fail(label + " checksum mismatch — the file is corrupt");
    sections.push_back({typeName(s.type), s.elementSize, s.offset, s.size, checksum, true});
  }
}

// Step 3: header, table and sections do not overlap; every byte between them is zero padding.
void checkPadding(const Reader& r, const FileLayout& f) {
  const uint64_t size = r.size();
  std::vector<std::pair<uint64_t, uint64_t>> ranges;  // [begin, end)
  ranges.reserve(f.entries.size() + 2);
  ranges.push_back({0, kHeaderSize});
  ranges.push_back({f.tableOffset, f.tableOffset + f.tableSize});
  for (const Entry& s : f.entries)
    if (s.size > 0) ranges.push_back({s.offset, s.offset + s.size});
  std::sort(ranges.begin(), ranges.end());
  uint64_t end = 0;
  for (const auto& [b, e] : ranges) {
    if (b < end) r.fail("sections overlap at offset " + std::to_string(b));
    for (uint64_t p = end; p < b; ++p)
      if (r.data()[p] != 0) r.fail("padding byte at offset " + std::to_string(p) + " is not zero — the file is corrupt");
    end = e;
  }
  for (uint64_t p = end; p < size; ++p)
    if (r.data()[p] != 0) r.fail("padding byte at offset " + std::to_string(p) + " is not zero — the file is corrupt");
}

// Step 4: the four singleton sections and every section's element size (NODE and LEAF are found through the
// view records; types from a later minor version are skipped).
void findSections(const Reader& r, FileLayout& f) {
  const bool strict = f.strict, format1 = f.format1, pooled = f.pooled;
  int64_t &bake = f.bake, &strs = f.strs, &lght = f.lght, &view = f.view;
  const uint64_t count = f.entries.size();
  for (uint64_t i = 0; i < count; ++i) {
    const Entry& s = f.entries[i];
    const std::string label = "section " + std::to_string(i) + " '" + typeName(s.type) + "'";
    auto expectElement = [&](uint32_t expected, bool extensible) {
      const bool ok = extensible && !strict ? s.elementSize >= expected : s.elementSize == expected;
      if (!ok)
        r.fail(label + ": element size " + std::to_string(s.elementSize) + " (expected " + std::to_string(expected) +
               (extensible && !strict ? " or more" : "") + ")");
      if (s.size % s.elementSize != 0)
        r.fail(label + ": size " + std::to_string(s.size) + " is not a multiple of its element size " +
               std::to_string(s.elementSize));
    };
    auto single = [&](int64_t& slot) {
      if (slot >= 0)
        r.fail("two '" + typeName(s.type) + "' sections (" + std::to_string(slot) + " and " + std::to_string(i) + ")");
      slot = int64_t(i);
    };
    switch (s.type) {
      case kBake: single(bake); expectElement(1, false); break;
      case kStrs: single(strs); expectElement(1, false); break;
      case kLght: single(lght); expectElement(kLightRecordSize, true); break;
      case kView: single(view); expectElement(pooled ? kPooledViewRecordSize : kViewRecordSize, true); break;
      case kNode:
        if (pooled) single(f.node);
        expectElement(format1 ? 4 : pooled ? 1 : 2, false);
        break;
      case kLeaf:
        if (pooled) single(f.leaf);
        expectElement(8, false);
        break;
      case kPool:
        if (!pooled) break;  // not a section of 1.x and 2.x: skipped as unknown
        single(f.pool);
        expectElement(kPoolLevelRecordSize, true);
        break;
      case kHott:
        if (!pooled) break;
        single(f.hott);
        expectElement(4, false);
        break;
      default: break;  // a section type from a later minor version: skipped
    }
  }
  for (const auto& [slot, type] : std::initializer_list<std::pair<int64_t, uint32_t>>{
           {bake, kBake}, {strs, kStrs}, {lght, kLght}, {view, kView}})
    if (slot < 0) r.fail("no '" + typeName(type) + "' section");
  if (pooled)
    for (const auto& [slot, type] : std::initializer_list<std::pair<int64_t, uint32_t>>{
             {f.pool, kPool}, {f.hott, kHott}, {f.node, kNode}, {f.leaf, kLeaf}})
      if (slot < 0) r.fail("no '" + typeName(type) + "' section (a " + f.dotZero.substr(0, 1) + ".x file has one)");
}

// A 2.x (or 1.x) view's own NODE and LEAF sections, validated (a format-1 DAG converted into `converted`).
void readViewDag(const Reader& r, const FileLayout& f, const std::string& vwhat, uint64_t w, ChildCode rootCode,
                 CpvsFile::View& out, std::vector<std::unique_ptr<ShadowDag>>& converted) {
  const uint8_t* data = r.data();
  const bool format1 = f.format1;
  const uint64_t count = f.entries.size();
  const std::vector<Entry>& entries = f.entries;
  const LightView& v = out.view;
  const uint32_t levels = uint32_t(std::countr_zero(v.resolution)) - 2;
  const uint64_t nodeSection = r.u32(w + V::kNodeSection), leafSection = r.u32(w + V::kLeafSection);
  if (nodeSection >= count || entries[nodeSection].type != kNode)
    r.fail(vwhat + ": node section index " + std::to_string(nodeSection) + " is not a 'NODE' section");
  if (leafSection >= count || entries[leafSection].type != kLeaf)
    r.fail(vwhat + ": leaf section index " + std::to_string(leafSection) + " is not a 'LEAF' section");
  const Entry& nodeS = entries[nodeSection];
  const Entry& leafS = entries[leafSection];
  const uint64_t words = r.u64(w + V::kNodeUnits), leafCount = r.u64(w + V::kLeafCount);
  const uint64_t nodeElement = format1 ? 4 : 2;
  const std::string unit = format1 ? " node words" : " node units";
  if (words != nodeS.size / nodeElement)
    r.fail(vwhat + ": " + std::to_string(words) + unit + ", but section " + std::to_string(nodeSection) +
           " 'NODE' holds " + std::to_string(nodeS.size / nodeElement));
  if (leafCount != leafS.size / 8)
    r.fail(vwhat + ": " + std::to_string(leafCount) + " leaves, but section " + std::to_string(leafSection) +
           " 'LEAF' holds " + std::to_string(leafS.size / 8));
  if (words > UINT32_MAX || leafCount > (uint64_t(1) << 32))
    r.fail(vwhat + ": DAG too large for 32-bit references");
  out.nodesPerLevel.resize(levels);
  for (uint32_t k = 0; k < kMaxLevels; ++k) {
    const uint64_t c = r.u64(w + V::kNodesPerLevel + 8 * k);
    if (k < levels) out.nodesPerLevel[k] = c;
    else if (c != 0) r.fail(vwhat + ": node count for level " + std::to_string(k) + " beyond the DAG's " +
                            std::to_string(levels) + " levels");
  }
  // 64-byte aligned offsets into a buffer aligned to at least 8 bytes: the spans are properly aligned.
  const std::span<const uint64_t> leaves(reinterpret_cast<const uint64_t*>(data + leafS.offset),
                                         size_t(leafCount));
  out.nodeBytes = nodeS.size;
  if (format1) {
    const std::span<const uint32_t> nodes(reinterpret_cast<const uint32_t*>(data + nodeS.offset), size_t(words));
    const std::vector<uint64_t> levelStart =
        validateDag(r, vwhat, rootCode, levels, nodes, leafCount, out.nodesPerLevel);
    Result<ShadowDag> dag =
        convertFormat1Dag(v.resolution, rootCode, nodes, levelStart, leaves, out.nodesPerLevel);
    if (!dag) r.fail(vwhat + ": cannot convert the format-1 DAG: " + dag.outcome().message());
    converted.push_back(std::make_unique<ShadowDag>(std::move(dag).value()));
    out.dag = converted.back()->view();
  } else {
    const std::span<const uint16_t> nodes(reinterpret_cast<const uint16_t*>(data + nodeS.offset), size_t(words));
    const std::vector<uint64_t> levelStart =
        validateDag(r, vwhat, rootCode, levels, nodes, leafCount, out.nodesPerLevel);
    out.dag = DagView{v.resolution, rootCode, nodes, leaves};
    out.dag.setLevelStarts(levelStart);
  }
  out.bytes = ByteDagView::inPlace(out.dag);
}

// A 3.x view's root: its code and its byte offset in the pool level of its edge, checked with the pool once every
// view is read (checkPool).
void readPoolRoot(const Reader& r, const FileLayout& f, const std::string& vwhat, uint64_t w, ChildCode rootCode,
                  CpvsFile::View& out) {
  if (f.strict && (r.u32(w + V::kNodeSection) != 0 || r.u32(w + V::kLeafSection) != 0 || r.u64(w + V::kLeafCount) != 0))
    r.fail(vwhat + ": reserved field is not zero in a " + f.dotZero + " file");
  const uint64_t root = r.u64(w + V::kPoolRoot);
  if (rootCode != ChildCode::Ref && root != 0) r.fail(vwhat + ": a root offset without a root node");
  out.bytes.resolution = out.view.resolution;
  out.bytes.rootCode = rootCode;
  out.bytes.root = root;
  out.nodesPerLevel.assign(uint32_t(std::countr_zero(out.view.resolution)) - 2, 0);
}

// One view record (record `index`, view vi of light li), its DAG validated (a format-1 DAG converted into
// `converted`, which owns it).
CpvsFile::View readView(const Reader& r, const FileLayout& f, uint64_t li, const std::string& named, uint64_t vi,
                        uint64_t index, std::vector<std::unique_ptr<ShadowDag>>& converted) {
  const bool strict = f.strict;
  const std::string& dotZero = f.dotZero;
  const Entry& viewS = f.entries[f.view];
  const uint64_t w = viewS.offset + index * viewS.elementSize;
  const std::string vwhat = named + " view " + std::to_string(vi) + " (record " + std::to_string(index) + ")";
  CpvsFile::View out;
  LightView& v = out.view;
  const uint8_t projection = r.u8(w + V::kProjection), mapping = r.u8(w + V::kDepthMapping), flags = r.u8(w + V::kFlags);
  const int face = int(int8_t(r.u8(w + V::kFace)));
  if (projection > 1) r.fail(vwhat + ": unknown projection " + std::to_string(projection));
  if (mapping > 1) r.fail(vwhat + ": unknown depth mapping " + std::to_string(mapping));
  if (face < -1 || face > 5) r.fail(vwhat + ": cube face " + std::to_string(face) + " (expected -1..5)");
  if (strict && (flags & ~1u) != 0)
    r.fail(vwhat + ": unknown flags " + std::to_string(flags) + " in a " + dotZero + " file");
  v.projection = Projection(projection);
  v.mapping = DepthMapping(mapping);
  v.face = face;
  v.empty = flags & 1u;
  v.resolution = r.u32(w + V::kResolution);
  if (v.resolution < 8 || v.resolution > kMaxResolution || !std::has_single_bit(v.resolution))
    r.fail(vwhat + ": resolution " + std::to_string(v.resolution) + " (expected a power of two from 8 to " +
           std::to_string(kMaxResolution) + ")");
  const uint32_t levels = uint32_t(std::countr_zero(v.resolution)) - 2;
  const uint8_t rootCode = r.u8(w + V::kRootCode);
  if (rootCode > 2) r.fail(vwhat + ": root code " + std::to_string(rootCode) + " (expected 0..2)");
  if (r.u8(w + V::kLevels) != levels)
    r.fail(vwhat + ": " + std::to_string(r.u8(w + V::kLevels)) + " DAG levels for resolution " +
           std::to_string(v.resolution) + " (expected " + std::to_string(levels) + ")");
  if (strict && r.u16(w + V::kReserved) != 0) r.fail(vwhat + ": reserved field is not zero in a " + dotZero + " file");
  if (r.u32(w + V::kLight) != li)
    r.fail(vwhat + ": belongs to light " + std::to_string(r.u32(w + V::kLight)) + ", not " + std::to_string(li));
  bool finite = true;
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) {
      v.viewFromWorld[c][row] = r.f64(w + V::kViewFromWorld + 8 * (4 * c + row));
      finite = finite && std::isfinite(v.viewFromWorld[c][row]);
    }
  if (!finite) r.fail(vwhat + ": viewFromWorld has a non-finite element");
  v.xMin = r.f64(w + V::kXMin);
  v.xMax = r.f64(w + V::kXMax);
  v.yMin = r.f64(w + V::kYMin);
  v.yMax = r.f64(w + V::kYMax);
  v.near = r.f64(w + V::kNear);
  v.far = r.f64(w + V::kFar);
  for (double x : {v.xMin, v.xMax, v.yMin, v.yMax, v.near, v.far})
    if (!std::isfinite(x)) r.fail(vwhat + ": a lateral or depth bound is not finite");
  if (!(v.xMin < v.xMax) || !(v.yMin < v.yMax))
    r.fail(vwhat + ": empty lateral extent x [" + num(v.xMin) + ", " + num(v.xMax) + "] y [" + num(v.yMin) + ", " +
           num(v.yMax) + "]");
  if (!(v.near < v.far)) r.fail(vwhat + ": near " + num(v.near) + " is not before far " + num(v.far));
  if (v.mapping == DepthMapping::Logarithmic && !(v.near > 0))
    r.fail(vwhat + ": logarithmic depth needs near > 0 (near is " + num(v.near) + ")");
  // Finite is not enough: the mapping divides by the extents and takes log(far / near), and a bound of 1e308
  // gives an infinite width. Every value must lie within what a bake of a real scene can write.
  for (double x : {v.xMin, v.xMax, v.yMin, v.yMax, v.near, v.far})
    if (!(std::abs(x) <= kMaxViewCoordinate))
      r.fail(vwhat + ": bound " + num(x) + " beyond +-" + num(kMaxViewCoordinate));
  const double n = double(v.resolution);
  const double spans[] = {n / (v.xMax - v.xMin), n / (v.yMax - v.yMin),
                          n / (v.mapping == DepthMapping::Linear ? v.far - v.near : std::log(v.far / v.near))};
  for (double scale : spans)
    if (!(std::isfinite(scale) && scale > 0)) r.fail(vwhat + ": an extent too small for its resolution");
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row)
      if (!(std::abs(v.viewFromWorld[c][row]) <= 2 * kMaxViewCoordinate))
        r.fail(vwhat + ": viewFromWorld element " + num(v.viewFromWorld[c][row]) + " beyond +-" +
               num(2 * kMaxViewCoordinate));
  if (f.pooled) readPoolRoot(r, f, vwhat, w, ChildCode(rootCode), out);
  else readViewDag(r, f, vwhat, w, ChildCode(rootCode), out, converted);
  return out;
}

// Step 5, per light: its record and its views' records (which must follow the previous light's: nextView).
CpvsFile::LightEntry readLight(const Reader& r, const FileLayout& f, uint64_t li, uint64_t& nextView,
                               std::vector<std::unique_ptr<ShadowDag>>& converted) {
  const bool strict = f.strict;
  const std::string& dotZero = f.dotZero;
  const Entry& strsS = f.entries[f.strs];
  const Entry& lghtS = f.entries[f.lght];
  const Entry& viewS = f.entries[f.view];
  const uint64_t viewCount = viewS.size / viewS.elementSize;
  const uint64_t at = lghtS.offset + li * lghtS.elementSize;
  const std::string what = "light " + std::to_string(li);
  CpvsFile::LightEntry entry;
  Light& l = entry.light;
  const uint32_t type = r.u32(at + L::kType);
  if (type >= kLightTypeCount) r.fail(what + ": unknown light type " + std::to_string(type));
  l.type = LightType(type);
  const uint64_t nameOffset = r.u32(at + L::kNameOffset), nameLength = r.u32(at + L::kNameLength);
  if (nameOffset > strsS.size || nameLength > strsS.size - nameOffset)
    r.fail(what + ": name (" + std::to_string(nameLength) + " bytes at " + std::to_string(nameOffset) +
           ") lies outside the string pool (" + std::to_string(strsS.size) + " bytes)");
  l.name.assign(reinterpret_cast<const char*>(r.data() + strsS.offset + nameOffset), size_t(nameLength));
  const std::string named = what + " '" + l.name + "'";
  const uint64_t firstView = r.u32(at + L::kFirstView), views = r.u32(at + L::kViewCount);
  if (firstView != nextView || views > viewCount - nextView)
    r.fail(named + ": views " + std::to_string(firstView) + ".." + std::to_string(firstView + views) +
           " do not follow the previous light's within the " + std::to_string(viewCount) + " view records");
  nextView += views;
  for (int c = 0; c < 3; ++c) l.color[c] = r.f32(at + L::kColor + 4 * c);
  l.intensity = r.f32(at + L::kIntensity);
  if (strict && r.u32(at + L::kReserved) != 0) r.fail(named + ": reserved field is not zero in a " + dotZero + " file");
  l.range = r.f64(at + L::kRange);
  l.innerConeAngle = r.f64(at + L::kInnerCone);
  l.outerConeAngle = r.f64(at + L::kOuterCone);
  for (int c = 0; c < 3; ++c) l.position[c] = r.f64(at + L::kPosition + 8 * c);
  for (int c = 0; c < 3; ++c) l.direction[c] = r.f64(at + L::kDirection + 8 * c);
  bool finite = std::isfinite(l.intensity) && std::isfinite(l.innerConeAngle) && std::isfinite(l.outerConeAngle);
  for (int c = 0; c < 3; ++c)
    finite = finite && std::isfinite(l.color[c]) && std::isfinite(l.position[c]) && std::isfinite(l.direction[c]);
  if (!finite) r.fail(named + ": a colour, intensity, cone, position or direction value is not finite");
  if (!(l.range > 0)) r.fail(named + ": range " + num(l.range) + " (expected > 0 or +inf)");

  // The views the light model gives the type (light.h, viewCountOf): view selection relies on them.
  if (views != viewCountOf(l))
    r.fail(named + ": " + std::to_string(views) + " views (a " + lightTypeName(l.type) + " light has " +
           std::to_string(viewCountOf(l)) + ")");
  entry.views.reserve(views);
  for (uint64_t vi = 0; vi < views; ++vi) {
    entry.views.push_back(readView(r, f, li, named, vi, firstView + vi, converted));
    const int face = hasCubeFaces(l) ? int(vi) : -1;
    if (entry.views.back().view.face != face)
      r.fail(named + ": view " + std::to_string(vi) + " is cube face " + std::to_string(entry.views.back().view.face) +
             " (expected " + std::to_string(face) + ")");
  }
  return entry;
}

// Step 6 (3.x): the node pool, with every view's root.
std::unique_ptr<FilePool> readPool(const Reader& r, const FileLayout& f, std::span<CpvsFile::View* const> views) {
  const Entry &poolS = f.entries[f.pool], &hottS = f.entries[f.hott], &nodeS = f.entries[f.node],
              &leafS = f.entries[f.leaf];
  const uint8_t* data = r.data();
  FilePoolSections sections;
  sections.records = {data + poolS.offset, size_t(poolS.size)};
  sections.recordSize = poolS.elementSize;
  sections.nodes = {data + nodeS.offset, size_t(nodeS.size)};
  // 64-byte aligned offsets into a buffer aligned to at least 8 bytes: the spans are properly aligned.
  sections.hot = {reinterpret_cast<const uint32_t*>(data + hottS.offset), size_t(hottS.size / 4)};
  sections.leaves = {reinterpret_cast<const uint64_t*>(data + leafS.offset), size_t(leafS.size / 8)};
  sections.strict = f.strict;
  sections.maxConvertedBytes = convertedBytesAllowed(r.size());
  Result<std::unique_ptr<FilePool>> pool = FilePool::read(sections, views, r.name());
  if (!pool) throw ReadFailure{pool.outcome().message()};
  return std::move(pool).value();
}

}  // namespace

void CpvsFile::parse(const std::string& name) {
  const Reader r(data_, size_, name);
  FileLayout f = readHeader(r);
  major_ = f.major;
  minor_ = f.minor;
  readSectionTable(r, f, sections_);
  checkPadding(r, f);
  findSections(r, f);
  const Entry& bakeS = f.entries[f.bake];
  settingsJson_.assign(reinterpret_cast<const char*>(data_ + bakeS.offset), size_t(bakeS.size));
  const Entry& lghtS = f.entries[f.lght];
  const Entry& viewS = f.entries[f.view];
  const uint64_t lightCount = lghtS.size / lghtS.elementSize;  // <= file size / 112
  const uint64_t viewCount = viewS.size / viewS.elementSize;   // <= file size / 472
  lights_.clear();
  lights_.reserve(lightCount);
  uint64_t nextView = 0;
  for (uint64_t li = 0; li < lightCount; ++li) lights_.push_back(readLight(r, f, li, nextView, converted_));
  if (nextView != viewCount)
    r.fail(std::to_string(viewCount - nextView) + " view records belong to no light");
  if (f.pooled) {
    std::vector<View*> views;
    for (LightEntry& light : lights_)
      for (View& view : light.views) views.push_back(&view);
    pool_ = readPool(r, f, views);
  }
}

const std::vector<CpvsFile::PoolLevel>& CpvsFile::poolLevels() const {
  static const std::vector<PoolLevel> kNone;
  return pool_ ? pool_->levels() : kNone;
}

uint64_t CpvsFile::poolLeaves() const { return pool_ ? pool_->leaves() : 0; }

Result<ShadowDag> CpvsFile::ownDag(const View& view) const {
  if (pool_) return pool_->ownDag(view.bytes);
  ShadowDag dag;
  dag.resolution = view.dag.resolution;
  dag.rootCode = view.dag.rootCode;
  dag.nodes.assign(view.dag.nodes.begin(), view.dag.nodes.end());
  dag.leaves.assign(view.dag.leaves.begin(), view.dag.leaves.end());
  dag.nodesPerLevel = view.nodesPerLevel;
  // Where each level starts: level l + 1 where the references of level l count from (DagView::childBase).
  const uint32_t log2 = dag.resolution >= 8 ? uint32_t(std::countr_zero(dag.resolution)) : 0;
  for (size_t l = 0; l < view.nodesPerLevel.size(); ++l)
    dag.levelOffsets.push_back(l == 0 ? 0 : view.dag.childBase[log2 - l + 1]);
  return dag;
}

}  // namespace cpvs
