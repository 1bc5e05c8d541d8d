// The GLSL 4.50 twin of cell_lanes.h's cellVerdict (steps 1-3 of a lookup in shadow_lookup.h: grid point,
// normal bias, voxel) and of a light's view selection, in 64-bit floats with the C++ operations in the same
// order, marked `precise` so that no compiler fuses a multiply and an add the CPU does not. The depth log is
// view_mapping.h's mappingLog (exponent and mantissa split with unpackDouble2x32), not GLSL's log. Where the
// GPU's double division and square root round correctly (llvmpipe) the integers are the CPU's; where they do
// not, a point near a voxel boundary may land one voxel over (docs/viewer.md has the measurement).
//
// The includer provides, for the view and light being looked up:
//   double cpvsMappingReal(uint i)   the view's ViewMapping constants, i = CPVS_MAP_* below
//   uint   cpvsMappingFlags()        CPVS_FLAG_* bits
//   double cpvsLightReal(uint i)     the light's constants, i = CPVS_LIGHT_* below
//   uint   cpvsLightShape()          CPVS_SHAPE_* bits (light.glsl.h)
//   uint   cpvsLightWord(uint i)     the light's words, i = CPVS_LIGHT_* below (the view count)
//   int    cpvsFaceView(uint face)   a point light's view index of cube face 0..5 (+X, -X, +Y, -Y, +Z, -Z), -1: none
// The record layouts (CPVS_MAP_*, CPVS_LIGHT_*) are lookup_records.glsl's, included before this text.

// The verdict of a lookup: CPVS_CELL_VOXEL (look up voxel), CPVS_CELL_LIT (1) or CPVS_CELL_ZERO (0).
#define CPVS_CELL_ZERO 0u
#define CPVS_CELL_LIT 1u
#define CPVS_CELL_VOXEL 2u

struct CpvsCell {
  uint verdict;
  ivec3 voxel;
  double slice;  // the biased point's continuous slice (LookupCell::uvs.z), before the clamp
};

double cpvsLogOfParts(double m, double e) {
  precise double f = m - 1.0LF;
  precise double s = f / (2.0LF + f);
  precise double z = s * s;
  precise double w = z * z;
  precise double t1 = w * (3.999999999940941908e-01LF + w * (2.222219843214978396e-01LF + w * 1.531383769920937332e-01LF));
  precise double t2 = z * (6.666666666666735130e-01LF +
                           w * (2.857142874366239149e-01LF + w * (1.818357216161805012e-01LF + w * 1.479819860511658591e-01LF)));
  precise double r = t2 + t1;
  precise double halfF2 = (0.5LF * f) * f;
  precise double result = e * 6.93147180369123816490e-01LF - ((halfF2 - (s * (halfF2 + r) + e * 1.90821492927058770002e-10LF)) - f);
  return result;
}

double cpvsMappingLog(double x) {
  uvec2 bits = unpackDouble2x32(x);  // (low, high) words
  precise double m = packDouble2x32(uvec2(bits.x, (bits.y & 0x000fffffu) | 0x3ff00000u));  // [1, 2)
  precise double e = double(int((bits.y >> 20u) & 0x7ffu)) - 1023.0LF;
  bool high = m > 1.4142135623730951LF;
  precise double halfM = m * 0.5LF;
  precise double nextE = e + 1.0LF;
  return cpvsLogOfParts(high ? halfM : m, high ? nextE : e);
}

bool cpvsFinite(double x) {
  precise double d = x - x;
  return d == 0.0LF;
}

// The view a point falls in (LightShadow::viewIndex), or -1 outside the light's influence: a light without a
// position has one view everywhere; else within range, inside the cone where the light has one, then its one
// view or the cube face of the major axis.
int cpvsSelectView(dvec3 p) {
  if (cpvsLightWord(CPVS_LIGHT_VIEW_COUNT) == 0u) return -1;  // a light without views: 0, as viewIndex answers
  uint shape = cpvsLightShape();
  if ((shape & CPVS_SHAPE_POSITION) == 0u) return 0;
  precise double tx = p.x - cpvsLightReal(CPVS_LIGHT_POSITION);
  precise double ty = p.y - cpvsLightReal(CPVS_LIGHT_POSITION + 1u);
  precise double tz = p.z - cpvsLightReal(CPVS_LIGHT_POSITION + 2u);
  precise double distance = sqrt((tx * tx + ty * ty) + tz * tz);
  double range = cpvsLightReal(CPVS_LIGHT_RANGE);
  if ((shape & CPVS_SHAPE_CONE) != 0u) {  // insideSpot
    precise double along = (tx * cpvsLightReal(CPVS_LIGHT_DIRECTION) + ty * cpvsLightReal(CPVS_LIGHT_DIRECTION + 1u)) +
                           tz * cpvsLightReal(CPVS_LIGHT_DIRECTION + 2u);
    precise double cosine = along / distance;
    bool inside = distance <= range && distance != 0.0LF && !(cosine < cpvsLightReal(CPVS_LIGHT_COS_OUTER));
    return inside ? 0 : -1;
  }
  if (!(distance <= range)) return -1;  // selectView: the one view, or the major axis's cube face
  if ((shape & CPVS_SHAPE_CUBE_FACES) == 0u) return 0;
  dvec3 m = abs(dvec3(tx, ty, tz));
  uint axis = m.x >= m.y && m.x >= m.z ? 0u : (m.y >= m.z ? 1u : 2u);
  double along = axis == 0u ? tx : (axis == 1u ? ty : tz);
  return cpvsFaceView(2u * axis + (along < 0.0LF ? 1u : 0u));
}

// cellVerdict for the selected view: kernelHalf = K / 2, margin in voxels, normals as given (a back face is 0).
CpvsCell cpvsLookupCell(dvec3 p, dvec3 n, double kernelHalf, double margin) {
  CpvsCell cell;
  cell.verdict = CPVS_CELL_ZERO;
  cell.voxel = ivec3(0);
  cell.slice = 0.0LF;
  bool valid = cpvsFinite(p.x) && cpvsFinite(p.y) && cpvsFinite(p.z) && cpvsFinite(n.x) && cpvsFinite(n.y) &&
               cpvsFinite(n.z);
  if (!valid) return cell;
  uint flags = cpvsMappingFlags();
  if ((flags & CPVS_FLAG_EMPTY) != 0u) {
    cell.verdict = CPVS_CELL_LIT;
    return cell;
  }
  bool orthographic = (flags & CPVS_FLAG_ORTHOGRAPHIC) != 0u;
  bool linearDepth = (flags & CPVS_FLAG_LINEAR) != 0u;
  // mapToGrid
  precise double viewX = (cpvsMappingReal(0u) * p.x + cpvsMappingReal(1u) * p.y) + (cpvsMappingReal(2u) * p.z + cpvsMappingReal(3u));
  precise double viewY = (cpvsMappingReal(4u) * p.x + cpvsMappingReal(5u) * p.y) + (cpvsMappingReal(6u) * p.z + cpvsMappingReal(7u));
  precise double viewZ = (cpvsMappingReal(8u) * p.x + cpvsMappingReal(9u) * p.y) + (cpvsMappingReal(10u) * p.z + cpvsMappingReal(11u));
  precise double d = -viewZ;
  precise double invDepth = 1.0LF;
  precise double a = viewX;
  precise double b = viewY;
  bool inFront = true;
  if (!orthographic) {
    invDepth = 1.0LF / d;
    a = viewX * invDepth;
    b = viewY * invDepth;
    inFront = d > 0.0LF;
  }
  precise double u = (a - cpvsMappingReal(CPVS_MAP_XMIN)) * cpvsMappingReal(CPVS_MAP_USCALE);
  precise double v = (b - cpvsMappingReal(CPVS_MAP_YMIN)) * cpvsMappingReal(CPVS_MAP_VSCALE);
  precise double s;
  if (linearDepth) {
    s = (d - cpvsMappingReal(CPVS_MAP_NEAR)) * cpvsMappingReal(CPVS_MAP_SSCALE);
  } else {
    precise double scaled = d * cpvsMappingReal(CPVS_MAP_INVNEAR);
    precise double logSlice = cpvsMappingLog(scaled) * cpvsMappingReal(CPVS_MAP_SSCALE);
    s = d > 0.0LF ? logSlice : packDouble2x32(uvec2(0u, 0xFFF00000u));  // -inf
  }
  if (!inFront) {
    cell.verdict = CPVS_CELL_LIT;
    return cell;
  }
  // gridNormalLanes
  precise double nvx = (cpvsMappingReal(0u) * n.x + cpvsMappingReal(1u) * n.y) + cpvsMappingReal(2u) * n.z;
  precise double nvy = (cpvsMappingReal(4u) * n.x + cpvsMappingReal(5u) * n.y) + cpvsMappingReal(6u) * n.z;
  precise double nvz = (cpvsMappingReal(8u) * n.x + cpvsMappingReal(9u) * n.y) + cpvsMappingReal(10u) * n.z;
  precise double invDs = linearDepth ? cpvsMappingReal(CPVS_MAP_INVDS) : cpvsMappingReal(CPVS_MAP_INVDS) * d;
  precise double mx, my, mz;
  if (orthographic) {
    mx = nvx * cpvsMappingReal(CPVS_MAP_USTEP);
    my = nvy * cpvsMappingReal(CPVS_MAP_VSTEP);
    mz = -nvz * invDs;
  } else {
    mx = (nvx * d) * cpvsMappingReal(CPVS_MAP_USTEP);
    my = (nvy * d) * cpvsMappingReal(CPVS_MAP_VSTEP);
    mz = ((nvx * viewX + nvy * viewY) * invDepth - nvz) * invDs;
  }
  if (mz > 0.0LF) return cell;  // back face: in the shadow of its own surface
  // cellLanes
  precise double length2 = (mx * mx + my * my) + mz * mz;
  bool biased = length2 > 0.0LF && length2 <= 1.7976931348623157e308LF;
  precise double root = sqrt(length2);
  precise double inv = biased ? 1.0LF / root : 0.0LF;
  precise double ux = mx * inv;
  precise double uy = my * inv;
  precise double uz = mz * inv;
  precise double bias = kernelHalf * (abs(ux) + abs(uy)) + margin;
  precise double qu = u + bias * ux;
  precise double qv = v + bias * uy;
  precise double qs = s + bias * uz;
  double resolution = cpvsMappingReal(CPVS_MAP_RESOLUTION);
  bool inside = qu >= 0.0LF && qu < resolution && qv >= 0.0LF && qv < resolution;
  if (!inside) {
    cell.verdict = CPVS_CELL_LIT;
    return cell;
  }
  double maxIndex = resolution - 1.0LF;
  double z = qs >= 0.0LF ? (qs < maxIndex ? qs : maxIndex) : 0.0LF;  // clampedSlice (NaN: 0)
  cell.verdict = CPVS_CELL_VOXEL;
  cell.voxel = ivec3(int(qu), int(qv), int(z));
  cell.slice = qs;
  return cell;
}
