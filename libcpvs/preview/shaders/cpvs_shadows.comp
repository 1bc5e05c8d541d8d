// Shadow pass: per pixel, per light of its tile's list, the CPVS lookup with K x K PCF (lookup_cell.glsl's
// voxel, dag_walk.glsl.h's count), as LightShadow::visibility answers it. One work group per tile.
// Counts the DAG bytes its walks read (work counter 0; 1 + light: per light; node units and leaves, not the
// records or the G-buffer).
// With RECORD_CELLS, every pair's verdict, voxel and count go to `cells` too (tests compare them with the CPU's).
layout(std430, binding = 11) writeonly buffer Cells { ivec4 cells[]; };  // (x, y, z, verdict | count << 2)
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
  double kernelHalf = 0.5LF * double(pcfKernel);  // cellSettings: K / 2
  for (uint slot = 0u; slot < count; ++slot) {
    float answer = 0.0;
    ivec4 record = ivec4(0);
    uint bytesBefore = gDagBytesRead;
    if (covered) {
      gLight = tileLights[tileOffsets[tile] + slot];
      int view = cpvsSelectView(p);
      if (view >= 0) {
        gView = cpvsLightWord(CPVS_LIGHT_FIRST_VIEW) + uint(view);
        CpvsCell cell = cpvsLookupCell(p, n, kernelHalf, biasMargin);
        record = ivec4(cell.voxel, int(cell.verdict));
        if (cell.verdict == CPVS_CELL_LIT) answer = 1.0;
        if (cell.verdict == CPVS_CELL_VOXEL) {
          uint shadowed = pcfKernel <= 1 ? (cpvsShadowed(uint(cell.voxel.x), uint(cell.voxel.y), uint(cell.voxel.z)) ? 1u : 0u)
                                         : cpvsShadowedTexels(cell.voxel.x, cell.voxel.y, uint(cell.voxel.z), pcfKernel);
          record.w |= int(shadowed << 2u);
          double k = double(pcfKernel);
          answer = pcfKernel <= 1 ? (shadowed != 0u ? 0.0 : 1.0) : float(1.0LF - double(shadowed) / (k * k));
        }
      }
    }
    visibility[pairIndex(tile, slot, local)] = answer;
    countWork(1u + tileLights[tileOffsets[tile] + slot], gDagBytesRead - bytesBefore);
#ifdef RECORD_CELLS
    cells[pairIndex(tile, slot, local)] = record;
#endif
  }
  countWork(0u, gDagBytesRead);
  endGroupWork();
}
