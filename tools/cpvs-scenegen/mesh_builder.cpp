#include "mesh_builder.h"

#include <array>
#include <stdexcept>
#include <utility>

#include "det_math.h"

namespace cpvs::scenegen {

Polygon rectPolygon(double x0, double z0, double x1, double z1) {
  return {{x1, z0}, {x0, z0}, {x0, z1}, {x1, z1}};
}

Polygon circlePolygon(glm::dvec2 centre, double radius, int sides, double phase) {
  Polygon p;
  p.reserve(static_cast<std::size_t>(sides));
  for (int i = 0; i < sides; ++i) {
    // Angle increasing from +x towards -z is the up order.
    const SinCos sc = detSinCos(phase + 2.0 * kPi * static_cast<double>(i) / static_cast<double>(sides));
    p.push_back(centre + radius * glm::dvec2(sc.c, -sc.s));
  }
  return p;
}

Polygon scaled(const Polygon& p, glm::dvec2 centre, double s) {
  Polygon out;
  out.reserve(p.size());
  for (const glm::dvec2& v : p) out.push_back(centre + s * (v - centre));
  return out;
}

std::uint32_t MeshBuilder::vertex(const glm::dvec3& p) {
  if (!countOnly_) positions_.emplace_back(glm::vec3(p - origin_));
  if (vertexCount_ == 0xFFFFFFFFu) throw std::length_error("mesh has too many vertices for uint32 indices");
  return vertexCount_++;
}

void MeshBuilder::triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  ++triangles_;
  if (countOnly_) return;
  indices_.push_back(a);
  indices_.push_back(b);
  indices_.push_back(c);
}

void MeshBuilder::loft(const std::vector<Ring>& rings, Top top, const glm::dvec3& apex) {
  if (rings.size() < 2 && !(rings.size() == 1 && top == Top::Apex))
    throw std::logic_error("loft needs two rings, or one ring and an apex");
  const std::size_t n = rings.front().polygon.size();
  std::vector<std::uint32_t> first(rings.size());
  for (std::size_t k = 0; k < rings.size(); ++k) {
    if (rings[k].polygon.size() != n) throw std::logic_error("loft rings differ in vertex count");
    first[k] = vertexCount_;
    for (const glm::dvec2& p : rings[k].polygon) vertex({p.x, rings[k].y, p.y});
  }
  const auto at = [&](std::size_t ring, std::size_t i) {
    return first[ring] + static_cast<std::uint32_t>(i % n);
  };
  if (!open_) {
    for (std::size_t i = 1; i + 1 < n; ++i) triangle(at(0, 0), at(0, i + 1), at(0, i));  // faces -y
  }
  for (std::size_t k = 0; k + 1 < rings.size(); ++k) {
    if (open_ && rings[k].y == rings[k + 1].y) continue;  // a terrace: a horizontal cap
    for (std::size_t i = 0; i < n; ++i) {
      triangle(at(k, i), at(k, i + 1), at(k + 1, i + 1));
      triangle(at(k, i), at(k + 1, i + 1), at(k + 1, i));
    }
  }
  const std::size_t t = rings.size() - 1;
  if (top == Top::Apex) {
    const std::uint32_t a = vertex(apex);
    for (std::size_t i = 0; i < n; ++i) triangle(a, at(t, i), at(t, i + 1));
  } else if (!open_) {
    for (std::size_t i = 1; i + 1 < n; ++i) triangle(at(t, 0), at(t, i), at(t, i + 1));  // faces +y
  }
}

void MeshBuilder::box(const glm::dvec3& lo, const glm::dvec3& hi) {
  prism(rectPolygon(lo.x, lo.z, hi.x, hi.z), lo.y, hi.y);
}

void MeshBuilder::prism(const Polygon& footprint, double y0, double y1) {
  loft({Ring{footprint, y0}, Ring{footprint, y1}}, Top::Flat);
}

void MeshBuilder::gableHouse(double x0, double z0, double x1, double z1, double y0, double y1,
                             double roofHeight, bool ridgeAlongX) {
  const Polygon r = rectPolygon(x0, z0, x1, z1);
  std::array<std::uint32_t, 4> b{}, t{};
  for (int i = 0; i < 4; ++i) b[i] = vertex({r[i].x, y0, r[i].y});
  for (int i = 0; i < 4; ++i) t[i] = vertex({r[i].x, y1, r[i].y});
  // Ring edge i runs from corner i to corner i+1; edges 1 and 3 are the x = x0 / x = x1 faces.
  const int g = ridgeAlongX ? 1 : 0;  // the first gable edge; the other one is g + 2
  const auto mid = [&](int e) {
    const glm::dvec2 m = 0.5 * (r[e % 4] + r[(e + 1) % 4]);
    return glm::dvec3(m.x, y1 + roofHeight, m.y);
  };
  const std::uint32_t ra = vertex(mid(g));
  const std::uint32_t rb = vertex(mid(g + 2));
  const auto B = [&](int i) { return b[i % 4]; };
  const auto T = [&](int i) { return t[i % 4]; };
  if (!open_) {
    triangle(B(0), B(2), B(1));
    triangle(B(0), B(3), B(2));
  }
  for (int i = 0; i < 4; ++i) {
    triangle(B(i), B(i + 1), T(i + 1));
    triangle(B(i), T(i + 1), T(i));
  }
  triangle(T(g), T(g + 1), ra);      // gable triangles
  triangle(T(g + 2), T(g + 3), rb);
  triangle(T(g + 3), T(g), ra);      // roof slope over eave edge g + 3
  triangle(T(g + 3), ra, rb);
  triangle(T(g + 1), T(g + 2), rb);  // roof slope over eave edge g + 1
  triangle(T(g + 1), rb, ra);
}

GenMesh MeshBuilder::take(std::string name) {
  GenMesh m;
  m.name = std::move(name);
  m.positions = std::move(positions_);
  m.indices = std::move(indices_);
  positions_.clear();
  indices_.clear();
  vertexCount_ = 0;
  triangles_ = 0;
  return m;
}

}  // namespace cpvs::scenegen
