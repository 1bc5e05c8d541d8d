// Writes the .cpvs container, version 2.0 or 3.0 (formats/cpvs/format.md; field offsets: formats/cpvs/cpvs_layout.h). Every byte is written explicitly (little-endian,
// no struct images), padding is zero, and nothing depends on the time, the machine or memory addresses: the
// same content gives the same bytes.
#include <bit>
#include <cstring>
#include <limits>

#include <xxhash.h>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/base/error.h"
#include "libcpvs/dag/node_pool.h"

static_assert(std::endian::native == std::endian::little, "cpvs: the .cpvs format is little-endian; "
                                                          "big-endian hosts are not supported");

namespace cpvs {

using namespace cpvsformat;
using H = HeaderLayout;
using E = SectionEntryLayout;
using L = LightRecordLayout;
using V = ViewRecordLayout;
using P = PoolLevelLayout;

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

std::string where(const Light& light, size_t li, size_t vi) {
  return "light " + std::to_string(li) + " '" + light.name + "' view " + std::to_string(vi);
}

}  // namespace

CpvsWriter::~CpvsWriter() = default;

CpvsWriter::CpvsWriter(std::string settingsJson, std::vector<Light> lights, std::vector<size_t> viewsPerLight,
                       WriteAt writeAt, uint16_t major)
    : settingsJson_(std::move(settingsJson)), lights_(std::move(lights)), viewsPerLight_(std::move(viewsPerLight)),
      writeAt_(std::move(writeAt)), major_(major) {
  constexpr uint64_t kU32 = std::numeric_limits<uint32_t>::max();
  if (!canWriteMajor(major_)) fail("format version " + std::to_string(major_) + " cannot be written (2 or 3)");
  const bool pooled = major_ >= 3;
  if (viewsPerLight_.size() != lights_.size()) fail("a view count is needed for every light");
  uint64_t viewCount = 0, namesBytes = 0;
  for (size_t li = 0; li < lights_.size(); ++li) {
    namesBytes += lights_[li].name.size();
    viewCount += viewsPerLight_[li];
  }
  if (lights_.size() > kU32 || viewCount > kU32 || namesBytes > kU32)
    fail("too many lights, views or name bytes for 32-bit fields");

  // Layout: header, section table, BAKE, STRS, LGHT, VIEW, then NODE and LEAF of each view in order (2.0) or
  // LEAF, NODE, POOL and HOTT of the pool (3.0: in the order the pool's layout hands them over).
  const uint32_t viewRecordSize = pooled ? kPooledViewRecordSize : kViewRecordSize;
  sections_.push_back({kBake, 1, 0, settingsJson_.size()});
  sections_.push_back({kStrs, 1, 0, namesBytes});
  sections_.push_back({kLght, kLightRecordSize, 0, lights_.size() * uint64_t(kLightRecordSize)});
  sections_.push_back({kView, viewRecordSize, 0, viewCount * viewRecordSize});
  if (pooled) {
    for (const auto& [type, element] : {std::pair{kLeaf, 8u}, {kNode, 1u}, {kPool, kPoolLevelRecordSize}, {kHott, 4u}})
      sections_.push_back({type, element});
    pool_ = std::make_unique<NodePool>(LeafShape::Slices, /*countViews=*/false);
  } else {
    for (uint64_t v = 0; v < viewCount; ++v) {
      sections_.push_back({kNode, 2});
      sections_.push_back({kLeaf, 8});
    }
  }
  end_ = alignUp(kHeaderSize + sections_.size() * uint64_t(kSectionEntrySize));  // header and table: at finish()
  viewRecords_.assign(viewCount, {});

  writeSection(sections_[0], settingsJson_.data());
  std::string names;
  for (const Light& l : lights_) names += l.name;
  writeSection(sections_[1], names.data());
  std::string records(sections_[2].size, '\0');
  Out out(records);
  uint64_t nameOffset = 0, viewIndex = 0;
  for (size_t li = 0; li < lights_.size(); ++li) {
    const Light& l = lights_[li];
    const uint64_t r = li * kLightRecordSize;
    out.u32(r + L::kType, uint32_t(l.type));
    out.u32(r + L::kNameOffset, uint32_t(nameOffset));
    out.u32(r + L::kNameLength, uint32_t(l.name.size()));
    out.u32(r + L::kFirstView, uint32_t(viewIndex));
    out.u32(r + L::kViewCount, uint32_t(viewsPerLight_[li]));
    for (int c = 0; c < 3; ++c) out.f32(r + L::kColor + 4 * c, l.color[c]);
    out.f32(r + L::kIntensity, l.intensity);
    // L::kReserved: zero
    out.f64(r + L::kRange, l.range);
    out.f64(r + L::kInnerCone, l.innerConeAngle);
    out.f64(r + L::kOuterCone, l.outerConeAngle);
    for (int c = 0; c < 3; ++c) out.f64(r + L::kPosition + 8 * c, l.position[c]);
    for (int c = 0; c < 3; ++c) out.f64(r + L::kDirection + 8 * c, l.direction[c]);
    nameOffset += l.name.size();
    viewIndex += viewsPerLight_[li];
  }
  writeSection(sections_[2], records.data());
  // VIEW: its place (and the padding before it) now, its records when every light is in (finish()).
  Section& view = sections_[3];
  view.offset = alignUp(end_);
  static const char kZeros[kAlignment] = {};
  if (view.offset > end_) writeAt_(end_, kZeros, size_t(view.offset - end_));
  end_ = view.offset + view.size;
}

void CpvsWriter::writeSection(Section& section, const void* data) {
  section.offset = alignUp(end_);
  static const char kZeros[kAlignment] = {};
  if (section.offset > end_) writeAt_(end_, kZeros, size_t(section.offset - end_));
  if (section.size) writeAt_(section.offset, static_cast<const char*>(data), size_t(section.size));
  section.checksum = XXH3_64bits(data, size_t(section.size));
  end_ = section.offset + section.size;
}

void CpvsWriter::add(const BakedLight& baked) {
  const size_t li = added_;
  if (li >= lights_.size()) fail("more lights added than the file was laid out for");
  const Light& light = lights_[li];
  if (baked.light.name != light.name || baked.light.type != light.type)
    fail("light " + std::to_string(li) + " added is '" + baked.light.name + "', the file was laid out for '" +
         light.name + "'");
  if (baked.views.size() != viewsPerLight_[li])
    fail("light " + std::to_string(li) + " '" + light.name + "' has " + std::to_string(baked.views.size()) +
         " view(s), the file was laid out for " + std::to_string(viewsPerLight_[li]));
  if (checkLights_) {
    // Never hand out a file a reader would reject. The light on its own, with its views' DAGs left empty, must
    // read back as a valid file (its records), and each DAG must pass the reader's own validation where it
    // lies: a copy of a forest's DAG into a test file would double the bake's peak memory.
    BakedLight records{baked.light, {}};
    for (const BakedView& bv : baked.views) records.views.push_back({bv.view, ShadowDag{}});
    std::string bytes;
    CpvsWriter alone(settingsJson_, {light}, {records.views.size()}, [&](uint64_t at, const char* data, size_t n) {
      if (bytes.size() < at + n) bytes.resize(at + n, '\0');
      std::memcpy(bytes.data() + at, data, n);
    }, major_);
    alone.checkLights_ = false;
    alone.add(records);
    alone.finish();
    const auto check = CpvsFile::fromBorrowedBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()},
                                                   "the written .cpvs");
    if (!check)
      fail(where(light, li, 0) + ": does not form a valid .cpvs (a bug in the baker): " + check.outcome().message());
    for (size_t vi = 0; vi < baked.views.size(); ++vi) {
      const ShadowDag& dag = baked.views[vi].dag;
      const Outcome valid = validateStoredDag(where(light, li, vi), baked.views[vi].view.resolution, dag.rootCode,
                                              dag.nodes, dag.leaves.size(), dag.nodesPerLevel);
      if (!valid) fail("the DAG does not form a valid .cpvs view (a bug in the baker): " + valid.message());
    }
  }
  for (size_t vi = 0; vi < baked.views.size(); ++vi) {
    const BakedView& bv = baked.views[vi];
    const ShadowDag& dag = bv.dag;
    const uint32_t sectionIndex = uint32_t(4 + 2 * viewsAdded_);
    viewRecords_[viewsAdded_] = viewRecord(bv, li, vi, sectionIndex);
    if (pool_) {
      if (dag.rootCode == ChildCode::Ref && dag.levelOffsets.size() != dag.nodesPerLevel.size())
        fail(where(light, li, vi) + ": the DAG's level offsets are missing (a bug in the baker)");
      DagView view = dag.view();
      view.resolution = bv.view.resolution;  // a DAG without nodes may leave it 0
      pool_->add(view);
    } else {
      sections_[sectionIndex].size = dag.nodes.size() * 2;
      writeSection(sections_[sectionIndex], dag.nodes.data());
      sections_[sectionIndex + 1].size = dag.leaves.size() * 8;
      writeSection(sections_[sectionIndex + 1], dag.leaves.data());
    }
    ++viewsAdded_;
  }
  ++added_;
}

std::vector<uint8_t> CpvsWriter::viewRecord(const BakedView& bv, size_t li, size_t vi, uint32_t sectionIndex) const {
  constexpr uint64_t kU32 = std::numeric_limits<uint32_t>::max();
  const Light& light = lights_[li];
  const LightView& v = bv.view;
  const ShadowDag& dag = bv.dag;
  if (dag.resolution != v.resolution && !(dag.resolution == 0 && dag.nodes.empty() && dag.leaves.empty()))
    fail(where(light, li, vi) + ": the DAG's resolution " + std::to_string(dag.resolution) +
         " differs from the view's " + std::to_string(v.resolution));
  if (dag.nodesPerLevel.size() > kMaxLevels)
    fail(where(light, li, vi) + ": " + std::to_string(dag.nodesPerLevel.size()) + " DAG levels (at most " +
         std::to_string(kMaxLevels) + ")");
  if (dag.nodes.size() > kU32 || dag.leaves.size() > kU32)
    fail(where(light, li, vi) + ": DAG too large for 32-bit references");
  if (v.face < -1 || v.face > 5)
    fail(where(light, li, vi) + ": cube face " + std::to_string(v.face) + " (expected -1..5)");
  const bool pooled = major_ >= 3;
  std::string record(pooled ? kPooledViewRecordSize : kViewRecordSize, '\0');
  Out out(record);
  const uint32_t levels = DagView{v.resolution, dag.rootCode, {}, {}}.levels();
  out.u8(V::kProjection, uint8_t(v.projection));
  out.u8(V::kDepthMapping, uint8_t(v.mapping));
  out.u8(V::kFace, uint8_t(int8_t(v.face)));
  out.u8(V::kFlags, v.empty ? 1 : 0);
  out.u32(V::kResolution, v.resolution);
  out.u8(V::kRootCode, uint8_t(dag.rootCode));
  out.u8(V::kLevels, uint8_t(std::min<uint32_t>(levels, 255)));
  // V::kReserved: zero
  out.u32(V::kLight, uint32_t(li));
  if (!pooled) {  // 3.0: the root's place in the pool (V::kPoolRoot) once the pool is laid out
    out.u32(V::kNodeSection, sectionIndex);
    out.u32(V::kLeafSection, sectionIndex + 1);
    out.u64(V::kNodeUnits, dag.nodes.size());
    out.u64(V::kLeafCount, dag.leaves.size());
  }
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) out.f64(V::kViewFromWorld + 8 * (4 * c + row), v.viewFromWorld[c][row]);
  out.f64(V::kXMin, v.xMin);
  out.f64(V::kXMax, v.xMax);
  out.f64(V::kYMin, v.yMin);
  out.f64(V::kYMax, v.yMax);
  out.f64(V::kNear, v.near);
  out.f64(V::kFar, v.far);
  if (!pooled)
    for (size_t k = 0; k < dag.nodesPerLevel.size(); ++k) out.u64(V::kNodesPerLevel + 8 * k, dag.nodesPerLevel[k]);
  return {record.begin(), record.end()};
}

// The pool laid out once every view is in, written as it is laid out: LEAF, then NODE level by level (each level's
// bytes freed once written, then kPoolTailBytes zero bytes), then the level records (POOL) and hot tables (HOTT),
// and each view record's root.
void CpvsWriter::finishPool() {
  Section &leaf = sections_[4], &node = sections_[5], &pool = sections_[6], &hott = sections_[7];
  std::string records;
  std::vector<uint32_t> hot;
  XXH3_state_t* state = nullptr;
  uint64_t nodeBytes = 0;
  std::vector<LaidOutPool::Root> roots;
  NodePool::LayoutSink sink;
  sink.leaves = [&](std::vector<uint64_t>&& leaves) {
    leaf.size = leaves.size() * 8;
    writeSection(leaf, leaves.data());
    node.offset = alignUp(end_);
    static const char kZeros[kAlignment] = {};
    if (node.offset > end_) writeAt_(end_, kZeros, size_t(node.offset - end_));
    state = XXH3_createState();
    if (!state) throw std::bad_alloc();
    XXH3_64bits_reset(state);
  };
  sink.level = [&](PooledLevel&& level) {
    if (hot.size() + level.hot.size() > std::numeric_limits<uint32_t>::max()) fail("hot tables too large");
    const uint64_t r = records.size();
    records.resize(r + kPoolLevelRecordSize, '\0');
    Out out(records);
    out.u32(r + P::kEdge, level.edge);
    out.u8(r + P::kShortBytes, level.widths.shortBytes);
    out.u8(r + P::kLongBytes, level.widths.longBytes);
    out.u64(r + P::kOffset, nodeBytes);
    out.u64(r + P::kSize, level.bytes.size());
    out.u64(r + P::kNodes, level.nodes);
    out.u32(r + P::kFirstHot, level.hot.empty() ? 0 : uint32_t(hot.size()));
    out.u32(r + P::kHotCount, uint32_t(level.hot.size()));
    hot.insert(hot.end(), level.hot.begin(), level.hot.end());
    if (!level.bytes.empty()) writeAt_(node.offset + nodeBytes, reinterpret_cast<const char*>(level.bytes.data()), level.bytes.size());
    XXH3_64bits_update(state, level.bytes.data(), level.bytes.size());
    nodeBytes += level.bytes.size();
  };
  sink.roots = [&](std::vector<LaidOutPool::Root>&& laid) { roots = std::move(laid); };
  pool_->layOutInto(/*hotTables=*/true, sink);
  pool_.reset();
  static const char kTail[kPoolTailBytes] = {};
  writeAt_(node.offset + nodeBytes, kTail, kPoolTailBytes);
  XXH3_64bits_update(state, kTail, kPoolTailBytes);
  node.size = nodeBytes + kPoolTailBytes;
  node.checksum = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  end_ = node.offset + node.size;
  pool.size = records.size();
  writeSection(pool, records.data());
  hott.size = hot.size() * 4;
  writeSection(hott, hot.data());
  for (size_t v = 0; v < viewRecords_.size(); ++v) {
    const LaidOutPool::Root& root = roots[v];
    std::string field(8, '\0');
    Out(field).u64(0, root.code == ChildCode::Ref ? root.offset : 0);
    std::memcpy(viewRecords_[v].data() + V::kPoolRoot, field.data(), 8);
  }
}

uint64_t CpvsWriter::finish() {
  if (added_ != lights_.size())
    fail(std::to_string(added_) + " of the " + std::to_string(lights_.size()) + " lights were added");
  if (pool_) finishPool();
  std::string records;
  records.reserve(size_t(sections_[3].size));
  for (const std::vector<uint8_t>& r : viewRecords_) records.append(r.begin(), r.end());
  Section& view = sections_[3];
  if (view.size) writeAt_(view.offset, records.data(), records.size());
  view.checksum = XXH3_64bits(records.data(), records.size());
  const uint64_t tableOffset = kHeaderSize;
  const uint64_t tableSize = sections_.size() * uint64_t(kSectionEntrySize);
  std::string head(size_t(alignUp(tableOffset + tableSize)), '\0');
  Out out(head);
  for (size_t i = 0; i < sections_.size(); ++i) {
    const Section& s = sections_[i];
    const uint64_t e = tableOffset + i * kSectionEntrySize;
    out.u32(e + E::kType, s.type);
    out.u32(e + E::kElementSize, s.elementSize);
    out.u64(e + E::kOffset, s.offset);
    out.u64(e + E::kSize, s.size);
    out.u64(e + E::kChecksum, s.checksum);
  }
  out.raw(H::kMagic, kCpvsMagic, sizeof kCpvsMagic);
  out.u16(H::kMajor, major_);
  out.u16(H::kMinor, kCpvsMinorVersion);
  out.u32(H::kHeaderSize, kHeaderSize);
  out.u32(H::kSectionCount, uint32_t(sections_.size()));
  out.u32(H::kFlags, 0);
  out.u64(H::kTableOffset, tableOffset);
  out.u64(H::kFileSize, end_);  // the file ends where the last section ends
  out.u64(H::kTableChecksum, XXH3_64bits(head.data() + tableOffset, tableSize));
  // H::kReserved: zero
  out.u64(H::kChecksum, XXH3_64bits(head.data(), H::kChecksum));
  writeAt_(0, head.data(), head.size());
  return end_;
}

std::string writeCpvs(const CpvsContent& content, uint16_t major) {
  std::vector<Light> lights;
  std::vector<size_t> views;
  for (const BakedLight& l : content.lights) {
    lights.push_back(l.light);
    views.push_back(l.views.size());
  }
  std::string bytes;
  CpvsWriter writer(content.settingsJson, std::move(lights), std::move(views), [&](uint64_t at, const char* data, size_t n) {
    if (bytes.size() < at + n) bytes.resize(size_t(at + n), '\0');
    std::memcpy(bytes.data() + at, data, n);
  }, major);
  writer.checkLights_ = false;  // the whole file is checked below
  for (const BakedLight& l : content.lights) writer.add(l);
  writer.finish();

  // Never hand out a file that a reader would reject: validate it exactly as CpvsFile::open does.
  const auto check = CpvsFile::fromBorrowedBytes({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, "the written .cpvs");
  if (!check) fail("the content does not form a valid .cpvs (a bug in the baker): " + check.outcome().message());
  return bytes;
}

}  // namespace cpvs
