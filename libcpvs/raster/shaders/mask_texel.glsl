// wrapTexel(coordinate, size, wrap): floor of the coordinate times the size, clamped to +-2^30, then
// CLAMP_TO_EDGE (33071), MIRRORED_REPEAT (33648) or REPEAT. (A header's wraps: w & 0xFFFF and (w >> 16) & 0xFFFF;
// the mask keeps the sign bit that >> copies down out of the T wrap.)

int wrapTexel(float coordinate, int size, int wrap) {
  int i = int(floor(clamp(coordinate * float(size), -1073741824.0, 1073741824.0)));
  if (wrap == 33071) return clamp(i, 0, size - 1);
  // The periods as unsigned, from i shifted by a multiple of the period that makes it non-negative (GLSL leaves
  // % of a negative operand undefined): i >= -2^30, so i + offset lies in [0, 2^32).
  uint period = uint(wrap == 33648 ? 2 * size : size);
  uint m = (uint(i) + period * (1073741824u / period + 1u)) % period;
  if (wrap == 33648) return int(m < uint(size) ? m : period - 1u - m);
  return int(m);
}
