#include "libcpvs/raster/triangle_setup.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cpvs {

int depthMode(const LightView& view) {
  const bool logarithmic = view.mapping == DepthMapping::Logarithmic;
  if (view.projection == Projection::Orthographic) return logarithmic ? 1 : 0;
  return logarithmic ? 3 : 2;
}

TriangleSetup setUpTriangle(const LightView& view, const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2) {
  const double n = view.resolution, ex = view.xMax - view.xMin, ey = view.yMax - view.yMin;
  const bool perspective = view.projection == Projection::Perspective;
  const int mode = depthMode(view);
  const double nearClip = 0.5 * view.near;
  const double ortLinearScale = 1.0 / (view.far - view.near);
  constexpr double kLimit = double(1 << 24);
  auto qOfDepth = [&](double d) {
    if (mode == 0) return (d - view.near) * ortLinearScale;
    if (mode == 1) return d;
    return 1.0 / d;
  };
  const glm::dvec3 p[3] = {p0, p1, p2};
  TriangleSetup s;
  for (int k = 0; k < 3; ++k) {
    s.d[k] = -p[k].z;
    if (perspective && !(s.d[k] >= nearClip)) s.safe = false;
    const double a = perspective ? p[k].x / s.d[k] : p[k].x, b = perspective ? p[k].y / s.d[k] : p[k].y;
    s.u[k] = n * (a - view.xMin) / ex;
    s.v[k] = n * (b - view.yMin) / ey;
  }
  // Depth plane q(u, v) = k0 + ku u + kv v.
  const glm::dvec3 normal = glm::cross(p[1] - p[0], p[2] - p[0]);
  double k0 = 0, ku = 0, kv = 0;
  bool planar = false;
  if (!perspective) {
    if (normal.z != 0) {  // d = (nx x + ny y - c) / nz with x = xMin + u ex / N
      const double c = glm::dot(normal, p[0]);
      ku = normal.x * ex / (n * normal.z);
      kv = normal.y * ey / (n * normal.z);
      k0 = (normal.x * view.xMin + normal.y * view.yMin - c) / normal.z;
      if (mode == 0) {
        k0 = (k0 - view.near) * ortLinearScale;
        ku *= ortLinearScale;
        kv *= ortLinearScale;
      }
      planar = true;
    }
  } else {
    const double c = glm::dot(normal, p[0]);
    if (c != 0) {  // 1 / d = (nx a + ny b - nz) / c with a = xMin + u ex / N
      ku = normal.x * ex / (n * c);
      kv = normal.y * ey / (n * c);
      k0 = (normal.x * view.xMin + normal.y * view.yMin - normal.z) / c;
      planar = true;
    }
  }
  // Reference texel: the rounded centroid of the projected vertices in front of the light.
  double su = 0, sv = 0;
  int visible = 0;
  for (int k = 0; k < 3; ++k)
    if (!perspective || s.d[k] >= nearClip) {
      su += s.u[k];
      sv += s.v[k];
      ++visible;
    }
  s.u0 = visible ? std::clamp(std::round(su / visible), -kLimit, kLimit) : 0.0;
  s.v0 = visible ? std::clamp(std::round(sv / visible), -kLimit, kLimit) : 0.0;
  s.qMin = -std::numeric_limits<float>::max();
  s.qMax = std::numeric_limits<float>::max();
  if (s.safe) {
    s.qMin = std::min({qOfDepth(s.d[0]), qOfDepth(s.d[1]), qOfDepth(s.d[2])});
    s.qMax = std::max({qOfDepth(s.d[0]), qOfDepth(s.d[1]), qOfDepth(s.d[2])});
  }
  s.q0 = planar ? k0 + ku * s.u0 + kv * s.v0 : (s.safe ? s.qMin : 0.0);
  s.ku = planar ? ku : 0.0;
  s.kv = planar ? kv : 0.0;
  return s;
}

MaskInterpolation setUpMaskInterpolation(const LightView& view, const glm::dvec3 (&p)[3], const glm::dvec2 (&uv)[3]) {
  // Barycentric weight of corner i, up to a common factor, as an affine function L_i(a, b) of the ray's
  // lateral coordinates: orthographic rays (a, b, 0) + s (0, 0, -1) give the 2D cross product of the other two
  // corners around (a, b); perspective rays s (a, b, -1) give the volume (a, b, -1) . (p_j x p_k).
  const bool perspective = view.projection == Projection::Perspective;
  double La[3], Lb[3], Lc[3];
  for (int i = 0; i < 3; ++i) {
    const glm::dvec3 &A = p[(i + 1) % 3], &B = p[(i + 2) % 3];
    if (perspective) {
      const glm::dvec3 c = glm::cross(A, B);
      La[i] = c.x;
      Lb[i] = c.y;
      Lc[i] = -c.z;
    } else {
      La[i] = A.y - B.y;
      Lb[i] = B.x - A.x;
      Lc[i] = A.x * B.y - A.y * B.x;
    }
  }
  // (a, b) of view texel coordinates (x, y): a = xMin + x ex / N.
  const double n = view.resolution, sx = (view.xMax - view.xMin) / n, sy = (view.yMax - view.yMin) / n;
  MaskInterpolation m{};
  for (int i = 0; i < 3; ++i) {
    const double c0 = La[i] * view.xMin + Lb[i] * view.yMin + Lc[i], cx = La[i] * sx, cy = Lb[i] * sy;
    m.U[0] += c0 * uv[i].x;
    m.U[1] += cx * uv[i].x;
    m.U[2] += cy * uv[i].x;
    m.V[0] += c0 * uv[i].y;
    m.V[1] += cx * uv[i].y;
    m.V[2] += cy * uv[i].y;
    m.W[0] += c0;
    m.W[1] += cx;
    m.W[2] += cy;
  }
  return m;
}

DepthFunction::DepthFunction(const LightView& view) : mode(depthMode(view)) {
  const bool logarithmic = view.mapping == DepthMapping::Logarithmic;
  nearDepth = view.near;
  invNear = 1.0 / view.near;
  scale = logarithmic ? 1.0 / std::log2(view.far / view.near) : 1.0 / (view.far - view.near);
}

double DepthFunction::operator()(double q) const {
  double t;
  if (mode == 0) t = q;
  else if (mode == 1) t = std::log2(std::max(q * invNear, 1e-30)) * scale;
  else if (mode == 2) t = (1.0 / std::max(q, 1e-30) - nearDepth) * scale;
  else t = -std::log2(std::max(q * nearDepth, 1e-30)) * scale;
  return std::clamp(t, 0.0, 1.0);
}

}  // namespace cpvs
