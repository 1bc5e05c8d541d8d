#pragma once
// A folder of finished light bakes keyed by what each one depends on, so that a re-bake after a light or a mesh
// moved re-bakes only the lights whose inputs changed (docs/many-lights.md, "The bake cache").
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/views/view_geometry.h"

namespace cpvs {

struct BakeSettings;

// What a light's DAGs depend on: the tool's version, the settings that shape the bytes, and per view its
// mapping and the triangles that reach it (in view space, closed and open apart), and a spot's cone (the voxels
// outside it are left free). The light's colour, intensity and name are not part of it: they do not change a
// voxel.
uint64_t lightBakeKey(const BakeSettings& settings, const Light& light, const std::vector<LightView>& views,
                      const std::vector<ViewGeometry>& geometry);

class BakeCache {
public:
  // Creates the folder if needed. Throws Error(OutputFailed) when it cannot be created or written.
  explicit BakeCache(std::string folder);

  // The light baked under `key`, with `light`'s own record (name, colour, intensity) in place. Nothing when
  // the entry is missing, or is damaged or from another key (then `problem` says so; the caller bakes again).
  std::optional<BakedLight> find(uint64_t key, const Light& light, std::string* problem = nullptr) const;
  // Stores a finished light under `key`: a one-light .cpvs, written to a temporary and renamed, so a reader
  // (or another bake sharing the folder) never sees half an entry. Throws Error(OutputFailed).
  void store(uint64_t key, const BakedLight& baked) const;

  std::string pathOf(uint64_t key) const;

  // Keeps the folder's entries within `maxBytes`: the least recently used go first (an entry is used when it is
  // stored or found: find() and store() set its modification time). Only entries are counted and removed (files
  // named as pathOf names them), never anything else in the folder. A bake sharing the folder that has an entry
  // open keeps reading it (removal unlinks; the mapping stays), and one about to open it finds it missing and
  // bakes the light. Returns the entries removed and the bytes left.
  struct Trimmed {
    uint64_t removed = 0, bytesLeft = 0;
  };
  Trimmed trim(uint64_t maxBytes) const;

private:
  std::string folder_;
};

}  // namespace cpvs
