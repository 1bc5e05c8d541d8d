#pragma once
// Enter and exit depth maps of one region of a light view, in integer slices (docs/architecture.md, "The voxel convention").
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include "libcpvs/views/view_regions.h"

namespace cpvs {

// Per texel (row-major within the region):
//  enter e: slice of the first surface along the ray through the texel centre, in [0, N-1];
//           e = N where the ray meets nothing (every voxel lit).
//  exit  x: first slice that must be shadowed. x = e + 1 where the first surface is open (or a back face);
//           for a closed solid, max(e + 1, slice where the ray leaves the union of closed solids);
//           x = N where the ray meets nothing.
// Voxel z is lit when z <= e, shadowed when z >= x, free (either value allowed) when e < z < x.
//
// A tile of 8x8 texels the renderer summarised instead of writing its texels (the CPU rasteriser's uniform tiles,
// docs/depth-maps.md): its enter slices are at most maxEnter and every exit is at least minExit > maxEnter (or
// the tile sees nothing: both N), which is all its tile chain depends on (tile_masks.cpp).
struct TileSummary {
  uint32_t maxEnter = 0, minExit = 0;
  bool summarized = false;
};

// An allocator whose vectors leave new elements uninitialised (resize writes nothing): a renderer that writes
// every texel it renders need not clear the texels of summarised tiles first (a region is 8 MB of texels).
template <class T>
struct UninitializedAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = UninitializedAllocator<U>;
  };
  UninitializedAllocator() = default;
  template <class U>
  UninitializedAllocator(const UninitializedAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* at) noexcept {
    ::new (static_cast<void*>(at)) U;
  }
  template <class U, class... Args>
  void construct(U* at, Args&&... args) {
    ::new (static_cast<void*>(at)) U(std::forward<Args>(args)...);
  }
};
using DepthTexels = std::vector<uint32_t, UninitializedAllocator<uint32_t>>;

struct DepthRegion {
  RegionRect rect;
  uint32_t resolution = 0;
  DepthTexels enter;
  DepthTexels exit;
  // Lossy bakes only (raster/next_surface.h), else empty: the slice of the nearest surface at or past the exit.
  DepthTexels next;
  // Per tile (row-major, rect.width / 8 per row), or empty: where summarized, that tile's enter and exit
  // texels hold nothing meaningful.
  std::vector<TileSummary> tiles;
  bool summarized(uint32_t tx, uint32_t ty) const {
    return !tiles.empty() && tiles[size_t(ty) * (rect.width / 8) + tx].summarized;
  }
  uint32_t enterAt(uint32_t x, uint32_t y) const { return enter[size_t(y) * rect.width + x]; }
  uint32_t exitAt(uint32_t x, uint32_t y) const { return exit[size_t(y) * rect.width + x]; }
};

}  // namespace cpvs
