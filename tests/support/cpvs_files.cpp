#include "support/cpvs_files.h"

#include <bit>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>
#include <xxhash.h>

#include "libcpvs/base/error.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/tiles/tile_masks.h"
#include "support/test_dags.h"

namespace cpvs::test::cpvsfiles {

ShadowDag bakedDag(uint32_t n, uint32_t seed) {
  return buildDag(buildTileChains(syntheticDepth(n, seed), UndefinedMode::Kampe), true);
}

// A DAG with no nodes: every voxel lit (or shadowed).
ShadowDag uniformDag(uint32_t n, ChildCode code) {
  ShadowDag dag;
  dag.resolution = n;
  dag.rootCode = code;
  dag.nodesPerLevel.assign(std::countr_zero(n) - 2, 0);
  dag.levelOffsets.assign(dag.nodesPerLevel.size(), 0);
  return dag;
}

LightView makeView(Projection projection, DepthMapping mapping, uint32_t n, int face, double k) {
  LightView v;
  v.projection = projection;
  v.mapping = mapping;
  v.resolution = n;
  v.face = face;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) v.viewFromWorld[c][r] = (c == r ? 1.0 : 0.0) + 0.125 * k * (c - r) + (c == 3 ? k : 0);
  v.xMin = -1.5 - k;
  v.xMax = 2.25 + k;
  v.yMin = -0.75;
  v.yMax = 1.0 / 3.0 + k;
  v.near = mapping == DepthMapping::Logarithmic ? 0.01 * (1 + k) : -2.5 + k;
  v.far = 40.0 + 0.1 * k;
  return v;
}

Light makeLight(LightType type, const std::string& name) {
  Light l;
  l.name = name;
  l.type = type;
  l.color = {1.0f, 0.9f, 0.75f};
  l.intensity = type == LightType::Directional ? 3.5f : 120.0f;
  l.range = type == LightType::Spot ? 25.5 : std::numeric_limits<double>::infinity();
  l.innerConeAngle = type == LightType::Spot ? kPi / 8 : 0.0;
  l.outerConeAngle = type == LightType::Spot ? kPi / 6 : kPi / 4;
  l.position = {1.25, 7.5, -0.1};
  l.direction = glm::normalize(glm::dvec3(0.3, -1.0, 0.2));
  return l;
}

// Baked DAGs from synthetic depth maps: a sun (1 view), a spot (1 view) and a point light (6 views).
CpvsContent bakedContent() {
  CpvsContent c;
  c.settingsJson = R"({"resolution":64,"undefined":"kampe","nodeReuse":true,"tool":"format_test"})";
  BakedLight sun{makeLight(LightType::Directional, "sun"), {}};
  sun.views.push_back({makeView(Projection::Orthographic, DepthMapping::Linear, 64, -1, 0), bakedDag(64, 1)});
  BakedLight spot{makeLight(LightType::Spot, "spot light"), {}};
  spot.views.push_back({makeView(Projection::Perspective, DepthMapping::Logarithmic, 32, -1, 1), bakedDag(32, 2)});
  BakedLight point{makeLight(LightType::Point, "bulb \xC3\xBC"), {}};
  for (int face = 0; face < 6; ++face) {
    BakedView v{makeView(Projection::Perspective, DepthMapping::Logarithmic, 16, face, 2 + face),
                face == 5 ? uniformDag(16, ChildCode::Lit) : bakedDag(16, 3 + face)};
    v.view.empty = face == 5;
    point.views.push_back(v);
  }
  c.lights = {sun, spot, point};
  return c;
}

// Hand-made DAGs, small and fixed: the content of the golden file.
CpvsContent tinyContent() {
  CpvsContent c;
  c.settingsJson = R"({"resolution":16,"undefined":"kampe","tool":"cpvs golden"})";
  // Sun, N = 16 (levels 0 and 1). Root: child 0 and child 4 -> node A (shared), child 1 shadowed, others lit.
  // A (leaf-parent): slice 0 -> leaf 0, slice 1 -> leaf 1, slice 2 shadowed, others lit. References count
  // units from the start of the next level: A is at unit 0 of level 1.
  ShadowDag sun;
  sun.resolution = 16;
  sun.rootCode = ChildCode::Ref;
  sun.nodes = {0x206, 0, 0, 0x1A, 0, 1};
  sun.leaves = {0x8100000000000081ull, 0x00FF00FF00FF00FFull};
  sun.nodesPerLevel = {1, 1};
  sun.levelOffsets = {0, 3};
  // Spot, N = 8: one leaf-parent root: slice 3 -> leaf 0, slice 5 shadowed.
  ShadowDag spot;
  spot.resolution = 8;
  spot.rootCode = ChildCode::Ref;
  spot.nodes = {0x480, 0};
  spot.leaves = {0x123456789ABCDEF0ull};
  spot.nodesPerLevel = {1};
  spot.levelOffsets = {0};
  // Point faces, N = 8: a two-leaf root, an all-shadowed face, and empty (all-lit) faces.
  ShadowDag face0;
  face0.resolution = 8;
  face0.rootCode = ChildCode::Ref;
  // Slice 0 -> leaf 0, slice 2 shadowed, slice 7 -> leaf 1 in the two-unit form (code 3), which the writer
  // only uses for values of 65536 and more but readers accept for any.
  face0.nodes = {0xC000 | 0x10 | 0x2, 0, 1, 0};
  face0.leaves = {0xF0F0F0F0F0F0F0F0ull, 0x1ull};
  face0.nodesPerLevel = {1};
  face0.levelOffsets = {0};

  BakedLight l0{makeLight(LightType::Directional, "sun"), {}};
  l0.views.push_back({makeView(Projection::Orthographic, DepthMapping::Linear, 16, -1, 0), sun});
  BakedLight l1{makeLight(LightType::Spot, "spot"), {}};
  l1.views.push_back({makeView(Projection::Perspective, DepthMapping::Logarithmic, 8, -1, 1), spot});
  BakedLight l2{makeLight(LightType::Point, "bulb"), {}};
  for (int face = 0; face < 6; ++face) {
    BakedView v{makeView(Projection::Perspective, DepthMapping::Logarithmic, 8, face, 2 + face),
                face == 0 ? face0 : uniformDag(8, face == 1 ? ChildCode::Shadowed : ChildCode::Lit)};
    v.view.empty = face >= 2;
    l2.views.push_back(v);
  }
  c.lights = {l0, l1, l2};
  return c;
}

Bytes toBytes(const std::string& s) { return Bytes(s.begin(), s.end()); }

Bytes readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeFile(const std::string& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::string openError(const Bytes& bytes, const std::string& name) {
  try {
    orThrow(CpvsFile::fromBytes(bytes, name));
  } catch (const Error& e) {
    EXPECT_EQ(e.category(), ErrorCategory::InvalidInput) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "opened although invalid";
  return {};
}


uint64_t getLE(const Bytes& b, size_t at, int n) {
  uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= uint64_t(b[at + i]) << (8 * i);
  return v;
}
void putLE(Bytes& b, size_t at, uint64_t v, int n) {
  if (at > b.size() || size_t(n) > b.size() - at) throw std::out_of_range("putLE past the end");
  for (int i = 0; i < n; ++i) b.at(at + i) = uint8_t(v >> (8 * i));
}
void putF64(Bytes& b, size_t at, double v) { putLE(b, at, std::bit_cast<uint64_t>(v), 8); }

RawFile unpack(const Bytes& b) {
  RawFile f;
  f.major = uint16_t(getLE(b, 8, 2));
  f.minor = uint16_t(getLE(b, 10, 2));
  const uint32_t count = uint32_t(getLE(b, 16, 4));
  const uint64_t table = getLE(b, 24, 8);
  for (uint32_t i = 0; i < count; ++i) {
    const size_t e = table + 32 * i;
    RawSection s;
    s.type = uint32_t(getLE(b, e, 4));
    s.elementSize = uint32_t(getLE(b, e + 4, 4));
    const uint64_t offset = getLE(b, e + 8, 8), size = getLE(b, e + 16, 8);
    s.bytes.assign(b.begin() + offset, b.begin() + offset + size);
    f.sections.push_back(std::move(s));
  }
  return f;
}

Bytes pack(const RawFile& f) {
  auto align = [](uint64_t v) { return (v + 63) / 64 * 64; };
  Bytes b(64, 0);
  std::vector<uint64_t> offsets;
  for (const RawSection& s : f.sections) {
    b.resize(align(b.size()), 0);
    offsets.push_back(b.size());
    b.insert(b.end(), s.bytes.begin(), s.bytes.end());
  }
  b.resize(align(b.size()), 0);
  const uint64_t table = b.size();
  b.resize(table + 32 * f.sections.size(), 0);
  for (size_t i = 0; i < f.sections.size(); ++i) {
    const RawSection& s = f.sections[i];
    putLE(b, table + 32 * i, s.type, 4);
    putLE(b, table + 32 * i + 4, s.elementSize, 4);
    putLE(b, table + 32 * i + 8, offsets[i], 8);
    putLE(b, table + 32 * i + 16, s.bytes.size(), 8);
    putLE(b, table + 32 * i + 24, XXH3_64bits(s.bytes.data(), s.bytes.size()), 8);
  }
  std::memcpy(b.data(), kCpvsMagic, 8);
  putLE(b, 8, f.major, 2);
  putLE(b, 10, f.minor, 2);
  putLE(b, 12, 64, 4);
  putLE(b, 16, f.sections.size(), 4);
  putLE(b, 24, table, 8);
  putLE(b, 32, b.size(), 8);
  putLE(b, 40, XXH3_64bits(b.data() + table, 32 * f.sections.size()), 8);
  putLE(b, 56, XXH3_64bits(b.data(), 56), 8);
  return b;
}

RawSection& sectionOf(RawFile& f, uint32_t type) {
  for (RawSection& s : f.sections)
    if (s.type == type) return s;
  throw std::runtime_error("no such section");
}

RawFile randomlyDamaged(const RawFile& original, size_t firstSection, std::mt19937& rng) {
  RawFile raw = original;
  const int edits = 1 + int(rng() % 3);
  for (int k = 0; k < edits; ++k) {
    RawSection& s = raw.sections[firstSection + rng() % (raw.sections.size() - firstSection)];
    if (s.bytes.empty()) continue;
    uint8_t& byte = s.bytes[rng() % s.bytes.size()];
    byte = rng() % 2 ? uint8_t(rng()) : uint8_t(byte ^ (1u << (rng() % 8)));
  }
  return raw;
}

}  // namespace cpvs::test::cpvsfiles
