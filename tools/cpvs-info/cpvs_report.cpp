// cpvs-info for .cpvs files: everything is read through the runtime reader (libcpvs/runtime), which validates the
// whole file first; nothing here trusts a byte the reader has not checked. When the reader rejects a file, a
// separate bounds-checked scan reports which checksums still match, so that "which part is damaged" has an
// answer even though the reader stops at the first problem.
#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <optional>
#include <sstream>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <xxhash.h>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/base/error.h"
#include "tools/common/exit_codes.h"
#include "tools/cpvs-info/info_common.h"

namespace cpvs::info {
namespace {

using nlohmann::ordered_json;
using namespace cpvsformat;


uint64_t loadLE(const uint8_t* p, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= uint64_t(p[i]) << (8 * i);
  return v;
}

const char* faceName(int face) {
  static const char* const kNames[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
  return face >= 0 && face < 6 ? kNames[face] : nullptr;
}
const char* projectionName(Projection p) { return p == Projection::Perspective ? "perspective" : "orthographic"; }
const char* mappingName(DepthMapping m) { return m == DepthMapping::Logarithmic ? "logarithmic" : "linear"; }
const char* codeName(ChildCode c) {
  switch (c) {
    case ChildCode::Lit: return "lit";
    case ChildCode::Shadowed: return "shadowed";
    case ChildCode::Ref: return "ref";
  }
  return "?";
}

uint64_t sum(const std::vector<uint64_t>& v) {
  uint64_t s = 0;
  for (uint64_t x : v) s += x;
  return s;
}

bool pooled(const CpvsFile& file) { return file.majorVersion() >= 3; }

// What a view's DAG holds: as stored in its own sections (a format-1 file's 32-bit node words count at their size
// there); a view of a 3.x file's pool, as a 2.0 file would store it (CpvsFile::ownDag takes it out of the pool).
struct ViewDag {
  std::vector<uint64_t> nodesPerLevel;
  uint64_t nodeUnits = 0, leaves = 0, bytes = 0;
};
ViewDag viewDag(const CpvsFile& file, const CpvsFile::View& v) {
  if (pooled(file)) {
    const ShadowDag own = orThrow(file.ownDag(v));
    return {own.nodesPerLevel, own.nodes.size(), own.leaves.size(), own.bytes()};
  }
  return {v.nodesPerLevel, v.dag.nodes.size(), v.dag.leaves.size(), v.nodeBytes + v.dag.leaves.size() * 8};
}

// The node pool of a 3.x file: NODE (every level and its zero tail), HOTT and LEAF.
uint64_t poolBytes(const CpvsFile& file) {
  uint64_t bytes = kPoolTailBytes + file.poolLeaves() * 8;
  for (const CpvsFile::PoolLevel& l : file.poolLevels()) bytes += l.bytes + l.hotEntries * 4;
  return bytes;
}

std::string versionsText() {
  return "this build reads " + std::to_string(kCpvsOldestReadableMajor) + ".x to " + std::to_string(kCpvsNewestMajor) +
         ".x and writes " + std::to_string(kCpvsDefaultMajor) + "." + std::to_string(kCpvsMinorVersion) + ", or " +
         std::to_string(kCpvsNewestMajor) + "." + std::to_string(kCpvsMinorVersion) + " with --format-version " +
         std::to_string(kCpvsNewestMajor);
}

// What the reader holds of a 3.x pool in memory: the one array of 2.0 node units every view reads
// (DagView::sharedNodes), in bytes.
uint64_t sharedUnitBytes(const CpvsFile& file) {
  for (const CpvsFile::LightEntry& light : file.lights())
    for (const CpvsFile::View& v : light.views)
      if (!v.dag.sharedNodes.empty()) return v.dag.sharedNodes.size_bytes();
  return 0;
}

void printPool(std::ostream& out, const CpvsFile& file, uint64_t viewsAs2) {
  uint64_t nodes = 0;
  for (const CpvsFile::PoolLevel& l : file.poolLevels()) nodes += l.nodes;
  out << "pool: " << file.poolLevels().size() << " levels, " << nodes << " nodes, " << file.poolLeaves()
      << " leaves, " << poolBytes(file) << " bytes (its views as 2.0 DAGs: " << viewsAs2
      << " bytes; read as one array of 2.0 node units: " << sharedUnitBytes(file) << " bytes)\n";
  for (const CpvsFile::PoolLevel& l : file.poolLevels()) {
    out << "  edge " << l.edge << ": " << l.nodes << " nodes in " << l.bytes << " bytes, references of "
        << unsigned(l.shortBytes) << " or " << unsigned(l.longBytes) << " bytes";
    if (l.hotEntries) out << ", a hot table of " << l.hotEntries << " entries (" << l.hotEntries * 4 << " bytes)";
    out << "\n";
  }
}

ordered_json poolJson(const CpvsFile& file, uint64_t viewsAs2) {
  if (!pooled(file)) return nullptr;
  ordered_json levels = ordered_json::array();
  for (const CpvsFile::PoolLevel& l : file.poolLevels())
    levels.push_back({{"edge", l.edge},
                      {"shortBytes", l.shortBytes},
                      {"longBytes", l.longBytes},
                      {"offset", l.offset},
                      {"bytes", l.bytes},
                      {"nodes", l.nodes},
                      {"hotEntries", l.hotEntries}});
  return {{"levels", levels}, {"leaves", file.poolLeaves()}, {"bytes", poolBytes(file)}, {"viewsAs2Bytes", viewsAs2},
          {"sharedUnitBytes", sharedUnitBytes(file)}};
}

// The BAKE block is JSON text by convention; a file from another writer may hold anything (it is checksummed,
// not interpreted by the reader), so this never throws.
ordered_json parseSettings(const std::string& text) {
  ordered_json j = ordered_json::parse(text, nullptr, /*allow_exceptions=*/false);
  return j.is_discarded() ? ordered_json(nullptr) : j;
}

std::string settingString(const ordered_json& settings, const char* key) {
  if (!settings.is_object() || !settings.contains(key)) return {};
  const ordered_json& v = settings[key];
  return v.is_string() ? v.get<std::string>() : v.dump();
}

// ---------------------------------------------------------------------------------------------------------------
// A valid file

void printText(const std::string& path, const CpvsFile& file) {
  const auto bytes = file.bytes();
  const uint8_t* d = bytes.data();
  const uint64_t tableOffset = loadLE(d + HeaderLayout::kTableOffset, 8);
  const uint64_t tableSize = file.sections().size() * uint64_t(kSectionEntrySize);
  const ordered_json settings = parseSettings(file.settingsJson());
  std::ostream& out = std::cout;

  out << "file: " << path << "\n";
  out << "format: .cpvs " << file.majorVersion() << "." << file.minorVersion() << " (" << versionsText() << ")\n";
  out << "header: " << loadLE(d + HeaderLayout::kHeaderSize, 4) << " bytes, flags " << loadLE(d + HeaderLayout::kFlags, 4) << ", "
      << file.sections().size() << " sections in a table at offset " << tableOffset << ", file size "
      << file.fileSize() << " bytes\n";
  const std::string tool = settingString(settings, "tool"), toolVersion = settingString(settings, "tool_version");
  const std::string inputHash = settingString(settings, "input_hash");
  out << "tool: " << (tool.empty() && toolVersion.empty() ? "(not recorded)" : tool + " " + toolVersion) << "\n";
  out << "input hash: " << (inputHash.empty() ? "(not recorded)" : inputHash) << "\n";
  if (settings.is_object()) {
    out << "settings:";
    for (const auto& [key, value] : settings.items())
      out << " " << key << "=" << (value.is_string() ? value.get<std::string>() : value.dump());
    out << "\n";
  } else {
    out << "settings (" << file.settingsJson().size() << " bytes, not a JSON object): " << file.settingsJson()
        << "\n";
  }

  size_t viewCount = 0;
  uint64_t dagTotal = 0;
  out << "lights (" << file.lights().size() << "):\n";
  for (size_t li = 0; li < file.lights().size(); ++li) {
    const CpvsFile::LightEntry& light = file.lights()[li];
    out << "  light " << li << ": " << lightText(light.light) << "\n";
    for (size_t vi = 0; vi < light.views.size(); ++vi) {
      const CpvsFile::View& v = light.views[vi];
      const LightView& lv = v.view;
      out << "    view " << vi;
      if (const char* face = faceName(lv.face)) out << " (face " << face << ")";
      out << ": N " << lv.resolution << ", " << projectionName(lv.projection) << ", " << mappingName(lv.mapping)
          << " depth, near " << number(lv.near) << " far " << number(lv.far) << ", "
          << (lv.projection == Projection::Perspective ? "tan x" : "x") << " [" << number(lv.xMin) << ", "
          << number(lv.xMax) << "] " << (lv.projection == Projection::Perspective ? "tan y" : "y") << " ["
          << number(lv.yMin) << ", " << number(lv.yMax) << "]" << (lv.empty ? ", empty (nothing reaches it)" : "")
          << "\n";
      const ViewDag dag = viewDag(file, v);
      out << "      DAG: root " << codeName(v.dag.rootCode) << ", " << dag.nodesPerLevel.size()
          << " levels; nodes per level (root first):";
      for (uint64_t c : dag.nodesPerLevel) out << " " << c;
      const bool words = file.majorVersion() == 1;  // format 1: 32-bit node words in the file
      if (pooled(file))
        out << " = " << sum(dag.nodesPerLevel) << " nodes, unique leaves " << dag.leaves
            << ", in the pool (as a 2.0 DAG: " << dag.bytes << " bytes)\n";
      else
        out << " = " << sum(dag.nodesPerLevel) << " nodes in " << v.nodeBytes / (words ? 4 : 2)
            << (words ? " words (" : " units (") << v.nodeBytes << " bytes); unique leaves " << dag.leaves
            << " (" << dag.leaves * 8 << " bytes); " << dag.bytes << " bytes\n";
      ++viewCount;
      dagTotal += dag.bytes;
    }
  }

  const uint64_t viewsAs2 = dagTotal;
  if (pooled(file)) {
    printPool(out, file, viewsAs2);
    dagTotal = poolBytes(file);
  }
  uint64_t sectionBytes = 0;
  out << "sections (" << file.sections().size() << "):\n";
  out << "     #  type      offset        bytes  element  xxh3-64           checksum\n";
  for (size_t i = 0; i < file.sections().size(); ++i) {
    const CpvsFile::SectionInfo& s = file.sections()[i];
    char line[160];
    std::snprintf(line, sizeof line, "  %4zu  %-4s  %10llu  %11llu  %7u  %s  %s\n", i, s.type.c_str(),
                  static_cast<unsigned long long>(s.offset), static_cast<unsigned long long>(s.size), s.elementSize,
                  hex64(s.checksum).c_str(), s.checksumOk ? "ok" : "MISMATCH");
    out << line;
    sectionBytes += s.size;
  }
  const size_t okSections = size_t(std::count_if(file.sections().begin(), file.sections().end(),
                                                 [](const CpvsFile::SectionInfo& s) { return s.checksumOk; }));
  out << "checksums (XXH3-64): header ok, section table ok, " << okSections << " of " << file.sections().size()
      << " sections ok\n";
  out << "total: " << file.fileSize() << " bytes = header " << kHeaderSize << " + section table " << tableSize
      << " + sections " << sectionBytes << " + padding " << file.fileSize() - kHeaderSize - tableSize - sectionBytes
      << "; DAGs " << dagTotal << " bytes in " << viewCount << " views of " << file.lights().size() << " lights\n";
}

void printJson(const std::string& path, const CpvsFile& file) {
  const auto bytes = file.bytes();
  const uint8_t* d = bytes.data();
  const ordered_json settings = parseSettings(file.settingsJson());

  ordered_json lights = ordered_json::array();
  size_t viewCount = 0;
  uint64_t dagTotal = 0;
  for (size_t li = 0; li < file.lights().size(); ++li) {
    const CpvsFile::LightEntry& light = file.lights()[li];
    ordered_json entry = {{"index", li}};
    entry.update(lightJson(light.light));
    ordered_json views = ordered_json::array();
    for (const CpvsFile::View& v : light.views) {
      const LightView& lv = v.view;
      const ViewDag dag = viewDag(file, v);
      ordered_json matrix = ordered_json::array();
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) matrix.push_back(lv.viewFromWorld[c][r]);
      const char* face = faceName(lv.face);
      views.push_back({{"face", face ? ordered_json(face) : ordered_json(nullptr)},
                       {"resolution", lv.resolution},
                       {"projection", projectionName(lv.projection)},
                       {"depthMapping", mappingName(lv.mapping)},
                       {"near", lv.near},
                       {"far", lv.far},
                       {"xMin", lv.xMin},
                       {"xMax", lv.xMax},
                       {"yMin", lv.yMin},
                       {"yMax", lv.yMax},
                       {"viewFromWorld", matrix},
                       {"empty", lv.empty},
                       {"rootCode", codeName(v.dag.rootCode)},
                       {"levels", dag.nodesPerLevel.size()},
                       {"nodesPerLevel", dag.nodesPerLevel},
                       {"nodes", sum(dag.nodesPerLevel)},
                       {"nodeUnits", dag.nodeUnits},
                       {"nodeBytes", v.nodeBytes},
                       {"uniqueLeaves", dag.leaves},
                       {"inPool", pooled(file)},
                       {"bytes", dag.bytes}});
      ++viewCount;
      dagTotal += dag.bytes;
    }
    entry["views"] = views;
    lights.push_back(entry);
  }

  ordered_json sections = ordered_json::array();
  uint64_t sectionBytes = 0;
  for (size_t i = 0; i < file.sections().size(); ++i) {
    const CpvsFile::SectionInfo& s = file.sections()[i];
    sections.push_back({{"index", i},
                        {"type", s.type},
                        {"offset", s.offset},
                        {"size", s.size},
                        {"elementSize", s.elementSize},
                        {"checksum", hex64(s.checksum)},
                        {"checksumOk", s.checksumOk}});
    sectionBytes += s.size;
  }
  const uint64_t tableSize = file.sections().size() * uint64_t(kSectionEntrySize);
  const std::string tool = settingString(settings, "tool"), toolVersion = settingString(settings, "tool_version");
  const std::string inputHash = settingString(settings, "input_hash");
  const ordered_json pool = poolJson(file, dagTotal);
  if (pooled(file)) dagTotal = poolBytes(file);
  const ordered_json report = {
      {"file", path},
      {"kind", "cpvs"},
      {"valid", true},
      {"formatVersion", std::to_string(file.majorVersion()) + "." + std::to_string(file.minorVersion())},
      {"major", file.majorVersion()},
      {"minor", file.minorVersion()},
      {"header",
       {{"size", loadLE(d + HeaderLayout::kHeaderSize, 4)},
        {"flags", loadLE(d + HeaderLayout::kFlags, 4)},
        {"sectionCount", file.sections().size()},
        {"sectionTableOffset", loadLE(d + HeaderLayout::kTableOffset, 8)},
        {"fileSize", loadLE(d + HeaderLayout::kFileSize, 8)},
        {"checksum", hex64(loadLE(d + HeaderLayout::kChecksum, 8))},
        {"checksumOk", true},
        {"sectionTableChecksum", hex64(loadLE(d + HeaderLayout::kTableChecksum, 8))},
        {"sectionTableChecksumOk", true}}},
      {"tool", tool.empty() ? ordered_json(nullptr) : ordered_json(tool)},
      {"toolVersion", toolVersion.empty() ? ordered_json(nullptr) : ordered_json(toolVersion)},
      {"inputHash", inputHash.empty() ? ordered_json(nullptr) : ordered_json(inputHash)},
      {"settings", settings.is_object() ? settings : ordered_json(file.settingsJson())},
      {"lights", lights},
      {"pool", pool},
      {"sections", sections},
      {"totals",
       {{"lights", file.lights().size()},
        {"views", viewCount},
        {"dagBytes", dagTotal},
        {"headerBytes", kHeaderSize},
        {"sectionTableBytes", tableSize},
        {"sectionBytes", sectionBytes},
        {"paddingBytes", file.fileSize() - kHeaderSize - tableSize - sectionBytes},
        {"bytes", file.fileSize()}}}};
  std::cout << report.dump(2, ' ', false, nlohmann::detail::error_handler_t::replace) << "\n";
}

// ---------------------------------------------------------------------------------------------------------------
// An invalid file: which checksums can still be located, and which of them match.

struct ChecksumScan {
  uint64_t fileSize = 0;
  std::optional<bool> headerOk, tableOk;  // unset: could not be checked
  struct Section {
    uint64_t index = 0;
    std::string type;  // four characters, '?' for unprintable ones
    uint64_t offset = 0, size = 0;
    std::string status;  // ok, mismatch, outside the file, not checked
  };
  std::vector<Section> sections;
  std::string note;  // why the scan could not go further
};

class Fd {
public:
  explicit Fd(const std::string& path) : fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  bool read(uint64_t at, void* into, size_t n) const {
    auto* p = static_cast<uint8_t*>(into);
    while (n > 0) {
      const ssize_t got = ::pread(fd_, p, n, off_t(at));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) return false;
      p += got;
      at += uint64_t(got);
      n -= size_t(got);
    }
    return true;
  }

private:
  int fd_;
};

// Never trusts the table: every range is checked against the file size, and the bytes hashed in all are
// bounded (a crafted table can list the whole file many times).
ChecksumScan scanChecksums(const std::string& path) {
  ChecksumScan scan;
  const Fd fd(path);
  struct stat st {};
  if (fd.get() < 0 || ::fstat(fd.get(), &st) != 0 || !S_ISREG(st.st_mode)) {
    scan.note = "the file cannot be read";
    return scan;
  }
  scan.fileSize = uint64_t(st.st_size);
  uint8_t header[kHeaderSize];
  if (scan.fileSize < kHeaderSize || !fd.read(0, header, kHeaderSize)) {
    scan.note = "the file is shorter than the " + std::to_string(kHeaderSize) + "-byte header";
    return scan;
  }
  if (std::memcmp(header, kCpvsMagic, sizeof kCpvsMagic) != 0) {
    scan.note = "the file does not start with the .cpvs magic";
    return scan;
  }
  scan.headerOk = XXH3_64bits(header, HeaderLayout::kChecksum) == loadLE(header + HeaderLayout::kChecksum, 8);
  const uint64_t count = loadLE(header + HeaderLayout::kSectionCount, 4),
                 tableOffset = loadLE(header + HeaderLayout::kTableOffset, 8);
  if (tableOffset > scan.fileSize || count > (scan.fileSize - tableOffset) / kSectionEntrySize) {
    scan.note = "the section table (" + std::to_string(count) + " entries at offset " + std::to_string(tableOffset) +
                ") does not lie inside the file";
    return scan;
  }
  std::vector<uint8_t> table(size_t(count * kSectionEntrySize));
  if (!fd.read(tableOffset, table.data(), table.size())) {
    scan.note = "the section table cannot be read";
    return scan;
  }
  scan.tableOk = XXH3_64bits(table.data(), table.size()) == loadLE(header + HeaderLayout::kTableChecksum, 8);

  constexpr size_t kListed = 1024;  // entries listed at most
  uint64_t budget = std::max<uint64_t>(uint64_t(1) << 30, 4 * scan.fileSize);
  std::vector<uint8_t> chunk(size_t(1) << 20);
  XXH3_state_t* state = XXH3_createState();
  for (uint64_t i = 0; i < count && i < kListed; ++i) {
    const uint8_t* e = table.data() + i * kSectionEntrySize;
    ChecksumScan::Section s;
    s.index = i;
    for (int k = 0; k < 4; ++k) s.type += (e[k] >= 0x20 && e[k] <= 0x7E) ? char(e[k]) : '?';
    s.offset = loadLE(e + SectionEntryLayout::kOffset, 8);
    s.size = loadLE(e + SectionEntryLayout::kSize, 8);
    if (s.offset > scan.fileSize || s.size > scan.fileSize - s.offset) {
      s.status = "outside the file";
    } else if (s.size > budget) {
      s.status = "not checked";
    } else {
      budget -= s.size;
      XXH3_64bits_reset(state);
      bool ok = true;
      for (uint64_t at = 0; ok && at < s.size;) {
        const size_t n = size_t(std::min<uint64_t>(chunk.size(), s.size - at));
        ok = fd.read(s.offset + at, chunk.data(), n);
        if (ok) XXH3_64bits_update(state, chunk.data(), n);
        at += n;
      }
      s.status = !ok ? "not checked" : XXH3_64bits_digest(state) == loadLE(e + SectionEntryLayout::kChecksum, 8) ? "ok" : "mismatch";
    }
    scan.sections.push_back(std::move(s));
  }
  XXH3_freeState(state);
  if (count > kListed) scan.note = std::to_string(count - kListed) + " more section entries not listed";
  return scan;
}

std::string status(const std::optional<bool>& ok) { return !ok ? "not checked" : *ok ? "ok" : "mismatch"; }

void printScanText(const std::string& path, const ChecksumScan& scan) {
  std::ostream& err = std::cerr;
  err << kTool << ": checksum status of " << path << ": header " << status(scan.headerOk) << ", section table "
      << status(scan.tableOk);
  if (!scan.tableOk) {
    err << (scan.note.empty() ? "" : " (" + scan.note + ")") << "\n";
    return;
  }
  if (!*scan.tableOk) err << " (the entries below may be damaged)";
  err << "\n";
  for (const ChecksumScan::Section& s : scan.sections)
    err << "  section " << s.index << " '" << s.type << "' (" << s.size << " bytes at offset " << s.offset
        << "): " << s.status << "\n";
  if (!scan.note.empty()) err << "  (" << scan.note << ")\n";
}

ordered_json scanJson(const ChecksumScan& scan) {
  auto flag = [](const std::optional<bool>& ok) { return ok ? ordered_json(*ok) : ordered_json(nullptr); };
  ordered_json sections = ordered_json::array();
  for (const ChecksumScan::Section& s : scan.sections)
    sections.push_back(
        {{"index", s.index}, {"type", s.type}, {"offset", s.offset}, {"size", s.size}, {"status", s.status}});
  return {{"headerChecksumOk", flag(scan.headerOk)},
          {"sectionTableChecksumOk", flag(scan.tableOk)},
          {"sections", sections},
          {"note", scan.note.empty() ? ordered_json(nullptr) : ordered_json(scan.note)}};
}

}  // namespace

int printCpvs(const std::string& path, bool json) {
  std::unique_ptr<CpvsFile> file;
  try {
    file = orThrow(CpvsFile::open(path));
  } catch (const Error& e) {
    std::string message = e.what();
    if (message.find("not a .cpvs file") != std::string::npos) message += "; not a glTF scene (.gltf or .glb) either";
    std::cerr << kTool << ": error: " << message << "\n";
    const ChecksumScan scan = scanChecksums(path);
    const bool located = scan.headerOk.has_value();  // nothing to say about a file without a .cpvs header
    if (json) {
      const ordered_json report = {{"file", path},
                                   {"kind", "cpvs"},
                                   {"valid", false},
                                   {"error", message},
                                   {"exitCode", int(cpvs::tools::exitCodeFor(e.category()))},
                                   {"checksums", located ? scanJson(scan) : ordered_json(nullptr)}};
      std::cout << report.dump(2, ' ', false, nlohmann::detail::error_handler_t::replace) << "\n";
    } else if (located) {
      printScanText(path, scan);
    }
    return int(cpvs::tools::exitCodeFor(e.category()));
  }
  if (json)
    printJson(path, *file);
  else
    printText(path, *file);
  return 0;
}

}  // namespace cpvs::info
