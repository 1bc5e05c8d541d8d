// One level of ManyPSMs' traversal (the post's "one tree level per compute dispatch"): every (node, view) item
// of this level is culled against its view, or emitted as its triangles when a leaf, or as a point splat when
// it is at most a texel wide in its view, or else its two children become items of the next level.
layout(local_size_x = 64) in;
layout(std430, binding = 22) readonly buffer ItemsIn { uvec2 itemsIn[]; };
layout(std430, binding = 23) writeonly buffer ItemsOut { uvec2 itemsOut[]; };
layout(std430, binding = 27) readonly buffer LeafTriangles { uint leafTriangles[]; };
layout(std430, binding = 28) buffer ViewCounters { uint viewCounters[]; };  // per view: triangles, points
uniform uint level;
uniform uint itemCapacity, triangleCapacity, pointCapacity;

// The node's box in view space (centre, half extent), widened by a relative margin so that float rounding
// never culls a box that holds a covering point.
void viewBox(PsmNode node, PsmView view, out vec3 centre, out vec3 extent) {
  vec3 c = 0.5 * (node.lo.xyz + node.hi.xyz), e = 0.5 * (node.hi.xyz - node.lo.xyz);
  centre = (view.viewFromWorld * vec4(c, 1.0)).xyz;
  mat3 m = mat3(view.viewFromWorld);
  extent = abs(m[0]) * e.x + abs(m[1]) * e.y + abs(m[2]) * e.z;
  extent += 1e-5 * (abs(centre) + extent) + 1e-7;
}

// Largest value of dot(n, p) over the box.
float boxMax(vec3 n, vec3 centre, vec3 extent) { return dot(n, centre) + dot(abs(n), extent); }

// Whether no point of the box reaches a texel of the view: outside one of its lateral planes, or (perspective)
// wholly behind the eye. Depth is not culled: the maps clamp it instead of clipping.
bool culled(PsmView view, vec3 c, vec3 e) {
  vec4 l = view.lateral;
  float xMin = l.x, yMin = l.y, xMax = l.x + l.z, yMax = l.y + l.w;
  if (view.depth.x != 0.0)
    return c.x + e.x < xMin || c.x - e.x > xMax || c.y + e.y < yMin || c.y - e.y > yMax;
  // With d = -z: x >= xMin d  <=>  x + xMin z >= 0, x <= xMax d  <=>  -x - xMax z >= 0.
  return boxMax(vec3(0.0, 0.0, -1.0), c, e) <= 0.0 ||
         boxMax(vec3(1.0, 0.0, xMin), c, e) < 0.0 || boxMax(vec3(-1.0, 0.0, -xMax), c, e) < 0.0 ||
         boxMax(vec3(0.0, 1.0, yMin), c, e) < 0.0 || boxMax(vec3(0.0, -1.0, -yMax), c, e) < 0.0;
}

// The widest the box's projection can be, in texels of the view (infinite when it reaches the eye plane).
float texelsWide(PsmView view, vec3 c, vec3 e) {
  float res = float(view.cell.w);
  if (view.depth.x != 0.0) return max(2.0 * e.x * res / view.lateral.z, 2.0 * e.y * res / view.lateral.w);
  float dNear = -c.z - e.z, dFar = -c.z + e.z;
  if (dNear <= 0.0) return 1e30;
  // x / d over the box lies between the extremes of (c.x +- e.x) / dNear and / dFar.
  float xLo = min((c.x - e.x) / dNear, (c.x - e.x) / dFar), xHi = max((c.x + e.x) / dNear, (c.x + e.x) / dFar);
  float yLo = min((c.y - e.y) / dNear, (c.y - e.y) / dFar), yHi = max((c.y + e.y) / dNear, (c.y + e.y) / dFar);
  return max((xHi - xLo) * res / view.lateral.z, (yHi - yLo) * res / view.lateral.w);
}

void main() {
  uint index = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 64u + gl_LocalInvocationID.x;
  if (index >= min(psmCounters[2u + level], itemCapacity)) return;
  uvec2 item = itemsIn[index];
  PsmNode node = psmNodes[item.x];
  PsmView view = psmViews[item.y];
  vec3 c, e;
  viewBox(node, view, c, e);
  if (culled(view, c, e)) return;
  uint first = floatBitsToUint(node.lo.w), count = floatBitsToUint(node.hi.w);
  if (texelsWide(view, c, e) <= 1.0) {
    uint at = atomicAdd(psmCounters[1], 1u);
    if (at < pointCapacity) psmPoints[at] = item;
    atomicAdd(viewCounters[2u * item.y + 1u], 1u);
  } else if (count > 0u) {
    uint at = atomicAdd(psmCounters[0], count);
    for (uint k = 0u; k < count; ++k)
      if (at + k < triangleCapacity) psmTriangles[at + k] = uvec2(leafTriangles[first + k], item.y);
    atomicAdd(viewCounters[2u * item.y], count);
  } else {
    uint at = atomicAdd(psmCounters[3u + level], 2u);
    if (at < itemCapacity) itemsOut[at] = uvec2(first, item.y);
    if (at + 1u < itemCapacity) itemsOut[at + 1u] = uvec2(first + 1u, item.y);
  }
}
