// ManyPSMs' indirect arguments, written on the GPU so no level waits for the CPU: a level's dispatch size from
// its item count (DISPATCH), or the two draws' vertex counts (DRAWS: triangles x 3, then points).
layout(local_size_x = 1) in;
layout(std430, binding = 29) buffer Indirect { uint indirect[]; };
uniform uint level;  // DISPATCH: the level; its arguments at 3 level
uniform uint itemCapacity, triangleCapacity, pointCapacity;
uniform uint drawsAt;  // DRAWS: where the two DrawArraysIndirectCommands start
void main() {
#ifdef DISPATCH
  uint groups = (min(psmCounters[2u + level], itemCapacity) + 63u) / 64u;
  uint x = min(groups, 65535u);
  indirect[3u * level] = x;
  indirect[3u * level + 1u] = x == 0u ? 0u : (groups + x - 1u) / x;
  indirect[3u * level + 2u] = 1u;
#else
  indirect[drawsAt] = 3u * min(psmCounters[0], triangleCapacity);
  indirect[drawsAt + 1u] = 1u;
  indirect[drawsAt + 2u] = 0u;
  indirect[drawsAt + 3u] = 0u;
  indirect[drawsAt + 4u] = min(psmCounters[1], pointCapacity);
  indirect[drawsAt + 5u] = 1u;
  indirect[drawsAt + 6u] = 0u;
  indirect[drawsAt + 7u] = 0u;
#endif
}
