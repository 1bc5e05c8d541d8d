#pragma once
// What cpvs-view's map modes share (shadowmap, lightcluster, manypsm): the depth-texture array their maps are
// drawn into (a map per layer, or ManyPSMs' atlas cells), its read-back, the light records the lookups read,
// and the lookup pass (shadow_map_lookups.comp: eval/shadow_map.h's voxel, bias and K x K PCF rule).
#include <cstdint>
#include <vector>

#include "libcpvs/runtime/gpu_records.h"
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

// Where one map lies in the array: its size^2 texels from (x, y) of `layer`.
struct MapPlace {
  uint32_t layer = 0, x = 0, y = 0, size = 0;
};

class ShadowMapArray {
public:
  // Makes the array at least `layers` layers of size x size (32-bit float depth, q / 65536 per texel).
  void ensure(const gl::Context& context, uint32_t size, uint32_t layers);
  GLuint texture() const { return texture_; }
  GLuint framebuffer() const { return framebuffer_; }
  // The maps at `places` as 16-bit depths, one after the other, each row-major.
  std::vector<uint16_t> read(const gl::Context& context, const std::vector<MapPlace>& places) const;

private:
  GLuint texture_ = 0, framebuffer_ = 0;
  uint32_t size_ = 0, layers_ = 0;
};

struct MapRecordBuffers {
  GLuint lightReals = 0, lightWords = 0, viewReals = 0, viewWords = 0;
};
MapRecordBuffers uploadMapRecords(const gl::Context& context, const GpuSceneRecords& records, FrameBuffers& buffers);

// The lookup pass's program, counting GpuWorkCounters::forLookups(lights) sums.
struct MapLookupProgram {
  GLuint program = 0;
  uint32_t counters = 1;
};
MapLookupProgram linkMapLookupProgram(const gl::Context& context, size_t lights);

// The lookups (timed "shadows"): every listed pair's visibility into Frame::visibility, and the bytes of map
// texels they read into Frame::lookupBytes (and per light).
void lookUpMaps(ShadowPassFrame& p, const MapLookupProgram& lookups, const ShadowMapArray& maps,
                const MapRecordBuffers& records);

}  // namespace cpvs
