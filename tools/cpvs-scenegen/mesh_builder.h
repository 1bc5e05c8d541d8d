#pragma once
// Appends solids to a triangle mesh. Conventions (the baker relies on them, tests check them):
//  * y is up; every closed solid is watertight (each edge in exactly two triangles, opposite directions)
//    and its triangles are counter-clockwise seen from outside (outward normals);
//  * "open" builders drop every horizontal cap (floors, flat roofs, setback terraces), so that nothing
//    they produce is closed; sloped faces (roofs, domes, spires) are kept;
//  * a builder in count-only mode does the same work but stores nothing, which lets the city generator
//    size its layout to a triangle budget cheaply and exactly.
// Footprint polygons are convex and given in "up order": the fan (p0, p1, p2) at constant y faces +y.
// In (x, z) that is the order (x1, z0) -> (x0, z0) -> (x0, z1) -> (x1, z1) for a rectangle.
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "gen_scene.h"

namespace cpvs::scenegen {

using Polygon = std::vector<glm::dvec2>;  // (x, z)

Polygon rectPolygon(double x0, double z0, double x1, double z1);
Polygon circlePolygon(glm::dvec2 centre, double radius, int sides, double phase = 0.0);
Polygon scaled(const Polygon& p, glm::dvec2 centre, double s);

// One horizontal ring of a loft: the polygon at height y.
struct Ring {
  Polygon polygon;
  double y = 0.0;
};

enum class Top { Flat, Apex };

class MeshBuilder {
 public:
  MeshBuilder(bool open, bool countOnly) : open_(open), countOnly_(countOnly) {}

  bool open() const { return open_; }
  std::uint64_t triangles() const { return triangles_; }

  // Positions are stored relative to this point (the translation of the node that will show the mesh).
  void setOrigin(const glm::dvec3& origin) { origin_ = origin; }

  std::uint32_t vertex(const glm::dvec3& p);
  void triangle(std::uint32_t a, std::uint32_t b, std::uint32_t c);

  // A closed solid swept through `rings` (same vertex count, bottom to top, y non-decreasing; rings at
  // equal y must be nested, the upper one inside). Bottom cap, side bands, then a flat top cap or an
  // apex at `apex` (x, y, z). Open mode: no caps, no horizontal bands.
  void loft(const std::vector<Ring>& rings, Top top, const glm::dvec3& apex = glm::dvec3(0.0));
  void box(const glm::dvec3& lo, const glm::dvec3& hi);
  // Vertical prism over `footprint` from y0 to y1 with a flat top.
  void prism(const Polygon& footprint, double y0, double y1);
  // A house with walls x0..x1, z0..z1 from y0 to y1 and a gable roof of height roofHeight whose ridge
  // runs along x (ridgeAlongX) or along z.
  void gableHouse(double x0, double z0, double x1, double z1, double y0, double y1, double roofHeight,
                  bool ridgeAlongX);

  // Moves the data out into a mesh (the builder is left empty).
  GenMesh take(std::string name);

 private:
  bool open_;
  bool countOnly_;
  glm::dvec3 origin_{0.0};
  std::uint32_t vertexCount_ = 0;
  std::uint64_t triangles_ = 0;
  std::vector<glm::vec3> positions_;
  std::vector<std::uint32_t> indices_;
};

}  // namespace cpvs::scenegen
