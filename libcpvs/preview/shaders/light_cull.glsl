// Whether a light's bounding volume meets a tile's bounds (lo, hi): a sun always; a point light's sphere
// (range) the box; a spot light's sphere, and its cone the box's bounding sphere (Wronski's cone test:
// the signed distance from the sphere's centre to the cone's side, a lower bound of the true distance).
// Conservative: in doubles, with the sphere enlarged by a relative 1e-6, so rounding never drops a light a
// pixel of the tile is in (tests/preview_test.cpp checks every pixel). bruteForceLightLists
// (libcpvs/preview/light_lists.cpp) is the same test in C++, operation for operation.
#ifndef CPVS_SPHERE_SCALE
#define CPVS_SPHERE_SCALE 1.0LF  // light_lists.comp doubles it for super-tiles
#endif
bool cpvsLightMeetsBox(uint shape, dvec3 position, dvec3 direction, double range, double cosOuter, double sinOuter,
                       dvec3 lo, dvec3 hi) {
  if ((shape & CPVS_SHAPE_POSITION) == 0u) return true;
  precise dvec3 gap = max(lo - position, dvec3(0.0LF)) + max(position - hi, dvec3(0.0LF));
  precise double gap2 = (gap.x * gap.x + gap.y * gap.y) + gap.z * gap.z;
  if (gap2 > range * range * 1.000001LF) return false;
  if ((shape & CPVS_SHAPE_CONE) == 0u || cosOuter <= 0.0LF) return true;
  precise dvec3 centre = 0.5LF * (lo + hi);
  precise dvec3 size = hi - lo;
  precise double radius = (0.5LF * sqrt((size.x * size.x + size.y * size.y) + size.z * size.z) * 1.000001LF +
                           1e-9LF * ((abs(centre.x) + abs(centre.y)) + abs(centre.z) + 1.0LF)) * CPVS_SPHERE_SCALE;
  precise dvec3 toCentre = centre - position;
  precise double along = (toCentre.x * direction.x + toCentre.y * direction.y) + toCentre.z * direction.z;
  precise double length2 = (toCentre.x * toCentre.x + toCentre.y * toCentre.y) + toCentre.z * toCentre.z;
  precise double across = sqrt(max(length2 - along * along, 0.0LF));
  precise double side = cosOuter * across - along * sinOuter;
  if (side > radius) return false;
  return along >= -radius;
}
