#pragma once
// One triangle of a view as both depth renderers see it: texel coordinates of its vertices and its depth as an
// affine function of the texel coordinates (docs/depth-maps.md, "Enter depth"). Shared by the GL renderer
// (which evaluates the plane in its fragment shader) and the CPU renderer, so both rasterise the same thing.
#include <cstdint>

#include <glm/glm.hpp>

#include "libcpvs/runtime/light_view.h"

namespace cpvs {

// depth mode: how q relates to depth d and to the normalised slice coordinate t
//  0: q = t (orthographic, linear)      1: q = d (orthographic, logarithmic)
//  2: q = 1/d (perspective, linear)     3: q = 1/d (perspective, logarithmic)
int depthMode(const LightView& view);

struct TriangleSetup {
  double u[3], v[3], d[3];  // texel coordinates (u, v) and view depth d of each vertex
  // Every vertex lies at d >= near / 2 (always for orthographic views); otherwise a perspective triangle must be
  // clipped at d = near / 2 before it is rasterised.
  bool safe = true;
  // q(u, v) = q0 + ku (u - u0) + kv (v - v0) around the integer reference texel (u0, v0), the rounded centroid of
  // the projected vertices; evaluations are clamped to [qMin, qMax] (the vertices' q; unbounded when not safe).
  double q0 = 0, ku = 0, kv = 0;
  double u0 = 0, v0 = 0;
  double qMin = 0, qMax = 0;
};

TriangleSetup setUpTriangle(const LightView& view, const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2);

// Where an alpha-tested triangle's mask is looked up (libcpvs/scene/coverage_mask.h): the coordinates of the
// point the ray through view texel coordinates (x, y) meets on the triangle's plane (texel centres at X + 0.5,
// as the GL renderer samples), uv = (U, V) / W with U, V and W affine in (x, y): exact barycentric
// interpolation for orthographic and perspective views alike, and the same for any clipped part.
struct MaskInterpolation {
  double U[3], V[3], W[3];  // value = c[0] + c[1] x + c[2] y
  // False where the ray runs in the triangle's plane (it then blocks light, the conservative answer).
  bool at(double x, double y, double& u, double& v) const {
    const double w = W[0] + W[1] * x + W[2] * y;
    if (w == 0.0) return false;
    u = (U[0] + U[1] * x + U[2] * y) / w;
    v = (V[0] + V[1] * x + V[2] * y) / w;
    return true;
  }
};
// p: the triangle's corners in view space, uv: their mask coordinates.
MaskInterpolation setUpMaskInterpolation(const LightView& view, const glm::dvec3 (&p)[3], const glm::dvec2 (&uv)[3]);

// t in [0, 1] of a q value (before the clamp to [qMin, qMax]).
struct DepthFunction {
  explicit DepthFunction(const LightView& view);
  double operator()(double q) const;
  int mode = 0;
  double nearDepth = 1, invNear = 1, scale = 1;
};

}  // namespace cpvs
