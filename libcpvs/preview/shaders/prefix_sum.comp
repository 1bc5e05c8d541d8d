// Exclusive prefix sum of the tiles' light counts (one work group: each invocation sums a run of tiles, the
// runs' sums are scanned in shared memory, then each run is written). offsets[tiles] = the total.
layout(local_size_x = 1024) in;
layout(std430, binding = 3) readonly buffer TileCounts { uint tileCounts[]; };
layout(std430, binding = 4) writeonly buffer TileOffsets { uint tileOffsets[]; };
uniform int tiles;
shared uint runSums[1024];
void main() {
  uint id = gl_LocalInvocationID.x;
  uint run = (uint(tiles) + 1023u) / 1024u;
  uint begin = min(id * run, uint(tiles)), end = min(begin + run, uint(tiles));
  uint sum = 0u;
  for (uint t = begin; t < end; ++t) sum += tileCounts[t];
  runSums[id] = sum;
  barrier();
  for (uint step = 1u; step < 1024u; step <<= 1u) {
    uint add = id >= step ? runSums[id - step] : 0u;
    barrier();
    runSums[id] += add;
    barrier();
  }
  uint offset = runSums[id] - sum;
  for (uint t = begin; t < end; ++t) {
    tileOffsets[t] = offset;
    offset += tileCounts[t];
  }
  if (id == 1023u) tileOffsets[uint(tiles)] = runSums[1023];
}
