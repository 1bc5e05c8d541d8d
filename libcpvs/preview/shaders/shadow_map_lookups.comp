// Shadow-map lookups (cpvs-view --shadows shadowmap / lightcluster): per pixel and listed light, eval/shadow_map.h's
// rule: lookup_cell.glsl's voxel and bias in the map's resolution M, then the K x K texels' 16-bit depths
// against the biased point's (texels outside the map lit). A light's shadow comes from the views of the light
// record CPVS_LIGHT_SHADOW_LIGHT names: its own, or (LightCluster) its cluster's cube at the cluster's centre.
// A view's map is the resolution^2 texels from (CPVS_VIEW_ATLAS_X, CPVS_VIEW_ATLAS_Y) of its layer (the
// origin for a map per layer; ManyPSMs packs several into one). Counts the bytes of the texels it reads (work
// counter 0; 1 + light: per light).
layout(binding = 3) uniform sampler2DArray shadowMaps;  // q / 65536 per texel
uniform int pcfKernel;
uniform double biasMargin;
void main() {
  beginGroupWork();
  uint tile = gl_WorkGroupID.y * uint(tileCount.x) + gl_WorkGroupID.x;
  uint local = gl_LocalInvocationID.y * 8u + gl_LocalInvocationID.x;
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  bool covered = pixel.x < imageSize_.x && pixel.y < imageSize_.y;
  vec4 position = covered ? texelFetch(positions, pixel, 0) : vec4(0.0);
  covered = covered && position.w != 0.0;
  dvec3 p = dvec3(position.xyz);
  dvec3 n = dvec3(covered ? texelFetch(normals, pixel, 0).xyz : vec3(0.0));
  uint count = tileOffsets[tile + 1u] - tileOffsets[tile];
  double kernelHalf = 0.5LF * double(pcfKernel);
  for (uint slot = 0u; slot < count; ++slot) {
    float answer = 0.0;
    if (covered) {
      gLight = tileLights[tileOffsets[tile] + slot];
      if (cpvsSelectView(p) >= 0) {  // within the light's own influence
        gLight = cpvsLightWord(CPVS_LIGHT_SHADOW_LIGHT);
        int view = cpvsSelectView(p);
        answer = 1.0;
        if (view >= 0) {
          gView = cpvsLightWord(CPVS_LIGHT_FIRST_VIEW) + uint(view);
          CpvsCell cell = cpvsLookupCell(p, n, kernelHalf, biasMargin);
          if (cell.verdict == CPVS_CELL_ZERO) answer = 0.0;
          if (cell.verdict == CPVS_CELL_VOXEL) {
            int m = int(cpvsMappingReal(CPVS_MAP_RESOLUTION));
            double slice = clamp(cell.slice, 0.0LF, double(m));
            double scaled = floor(slice * 65536.0LF / double(m));
            uint q = scaled > 0.0LF ? uint(min(scaled, 65535.0LF)) : 0u;  // quantizeSlice
            int layer = int(cpvsViewWord(CPVS_VIEW_LAYER));
            ivec2 origin = ivec2(cpvsViewWord(CPVS_VIEW_ATLAS_X), cpvsViewWord(CPVS_VIEW_ATLAS_Y));
            uint read = 0u;
            int r = pcfKernel / 2;
            uint lit = 0u;
            for (int dy = -r; dy <= r; ++dy)
              for (int dx = -r; dx <= r; ++dx) {
                ivec2 t = cell.voxel.xy + ivec2(dx, dy);
                bool outside = t.x < 0 || t.y < 0 || t.x >= m || t.y >= m;
                uint stored = outside ? 65535u : uint(texelFetch(shadowMaps, ivec3(origin + t, layer), 0).r * 65536.0);
                lit += (outside || q <= stored) ? 1u : 0u;
                read += outside ? 0u : 1u;
              }
            countWork(0u, 4u * read);  // 32-bit texels
            countWork(1u + tileLights[tileOffsets[tile] + slot], 4u * read);
            double k = double(pcfKernel);
            answer = float(double(lit) / (k * k));
          }
        }
      }
    }
    visibility[pairIndex(tile, slot, local)] = answer;
  }
  endGroupWork();
}
