#pragma once
// Serialising a bake into a .cpvs (the byte-level spec: formats/cpvs/format.md), all at once or light by light as a bake
// finishes them.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

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

// Writes a .cpvs light by light: the lights and how many views each has are known before any is baked, so the
// layout of the settings, names and records is fixed up front; each light's DAG sections are written as it is
// added (in order), and the records, section table and header when the writer finishes. Memory holds one
// light's DAGs at a time. The bytes equal writeCpvs's for the same content.
class CpvsWriter {
public:
  // Receives bytes at an offset of the file; every byte of [0, file size) is written exactly once.
  using WriteAt = std::function<void(uint64_t offset, const char* data, size_t size)>;
  CpvsWriter(std::string settingsJson, std::vector<Light> lights, std::vector<size_t> viewsPerLight, WriteAt writeAt);
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
  struct ViewRecord;  // what the VIEW record of an added view needs besides its LightView
  void writeSection(Section& section, const void* data);
  std::string settingsJson_;
  std::vector<Light> lights_;
  std::vector<size_t> viewsPerLight_;
  WriteAt writeAt_;
  std::vector<Section> sections_;
  std::vector<std::vector<uint8_t>> viewRecords_;  // each view's 472 bytes, filled as its light is added
  size_t added_ = 0, viewsAdded_ = 0;
  uint64_t end_ = 0;  // the end of the last section written
  bool checkLights_ = true;
  friend std::string writeCpvs(const CpvsContent& content);
};

// Serialises deterministically (same content, same bytes). The result is validated as a reader would before
// it is returned: content that would not read back (a malformed DAG, a non-finite view parameter, a
// resolution that is not a power of two) throws Error(RuntimeFailure) naming the light and view.
std::string writeCpvs(const CpvsContent& content);

}  // namespace cpvs
