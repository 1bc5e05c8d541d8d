// Writes the .cpvs container, version 2.0 (docs/format.md). Every byte is written explicitly (little-endian,
// no struct images), padding is zero, and nothing depends on the time, the machine or memory addresses: the
// same content gives the same bytes.
#include <bit>
#include <cstring>
#include <limits>

#include <xxhash.h>

#include "formats/cpvs/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/base/error.h"

static_assert(std::endian::native == std::endian::little, "cpvs: the .cpvs format is little-endian; "
                                                          "big-endian hosts are not supported");

namespace cpvs {

using namespace cpvsformat;

namespace {

[[noreturn]] void fail(const std::string& what) { throw Error(ErrorCategory::RuntimeFailure, "writeCpvs: " + what); }

uint64_t alignUp(uint64_t v) { return (v + kAlignment - 1) / kAlignment * kAlignment; }

// Little-endian stores into a zero-filled buffer.
class Out {
public:
  explicit Out(std::string& buffer) : b_(buffer) {}
  void u8(uint64_t at, uint8_t v) { b_[at] = char(v); }
  void u16(uint64_t at, uint16_t v) { put(at, v, 2); }
  void u32(uint64_t at, uint32_t v) { put(at, v, 4); }
  void u64(uint64_t at, uint64_t v) { put(at, v, 8); }
  void f32(uint64_t at, float v) { u32(at, std::bit_cast<uint32_t>(v)); }
  void f64(uint64_t at, double v) { u64(at, std::bit_cast<uint64_t>(v)); }
  void raw(uint64_t at, const void* data, size_t n) {
    if (n) std::memcpy(b_.data() + at, data, n);
  }

private:
  void put(uint64_t at, uint64_t v, int n) {
    for (int i = 0; i < n; ++i) b_[at + i] = char(uint8_t(v >> (8 * i)));
  }
  std::string& b_;
};

struct Section {
  uint32_t type = 0;
  uint32_t elementSize = 0;
  uint64_t offset = 0, size = 0;
};

std::string where(const BakedLight& light, size_t li, size_t vi) {
  return "light " + std::to_string(li) + " '" + light.light.name + "' view " + std::to_string(vi);
}

}  // namespace

std::string writeCpvs(const CpvsContent& content) {
  constexpr uint64_t kU32 = std::numeric_limits<uint32_t>::max();
  // Counts that the fixed-width fields must hold.
  uint64_t viewCount = 0, namesBytes = 0;
  for (size_t li = 0; li < content.lights.size(); ++li) {
    const BakedLight& light = content.lights[li];
    namesBytes += light.light.name.size();
    viewCount += light.views.size();
    for (size_t vi = 0; vi < light.views.size(); ++vi) {
      const BakedView& v = light.views[vi];
      const ShadowDag& dag = v.dag;
      if (dag.resolution != v.view.resolution && !(dag.resolution == 0 && dag.nodes.empty() && dag.leaves.empty()))
        fail(where(light, li, vi) + ": the DAG's resolution " + std::to_string(dag.resolution) +
             " differs from the view's " + std::to_string(v.view.resolution));
      if (dag.nodesPerLevel.size() > kMaxLevels)
        fail(where(light, li, vi) + ": " + std::to_string(dag.nodesPerLevel.size()) + " DAG levels (at most " +
             std::to_string(kMaxLevels) + ")");
      if (dag.nodes.size() > kU32 || dag.leaves.size() > kU32)
        fail(where(light, li, vi) + ": DAG too large for 32-bit references");
      if (v.view.face < -1 || v.view.face > 5)
        fail(where(light, li, vi) + ": cube face " + std::to_string(v.view.face) + " (expected -1..5)");
    }
  }
  if (content.lights.size() > kU32 || viewCount > kU32 || namesBytes > kU32)
    fail("too many lights, views or name bytes for 32-bit fields");

  // Layout: header, section table, BAKE, STRS, LGHT, VIEW, then NODE and LEAF of each view in order.
  std::vector<Section> sections;
  sections.push_back({kBake, 1, 0, content.settingsJson.size()});
  sections.push_back({kStrs, 1, 0, namesBytes});
  sections.push_back({kLght, kLightRecordSize, 0, content.lights.size() * uint64_t(kLightRecordSize)});
  sections.push_back({kView, kViewRecordSize, 0, viewCount * kViewRecordSize});
  for (const BakedLight& light : content.lights)
    for (const BakedView& v : light.views) {
      sections.push_back({kNode, 2, 0, v.dag.nodes.size() * 2});
      sections.push_back({kLeaf, 8, 0, v.dag.leaves.size() * 8});
    }
  const uint64_t tableOffset = kHeaderSize;
  const uint64_t tableSize = sections.size() * uint64_t(kSectionEntrySize);
  uint64_t cursor = alignUp(tableOffset + tableSize), fileSize = cursor;
  for (Section& s : sections) {
    s.offset = cursor;
    fileSize = s.offset + s.size;  // the file ends where the last section ends
    cursor = alignUp(fileSize);
  }

  std::string bytes(fileSize, '\0');
  Out out(bytes);

  // BAKE and STRS.
  out.raw(sections[0].offset, content.settingsJson.data(), content.settingsJson.size());
  {
    uint64_t at = sections[1].offset;
    for (const BakedLight& light : content.lights) {
      out.raw(at, light.light.name.data(), light.light.name.size());
      at += light.light.name.size();
    }
  }
  // LGHT, VIEW, NODE, LEAF.
  uint64_t nameOffset = 0;
  uint32_t viewIndex = 0;
  uint32_t sectionIndex = 4;
  for (size_t li = 0; li < content.lights.size(); ++li) {
    const Light& l = content.lights[li].light;
    const uint64_t r = sections[2].offset + li * kLightRecordSize;
    out.u32(r + 0, uint32_t(l.type));
    out.u32(r + 4, uint32_t(nameOffset));
    out.u32(r + 8, uint32_t(l.name.size()));
    out.u32(r + 12, viewIndex);
    out.u32(r + 16, uint32_t(content.lights[li].views.size()));
    for (int c = 0; c < 3; ++c) out.f32(r + 20 + 4 * c, l.color[c]);
    out.f32(r + 32, l.intensity);
    // r + 36: reserved, zero
    out.f64(r + 40, l.range);
    out.f64(r + 48, l.innerConeAngle);
    out.f64(r + 56, l.outerConeAngle);
    for (int c = 0; c < 3; ++c) out.f64(r + 64 + 8 * c, l.position[c]);
    for (int c = 0; c < 3; ++c) out.f64(r + 88 + 8 * c, l.direction[c]);
    nameOffset += l.name.size();

    for (const BakedView& bv : content.lights[li].views) {
      const LightView& v = bv.view;
      const ShadowDag& dag = bv.dag;
      const uint64_t w = sections[3].offset + uint64_t(viewIndex) * kViewRecordSize;
      const uint32_t levels = DagView{v.resolution, dag.rootCode, {}, {}}.levels();
      out.u8(w + 0, uint8_t(v.projection));
      out.u8(w + 1, uint8_t(v.mapping));
      out.u8(w + 2, uint8_t(int8_t(v.face)));
      out.u8(w + 3, v.empty ? 1 : 0);
      out.u32(w + 4, v.resolution);
      out.u8(w + 8, uint8_t(dag.rootCode));
      out.u8(w + 9, uint8_t(std::min<uint32_t>(levels, 255)));
      // w + 10: reserved u16, zero
      out.u32(w + 12, uint32_t(li));
      out.u32(w + 16, sectionIndex);
      out.u32(w + 20, sectionIndex + 1);
      out.u64(w + 24, dag.nodes.size());
      out.u64(w + 32, dag.leaves.size());
      for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) out.f64(w + 40 + 8 * (4 * c + row), v.viewFromWorld[c][row]);
      out.f64(w + 168, v.xMin);
      out.f64(w + 176, v.xMax);
      out.f64(w + 184, v.yMin);
      out.f64(w + 192, v.yMax);
      out.f64(w + 200, v.near);
      out.f64(w + 208, v.far);
      for (size_t k = 0; k < dag.nodesPerLevel.size(); ++k) out.u64(w + 216 + 8 * k, dag.nodesPerLevel[k]);
      out.raw(sections[sectionIndex].offset, dag.nodes.data(), dag.nodes.size() * 2);
      out.raw(sections[sectionIndex + 1].offset, dag.leaves.data(), dag.leaves.size() * 8);
      sectionIndex += 2;
      ++viewIndex;
    }
  }

  // Section table, then the header that covers it.
  for (size_t i = 0; i < sections.size(); ++i) {
    const Section& s = sections[i];
    const uint64_t e = tableOffset + i * kSectionEntrySize;
    out.u32(e + 0, s.type);
    out.u32(e + 4, s.elementSize);
    out.u64(e + 8, s.offset);
    out.u64(e + 16, s.size);
    out.u64(e + 24, XXH3_64bits(bytes.data() + s.offset, s.size));
  }
  out.raw(0, kCpvsMagic, sizeof kCpvsMagic);
  out.u16(8, kCpvsMajorVersion);
  out.u16(10, kCpvsMinorVersion);
  out.u32(12, kHeaderSize);
  out.u32(16, uint32_t(sections.size()));
  out.u32(20, 0);  // flags
  out.u64(24, tableOffset);
  out.u64(32, fileSize);
  out.u64(40, XXH3_64bits(bytes.data() + tableOffset, tableSize));
  // 48..55: reserved, zero
  out.u64(56, XXH3_64bits(bytes.data(), 56));

  // Never hand out a file that a reader would reject: validate it exactly as CpvsFile::open does.
  const auto check = CpvsFile::fromBorrowedBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, "the written .cpvs");
  if (!check) fail("the content does not form a valid .cpvs (a bug in the baker): " + check.outcome().message());
  return bytes;
}

}  // namespace cpvs
