#include "libcpvs/dag/dag_encoder.h"

#include <algorithm>
#include <string>
#include <utility>

#include "libcpvs/base/error.h"
#include "libcpvs/dag/leaf_parent_table.h"

namespace cpvs {

namespace {

// encodeDag's order is a stable counting sort on the reference count capped at kCap: bucket 0 holds what is
// referenced kCap times or more, bucket kCap what nothing references; ties keep the build order.
constexpr uint32_t kCap = 1u << 16;
uint32_t bucketOf(uint32_t references) { return kCap - std::min(references, kCap); }

// Values consumed between two hand-backs of pages to the kernel.
constexpr size_t kDiscardStep = size_t(1) << 20;

[[noreturn]] void fail(const std::string& message) { throw Error(ErrorCategory::RuntimeFailure, message); }

template <class F>
void forEachReference(MappedArray<uint32_t>& words, F&& visit) {
  for (size_t i = 0; i < words.size();) {
    const unsigned count = nodeWordCount(words[i]);
    for (unsigned k = 1; k < count; ++k) visit(words[i + k]);
    i += count;
  }
}

// A level's nodes one after the other, at the positions its parents reference: build-form words.
class WordNodes {
public:
  explicit WordNodes(MappedArray<uint32_t>& words) : words_(words) {}
  size_t end() const { return words_.size(); }
  // Reads the node at `at` into its header and references; returns where the next node starts.
  size_t read(size_t at, uint32_t& header, uint32_t (&refs)[8]) const {
    header = words_[at];
    const unsigned count = nodeWordCount(header) - 1;
    for (unsigned k = 0; k < count; ++k) refs[k] = words_[at + 1 + k];
    return at + 1 + count;
  }
  void discardBefore(size_t at) { words_.discardBefore(at); }
  void release() { words_ = MappedArray<uint32_t>(); }

private:
  MappedArray<uint32_t>& words_;
};

// The leaf parents, byte-coded (leaf_parent_table.h); their references mapped through the leaves' new places.
class LeafParentNodes {
public:
  LeafParentNodes(MappedArray<uint8_t>& bytes, const std::vector<uint32_t>* leafPlace)
      : bytes_(bytes), leafPlace_(leafPlace) {}
  size_t end() const { return bytes_.size(); }
  size_t read(size_t at, uint32_t& header, uint32_t (&refs)[8]) const {
    const size_t next = at + LeafParentTable::decode(&bytes_[at], header, refs);
    if (leafPlace_) {
      const unsigned count = nodeWordCount(header) - 1;
      for (unsigned k = 0; k < count; ++k) refs[k] = (*leafPlace_)[refs[k]];
    }
    return next;
  }
  void discardBefore(size_t at) { bytes_.discardBefore(at); }
  void release() { bytes_ = MappedArray<uint8_t>(); }

private:
  MappedArray<uint8_t>& bytes_;
  const std::vector<uint32_t>* leafPlace_;
};

// Where the nodes of a level start: one bit a word (or byte), and the number of starts before each block of
// 64, so a reference (an offset) maps to the node's ordinal in build order in constant time for 1.5 bits a
// word (an array of ordinals by offset would take 32).
class NodeStarts {
public:
  template <class Nodes>
  explicit NodeStarts(const Nodes& nodes) : bits_(nodes.end() / 64 + 1, 0), before_(bits_.size(), 0) {
    uint32_t header, refs[8];
    for (size_t i = 0; i < nodes.end(); i = nodes.read(i, header, refs)) bits_[i / 64] |= uint64_t(1) << (i % 64);
    for (size_t b = 0; b < bits_.size(); ++b) {
      before_[b] = uint32_t(nodes_);
      nodes_ += popcount64(bits_[b]);
    }
  }
  uint64_t nodes() const { return nodes_; }
  // The ordinal of the node that starts at `offset`, or UINT32_MAX where none does.
  uint32_t ordinal(uint32_t offset) const {
    const size_t block = offset / 64;
    const uint64_t bit = uint64_t(1) << (offset % 64);
    if (block >= bits_.size() || !(bits_[block] & bit)) return UINT32_MAX;
    return before_[block] + popcount64(bits_[block] & (bit - 1));
  }

private:
  std::vector<uint64_t> bits_;
  std::vector<uint32_t> before_;
  uint64_t nodes_ = 0;
};

// Counts the references to each node of level l + 1 (by ordinal) from level l, and rewrites those references
// from offsets into ordinals, which is all the level's words are needed for once it is encoded.
template <class Nodes>
std::vector<uint32_t> countAndRenumber(MappedArray<uint32_t>& parents, const Nodes& level, size_t l) {
  const NodeStarts starts(level);
  std::vector<uint32_t> counts(starts.nodes(), 0);
  forEachReference(parents, [&](uint32_t& ref) {
    const uint32_t k = starts.ordinal(ref);
    if (k == UINT32_MAX)
      fail("DAG level " + std::to_string(l) + " references offset " + std::to_string(ref) + " of level " +
           std::to_string(l + 1) + ", where no node starts");
    uint32_t& n = counts[k];
    n += n != UINT32_MAX;
    ref = k;
  });
  return counts;
}

// Orders the leaves most referenced first, in place; returns each leaf's new index by its old one.
std::vector<uint32_t> reorderLeaves(const LeafParentNodes& leafParents, std::vector<uint64_t>& leaves) {
  std::vector<uint32_t> place(leaves.size(), 0);  // reference counts, then each leaf's new index
  uint32_t header, refs[8];
  for (size_t i = 0; i < leafParents.end();) {
    i = leafParents.read(i, header, refs);
    for (unsigned k = 0; k + 1 < nodeWordCount(header); ++k) {
      if (refs[k] >= place.size())
        fail("DAG leaf parent references leaf " + std::to_string(refs[k]) + " of " + std::to_string(place.size()));
      uint32_t& n = place[refs[k]];
      n += n != UINT32_MAX;
    }
  }
  std::vector<uint32_t> bucketStart(kCap + 2, 0);
  for (uint32_t n : place) ++bucketStart[bucketOf(n) + 1];
  for (size_t b = 1; b < bucketStart.size(); ++b) bucketStart[b] += bucketStart[b - 1];
  for (uint32_t& n : place) n = bucketStart[bucketOf(n)]++;
  // Follow each cycle of the permutation on a copy of the places: every swap puts one leaf where it belongs.
  std::vector<uint32_t> cycle = place;
  for (size_t i = 0; i < leaves.size(); ++i) {
    while (cycle[i] != i) {
      const uint32_t j = cycle[i];
      std::swap(leaves[i], leaves[j]);
      std::swap(cycle[i], cycle[j]);
    }
  }
  return place;
}

// Units a node takes in the stored form once its references are final (unit offsets or leaf indices).
uint64_t storedUnits(const uint32_t (&refs)[8], unsigned count) {
  uint64_t units = 1;
  for (unsigned k = 0; k < count; ++k) units += referenceUnits(refs[k]);
  return units;
}

// Encodes one level whose references are final, its nodes ordered by `place` (reference counts by ordinal),
// which then holds each node's unit offset. Consumes the nodes.
template <class Nodes>
MappedArray<uint16_t> encodeLevel(Nodes& nodes, std::vector<uint32_t>& place, size_t l) {
  // Two passes in build order: the units each bucket takes, then every node written at its bucket's cursor.
  std::vector<uint64_t> bucketStart(kCap + 2, 0);
  uint32_t header, refs[8];
  for (size_t i = 0, k = 0; i < nodes.end(); ++k) {
    i = nodes.read(i, header, refs);
    bucketStart[bucketOf(place[k]) + 1] += storedUnits(refs, nodeWordCount(header) - 1);
  }
  for (size_t b = 1; b < bucketStart.size(); ++b) bucketStart[b] += bucketStart[b - 1];
  MappedArray<uint16_t> out;
  out.resize(bucketStart.back());
  size_t discardAt = kDiscardStep;
  for (size_t i = 0, k = 0; i < nodes.end(); ++k) {
    i = nodes.read(i, header, refs);
    uint64_t& cursor = bucketStart[bucketOf(place[k])];
    if (cursor > UINT32_MAX) fail("DAG level " + std::to_string(l) + " too large for 32-bit references");
    const uint64_t at = cursor;
    place[k] = uint32_t(at);
    uint64_t next = at + 1;
    const auto put = [&](uint16_t unit) { out[next++] = unit; };
    out[at] = uint16_t(storeNode(header, [&](unsigned k) { return refs[k]; }, put));
    cursor = next;
    if (i >= discardAt) {
      nodes.discardBefore(i);
      discardAt = i + kDiscardStep;
    }
  }
  nodes.release();
  return out;
}

}  // namespace

ShadowDag encodeBuiltDag(uint32_t resolution, ChildCode rootCode, std::vector<MappedArray<uint32_t>> levelWords,
                         MappedArray<uint8_t> leafParents, std::vector<uint64_t> leaves) {
  ShadowDag dag;
  dag.resolution = resolution;
  dag.rootCode = rootCode;
  const size_t leafLevel = levelWords.size(), levels = leafLevel + 1;
  const std::vector<uint32_t> leafPlace = reorderLeaves(LeafParentNodes(leafParents, nullptr), leaves);
  dag.leaves = std::move(leaves);
  dag.nodesPerLevel.assign(levels, 0);

  // Bottom-up: a level's unit offsets depend on its references' widths, hence on the offsets below.
  std::vector<MappedArray<uint16_t>> units(levels);
  auto encode = [&](auto& nodes, size_t l) {
    std::vector<uint32_t> place = l > 0 ? countAndRenumber(levelWords[l - 1], nodes, l - 1)
                                        : std::vector<uint32_t>(NodeStarts(nodes).nodes(), 0);
    dag.nodesPerLevel[l] = place.size();
    units[l] = encodeLevel(nodes, place, l);
    if (l > 0) forEachReference(levelWords[l - 1], [&](uint32_t& ref) { ref = place[ref]; });
  };
  LeafParentNodes leafParentNodes(leafParents, &leafPlace);
  encode(leafParentNodes, leafLevel);
  for (size_t l = leafLevel; l-- > 0;) {
    WordNodes nodes(levelWords[l]);
    encode(nodes, l);
  }

  uint64_t total = 0;
  for (const MappedArray<uint16_t>& level : units) {
    dag.levelOffsets.push_back(total);
    total += level.size();
  }
  // Level starts and the file's unit count are 32-bit.
  if (total > UINT32_MAX) fail("DAG of " + std::to_string(total) + " node units: too large for a .cpvs view");
  // One level after the other, each given back as it is copied: the peak is the stored DAG plus a step.
  dag.nodes.reserve(total);
  for (MappedArray<uint16_t>& level : units) {
    const std::span<const uint16_t> from = level.span();
    for (size_t at = 0; at < from.size(); at += kDiscardStep) {
      const size_t end = std::min(from.size(), at + kDiscardStep);
      dag.nodes.insert(dag.nodes.end(), from.begin() + at, from.begin() + end);
      level.discardBefore(end);
    }
    level = MappedArray<uint16_t>();
  }
  return dag;
}

}  // namespace cpvs
