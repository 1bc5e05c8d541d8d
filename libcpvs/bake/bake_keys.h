#pragma once
// The bake cache's keys: 64-bit hashes of everything a result's bytes depend on, at two grains. A light's key
// covers its whole bake; a region's key covers one region of one view (docs/incremental-bakes.md), so that an
// edit that misses a region leaves its key, and its cached DAG events, as they were.
#include <cstdint>
#include <vector>

#include "libcpvs/views/view_geometry.h"

namespace cpvs {

struct BakeSettings;

// What a light's DAGs depend on: the tool's version, the settings that shape the bytes, and per view its
// mapping and the triangles that reach it (in view space, closed and open apart), and a spot's cone (the voxels
// outside it are left free). The light's colour, intensity and name are not part of it: they do not change a
// voxel.
uint64_t lightBakeKey(const BakeSettings& settings, const Light& light, const std::vector<LightView>& views,
                      const std::vector<ViewGeometry>& geometry);

// What every region of one view shares: the tool's version, the settings that shape the bytes, the region size
// the view is built with, whether tiles may be summarised, the spot's cone, and the view's mapping. No geometry.
uint64_t viewFrameKey(const BakeSettings& settings, const Light& light, const LightView& view, uint32_t regionSize,
                      bool summarizeTiles);

// What one region's DAG events depend on beyond its view's frame: its rectangle, whether the spot's cone leaves
// it out (then nothing else counts), and otherwise the triangles that reach it as cullToRegion keeps them, in
// order: view-space corners, closed or open, and for alpha-tested ones their mask's hash (`maskHashes`, per mask
// of the geometry's `masks`) and mask coordinates.
uint64_t regionKey(uint64_t frameKey, const RegionRect& rect, bool outsideCone, const ViewGeometry& regionGeometry,
                   const std::vector<uint64_t>& maskHashes);

}  // namespace cpvs
