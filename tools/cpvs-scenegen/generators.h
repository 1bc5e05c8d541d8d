#pragma once
// The benchmark scenes of cpvs-scenegen (see docs/scenegen.md).
#include <cstdint>

#include "gen_scene.h"

namespace cpvs::scenegen {

struct CityOptions {
  std::uint64_t seed = 1;
  std::uint64_t targetTriangles = 100000;
  bool open = false;  // open-city: single-sided walls, no caps, ground as one sheet
  int spotLights = 0;  // > 0: city-spots (these spots and no sun); 0: one directional sun
  bool pointLights = false;  // city-spots: point lights at the spots' places instead
  int groundTiles = 1;  // > 1: the ground slab as N x N instanced tiles (caster culling can then drop parts of it)
};

// What the city generator chose to approximate the triangle budget.
struct CityInfo {
  int lotsPerSide = 0;    // the searched density
  int blocksPerSide = 0;
  int lotsPerBlockSide = 0;
  double blockPitch = 0.0;  // block + street, in scene units
  double lotSize = 0.0;
  double detail = 0.0;  // 0 (plain boxes) .. 1.8 (dense facades)
};

// The closed (or open) city: ~1000 x 1000 units, y up, buildings 10..120 high on a ground slab.
GenScene generateCity(const CityOptions& options, CityInfo* info = nullptr);

struct LandscapeOptions {
  std::uint64_t seed = 1;
  std::uint64_t targetTriangles = 100000;
};

// A closed fractal landscape: an fBm heightfield (1000 x 1000 units) with side walls and a bottom.
GenScene generateLandscape(const LandscapeOptions& options);

// The alpha-test scene: a ground quad and three cards at y = 1 (alpha-masked checker, blended glass,
// opaque checker) under a sun shining straight down. Fixed; see docs/scenegen.md for its exact geometry.
GenScene generateAlphaTest();

struct FoliageOptions {
  std::uint64_t seed = 1;
  std::uint64_t targetTriangles = 200000;
  int spotLights = 16;
};

struct FoliageInfo {
  int trees = 0;
  int prototypes = 0;  // tree prototypes placed at least once
  int buildings = 0;
  double leafCoverage = 0.0;  // the share of leaf-texture texels with alpha 255
};

// A wooded level (400 x 400 units): a ground quad, box buildings with glass windows and canopies (BLEND),
// and trees placed by EXT_mesh_gpu_instancing (trunk + alpha-masked leaf cards), lit by a sun and spots.
GenScene generateFoliage(const FoliageOptions& options, FoliageInfo* info = nullptr);

// The direction the default sun of the city and landscape travels (normalised (-0.4, -1, -0.3)).
glm::dvec3 sunDirection();

}  // namespace cpvs::scenegen
