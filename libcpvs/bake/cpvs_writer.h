#pragma once
// Serialising a bake into a .cpvs (the byte-level spec: formats/cpvs/format.md), all at once or light by light as a bake
// finishes them, in format 2.0 (a DAG per view) or 3.0 (one pool of nodes and leaves for the whole file).
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <memory>

#include "formats/cpvs/cpvs_format.h"
#include "libcpvs/runtime/light.h"
#include "libcpvs/runtime/light_view.h"
#include "libcpvs/runtime/shadow_dag.h"

namespace cpvs {

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

class NodePool;

// Writes a .cpvs light by light: the lights and how many views each has are known before any is baked, so the
// layout of the settings, names and records is fixed up front. In 2.0 each light's DAG sections are written as
// it is added (in order), and the records, section table and header when the writer finishes: memory holds one
// light's DAGs at a time. In 3.0 each light's views join the file's node pool as it is added and the pool is
// laid out and written when the writer finishes: memory holds the pool (about 4x its laid-out bytes while it is
// built, libcpvs/dag/node_pool.h). The bytes equal writeCpvs's for the same content and version.
class CpvsWriter {
public:
  // Receives bytes at an offset of the file; every byte of [0, file size) is written exactly once.
  using WriteAt = std::function<void(uint64_t offset, const char* data, size_t size)>;
  // `major`: the format version to write, 2 or 3 (canWriteMajor); the minor is kCpvsMinorVersion.
  CpvsWriter(std::string settingsJson, std::vector<Light> lights, std::vector<size_t> viewsPerLight, WriteAt writeAt,
             uint16_t major = kCpvsDefaultMajor);
  ~CpvsWriter();
  // The next light, in the order given. Each light is first checked as a one-light file would be by a reader;
  // content that would not read back throws Error(RuntimeFailure) naming the light and view.
  void add(const BakedLight& light);
  // Writes the records, the section table and the header once every light is added; returns the file size.
  uint64_t finish();

private:
  struct Section {
    uint32_t type = 0, elementSize = 0;
    uint64_t offset = 0, size = 0, checksum = 0;
  };
  void writeSection(Section& section, const void* data);
  std::vector<uint8_t> viewRecord(const BakedView& view, size_t li, size_t vi, uint32_t sectionIndex) const;
  void finishPool();  // 3.0: LEAF, NODE, POOL and HOTT, and each view record's root
  std::string settingsJson_;
  std::vector<Light> lights_;
  std::vector<size_t> viewsPerLight_;
  WriteAt writeAt_;
  std::vector<Section> sections_;
  std::vector<std::vector<uint8_t>> viewRecords_;  // each view's record, filled as its light is added
  size_t added_ = 0, viewsAdded_ = 0;
  uint64_t end_ = 0;  // the end of the last section written
  bool checkLights_ = true;
  uint16_t major_;
  std::unique_ptr<NodePool> pool_;  // 3.0: every added view's DAG, until finish()
  friend std::string writeCpvs(const CpvsContent& content, uint16_t major);
};

// Serialises deterministically (same content, same bytes). The result is validated as a reader would before
// it is returned: content that would not read back (a malformed DAG, a non-finite view parameter, a
// resolution that is not a power of two) throws Error(RuntimeFailure) naming the light and view.
std::string writeCpvs(const CpvsContent& content, uint16_t major = kCpvsDefaultMajor);

}  // namespace cpvs
