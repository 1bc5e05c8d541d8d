// The foliage level: alpha-tested leaf cards placed by GPU instancing, beside glass that casts no shadow.
//
// Layout (400 x 400 units, y up, centred on the origin): a ground quad; two streets 12 units wide along
// the x and z axes; a clearing in each quadrant; 6 to 12 closed box buildings (opaque) off the streets and
// clearings, with a glass ribbon window per floor on every facade and, for some, a glass canopy on two posts
// over the street side (the glass is alphaMode BLEND, alpha 0.15, untextured). Trees fill the rest: 3 tree
// prototypes, each a closed hexagonal trunk (opaque) and a crown of 24 to 56 double-sided leaf cards (two
// triangles each, alphaMode MASK with a generated leaf-cluster texture), each prototype placed by one trunk
// node and one crown node carrying the same EXT_mesh_gpu_instancing instances (random yaw, uniform scale
// 0.8 .. 1.3). The number of trees meets the triangle budget. Lights: a sun along (0.4, -1, 0.3) and spot
// lights above the streets and clearings pointing down.
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "det_math.h"
#include "generators.h"
#include "mesh_builder.h"
#include "png_writer.h"

namespace cpvs::scenegen {
namespace {

constexpr double kHalf = 200.0;        // the ground spans [-200, 200] in x and z
constexpr double kStreetHalf = 6.0;    // streets: |z| < 6 and |x| < 6
constexpr double kTreeLimit = 190.0;   // tree trunks stay inside [-190, 190]
constexpr double kBuildingBase = -0.5; // closed buildings start below the ground
constexpr int kPrototypes = 3;
constexpr int kLeafTexture = 256;

enum Material { kGrass, kConcrete, kGlass, kBark, kLeaves };

struct Clearing {
  glm::dvec2 centre;
  double radius;
};

struct Building {
  double x0, z0, x1, z1, h;
};

struct TreePrototype {
  GenMesh trunk, crown;
};

// A quad p0 p1 p2 p3 (a convex loop), wound counter-clockwise seen from the side `normal` points to.
void addQuad(GenMesh& m, glm::dvec3 p0, glm::dvec3 p1, glm::dvec3 p2, glm::dvec3 p3, const glm::dvec3& normal) {
  if (glm::dot(glm::cross(p1 - p0, p2 - p0), normal) < 0.0) std::swap(p1, p3);
  const std::uint32_t base = static_cast<std::uint32_t>(m.positions.size());
  for (const glm::dvec3& p : {p0, p1, p2, p3}) m.positions.emplace_back(p);
  for (const std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
}

// The leaf-cluster texture: leaves (ellipses in random places, sizes and directions, wrapping around the
// edges so the texture tiles) with alpha 255, added until half the texels are covered; alpha 0 elsewhere.
// Returns the RGBA texels and the covered share.
std::pair<std::vector<std::uint8_t>, double> leafTexture(std::uint64_t seed) {
  constexpr int n = kLeafTexture;
  std::vector<std::uint8_t> rgba(static_cast<std::size_t>(n) * n * 4);
  for (std::size_t i = 0; i < rgba.size(); i += 4) {  // clear texels carry the mean leaf colour (for filtering)
    rgba[i] = 60;
    rgba[i + 1] = 112;
    rgba[i + 2] = 40;
    rgba[i + 3] = 0;
  }
  Rng rng(hash64(seed, 0x4C454146ULL));  // "LEAF"
  std::size_t covered = 0;
  const std::size_t target = static_cast<std::size_t>(n) * n / 2;
  for (int leaf = 0; leaf < 4000 && covered < target; ++leaf) {
    const double cx = rng.uniform(0.0, n), cy = rng.uniform(0.0, n);
    const double a = rng.uniform(16.0, 34.0);  // half length
    const double b = a * rng.uniform(0.32, 0.5);  // half width
    const SinCos dir = detSinCos(rng.uniform(0.0, kPi));
    const double red = rng.uniform(35.0, 80.0), green = rng.uniform(95.0, 150.0), blue = rng.uniform(20.0, 55.0);
    const int x0 = static_cast<int>(cx - a) - 1, x1 = static_cast<int>(cx + a) + 1;
    const int y0 = static_cast<int>(cy - a) - 1, y1 = static_cast<int>(cy + a) + 1;
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
        const double along = dx * dir.c + dy * dir.s, across = -dx * dir.s + dy * dir.c;
        const double q = (along / a) * (along / a) + (across / b) * (across / b);
        if (q > 1.0) continue;
        const int px = ((x % n) + n) % n, py = ((y % n) + n) % n;
        std::uint8_t* t = &rgba[4 * (static_cast<std::size_t>(py) * n + static_cast<std::size_t>(px))];
        if (t[3] == 0) ++covered;
        // Lighter towards the tip, darker at the rim and along the midrib.
        double shade = 0.75 + 0.3 * (0.5 + 0.5 * along / a) - 0.15 * q;
        if (across < 0.7 && across > -0.7) shade *= 0.75;
        t[0] = static_cast<std::uint8_t>(std::min(255.0, red * shade + 0.5));
        t[1] = static_cast<std::uint8_t>(std::min(255.0, green * shade + 0.5));
        t[2] = static_cast<std::uint8_t>(std::min(255.0, blue * shade + 0.5));
        t[3] = 255;
      }
    }
  }
  return {std::move(rgba), static_cast<double>(covered) / (static_cast<double>(n) * n)};
}

// Tree prototype `index`: a hexagonal trunk and a crown of leaf cards in an ellipsoid above it.
TreePrototype buildTree(std::uint64_t seed, int index) {
  Rng rng(hash64(seed, 0x54524545ULL, static_cast<std::uint64_t>(index)));  // "TREE"
  const double trunkRadius = rng.uniform(0.25, 0.4);
  const double trunkHeight = rng.uniform(2.5, 4.5);
  const double rx = rng.uniform(2.2, 3.5), ry = rng.uniform(2.5, 4.0);
  const double cy = trunkHeight + 0.8 * ry;
  const int cards = rng.range(24, 56);
  const double half = rng.uniform(0.9, 1.4);

  TreePrototype t;
  MeshBuilder trunk(false, false);
  trunk.prism(circlePolygon(glm::dvec2(0.0), trunkRadius, 6), -0.3, cy);
  t.trunk = trunk.take("tree_" + std::to_string(index) + "_trunk");
  t.trunk.material = kBark;

  GenMesh& m = t.crown;
  m.name = "tree_" + std::to_string(index) + "_crown";
  m.material = kLeaves;
  const glm::dvec3 up(0.0, 1.0, 0.0), side(1.0, 0.0, 0.0);
  for (int c = 0; c < cards; ++c) {
    glm::dvec3 p;
    do {
      p = {rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)};
    } while (glm::dot(p, p) > 1.0);
    const glm::dvec3 centre(p.x * rx, cy + p.y * ry, p.z * rx);
    glm::dvec3 normal;
    do {
      normal = {rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)};
    } while (glm::dot(normal, normal) > 1.0 || glm::dot(normal, normal) < 1e-4);
    normal = glm::normalize(normal);
    const glm::dvec3 u0 = glm::normalize(glm::cross(std::abs(normal.y) < 0.9 ? up : side, normal));
    const glm::dvec3 v0 = glm::cross(normal, u0);
    const SinCos spin = detSinCos(rng.uniform(0.0, 2.0 * kPi));
    const glm::dvec3 u = half * (spin.c * u0 + spin.s * v0), v = half * (spin.c * v0 - spin.s * u0);
    // Corners counter-clockwise about `normal` (u x v points along it), uv covering [0, 1]^2.
    const std::uint32_t base = static_cast<std::uint32_t>(m.positions.size());
    const glm::dvec3 corners[4] = {centre - u - v, centre + u - v, centre + u + v, centre - u + v};
    const glm::vec2 uvs[4] = {{0.0f, 1.0f}, {1.0f, 1.0f}, {1.0f, 0.0f}, {0.0f, 0.0f}};
    for (int k = 0; k < 4; ++k) {
      m.positions.emplace_back(corners[k]);
      m.texcoords.push_back(uvs[k]);
    }
    for (const std::uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
  }
  return t;
}

bool overlaps(const Building& b, double x0, double z0, double x1, double z1) {
  return b.x0 < x1 && x0 < b.x1 && b.z0 < z1 && z0 < b.z1;
}

bool inStreet(double x, double z, double margin) {
  return std::abs(x) < kStreetHalf + margin || std::abs(z) < kStreetHalf + margin;
}

bool inClearing(const std::vector<Clearing>& clearings, double x, double z, double margin) {
  for (const Clearing& c : clearings) {
    const double dx = x - c.centre.x, dz = z - c.centre.y, r = c.radius + margin;
    if (dx * dx + dz * dz < r * r) return true;
  }
  return false;
}

std::vector<Clearing> placeClearings(Rng& layout) {
  // One per quadrant.
  std::vector<Clearing> clearings;
  for (int q = 0; q < 4; ++q) {
    const double sx = (q & 1) ? 1.0 : -1.0, sz = (q & 2) ? 1.0 : -1.0;
    clearings.push_back({{sx * layout.uniform(50.0, 150.0), sz * layout.uniform(50.0, 150.0)},
                         layout.uniform(12.0, 20.0)});
  }
  return clearings;
}

std::vector<Building> placeBuildings(Rng& layout, const std::vector<Clearing>& clearings) {
  // Buildings: boxes centred in [-165, 165]^2, at least 4 units off the streets and clearings and 10 apart.
  std::vector<Building> buildings;
  const int wanted = layout.range(6, 12);
  for (int attempt = 0; attempt < 2000 && static_cast<int>(buildings.size()) < wanted; ++attempt) {
    const double w = layout.uniform(12.0, 24.0), d = layout.uniform(12.0, 24.0);
    const double cx = layout.uniform(-165.0, 165.0), cz = layout.uniform(-165.0, 165.0);
    const Building b{cx - 0.5 * w, cz - 0.5 * d, cx + 0.5 * w, cz + 0.5 * d, layout.uniform(8.0, 30.0)};
    bool ok = !(b.x0 < kStreetHalf + 4.0 && b.x1 > -kStreetHalf - 4.0) &&
              !(b.z0 < kStreetHalf + 4.0 && b.z1 > -kStreetHalf - 4.0);
    for (const Clearing& c : clearings) {  // the clearing's circle against the box grown by 4
      const double px = std::clamp(c.centre.x, b.x0 - 4.0, b.x1 + 4.0), pz = std::clamp(c.centre.y, b.z0 - 4.0, b.z1 + 4.0);
      const double dx = px - c.centre.x, dz = pz - c.centre.y;
      if (dx * dx + dz * dz < c.radius * c.radius) ok = false;
    }
    for (const Building& other : buildings)
      if (overlaps(other, b.x0 - 10.0, b.z0 - 10.0, b.x1 + 10.0, b.z1 + 10.0)) ok = false;
    if (ok) buildings.push_back(b);
  }

  return buildings;
}

// The ground and the buildings' meshes, with their windows and canopies, as nodes of their own; returns the
// footprints trees avoid (buildings and their canopies) and adds the triangles to `triangles`.
std::vector<Building> addGroundAndBuildings(GenScene& scene, const std::vector<Building>& buildings, Rng& layout,
                                            std::uint64_t& triangles) {
  GenMesh ground;
  ground.name = "Ground";
  ground.material = kGrass;
  addQuad(ground, {kHalf, 0.0, -kHalf}, {-kHalf, 0.0, -kHalf}, {-kHalf, 0.0, kHalf}, {kHalf, 0.0, kHalf},
          {0.0, 1.0, 0.0});
  MeshBuilder solid(false, false);
  GenMesh windows, canopies;
  windows.name = "Windows";
  windows.material = kGlass;
  canopies.name = "GlassCanopies";
  canopies.material = kGlass;
  std::vector<Building> keepOut;  // footprints trees avoid: buildings and their canopies
  for (std::size_t i = 0; i < buildings.size(); ++i) {
    const Building& b = buildings[i];
    solid.box({b.x0, kBuildingBase, b.z0}, {b.x1, b.h, b.z1});
    keepOut.push_back(b);
    // A ribbon window per floor on each facade, 0.05 in front of the wall.
    constexpr double e = 0.05;
    for (double f = 0.0; f + 2.4 < b.h - 1.0; f += 3.5) {
      const double ya = f + 1.0, yb = f + 2.4;
      const double xa = b.x0 + 1.0, xb = b.x1 - 1.0, za = b.z0 + 1.0, zb = b.z1 - 1.0;
      addQuad(windows, {xa, ya, b.z0 - e}, {xb, ya, b.z0 - e}, {xb, yb, b.z0 - e}, {xa, yb, b.z0 - e}, {0, 0, -1});
      addQuad(windows, {xa, ya, b.z1 + e}, {xb, ya, b.z1 + e}, {xb, yb, b.z1 + e}, {xa, yb, b.z1 + e}, {0, 0, 1});
      addQuad(windows, {b.x0 - e, ya, za}, {b.x0 - e, ya, zb}, {b.x0 - e, yb, zb}, {b.x0 - e, yb, za}, {-1, 0, 0});
      addQuad(windows, {b.x1 + e, ya, za}, {b.x1 + e, ya, zb}, {b.x1 + e, yb, zb}, {b.x1 + e, yb, za}, {1, 0, 0});
    }
    // A glass canopy over the facade that faces the nearer street (always on the first building), 4 units
    // deep at y = 3.2, on two posts at its outer corners.
    if (i == 0 || layout.chance(0.5)) {
      const double cx = 0.5 * (b.x0 + b.x1), cz = 0.5 * (b.z0 + b.z1);
      constexpr double depth = 4.0, y = 3.2, post = 0.12;
      // The canopy on the facade facing the nearer street: written for the x-axis street (z = 0), with "along"
      // the street's axis and "across" the other; the z-axis street is the same with x and z swapped.
      const bool xStreet = std::abs(cz) < std::abs(cx);
      const double along0 = xStreet ? b.x0 : b.z0, along1 = xStreet ? b.x1 : b.z1;
      const double across0 = xStreet ? b.z0 : b.x0, across1 = xStreet ? b.z1 : b.x1;
      const double alongCentre = xStreet ? cx : cz, acrossCentre = xStreet ? cz : cx;
      const double w = 0.3 * (along1 - along0);
      const double a0 = alongCentre - w, a1 = alongCentre + w;
      const double c0 = acrossCentre > 0.0 ? across0 - depth : across1;
      const double c1 = acrossCentre > 0.0 ? across0 : across1 + depth;
      const double co = acrossCentre > 0.0 ? c0 + 0.2 : c1 - 0.2;
      const auto toXz = [&](double along, double across) {
        return xStreet ? glm::dvec2(along, across) : glm::dvec2(across, along);
      };
      const glm::dvec2 lo = toXz(a0, c0), hi = toXz(a1, c1);
      const double x0 = lo.x, z0 = lo.y, x1 = hi.x, z1 = hi.y;
      const glm::dvec2 p0 = toXz(a0 + 0.2, co), p1 = toXz(a1 - 0.2, co);  // the posts
      addQuad(canopies, {x1, y, z0}, {x0, y, z0}, {x0, y, z1}, {x1, y, z1}, {0.0, 1.0, 0.0});
      for (const glm::dvec2& p : {p0, p1})
        solid.box({p.x - post, kBuildingBase, p.y - post}, {p.x + post, y, p.y + post});
      keepOut.push_back({x0, z0, x1, z1, y});
    }
  }
  GenMesh buildingMesh = solid.take("Buildings");
  buildingMesh.material = kConcrete;

  for (GenMesh* m : {&ground, &buildingMesh, &windows, &canopies}) {
    if (m->indices.empty()) continue;
    triangles += m->triangles();
    GenNode n;
    n.name = m->name;
    n.mesh = static_cast<int>(scene.meshes.size());
    scene.nodes.push_back(n);
    scene.meshes.push_back(std::move(*m));
  }

  return keepOut;
}

// Trees until the budget is met (the last tree may overshoot it by at most half a tree), each prototype's
// instances on one node per mesh; returns the number of trees and sets the number of prototypes used.
int plantTrees(GenScene& scene, const FoliageOptions& o, const std::vector<Clearing>& clearings,
               const std::vector<Building>& keepOut, std::uint64_t& triangles, int& usedPrototypes) {
  std::vector<TreePrototype> protos;
  for (int k = 0; k < kPrototypes; ++k) protos.push_back(buildTree(o.seed, k));
  std::vector<std::vector<GenInstance>> placed(kPrototypes);
  Rng forest(hash64(o.seed, 0x464F52455354ULL));  // "FOREST"
  int trees = 0;
  while (trees < 2000000) {
    const int k = forest.range(0, kPrototypes - 1);
    const std::uint64_t cost = protos[static_cast<std::size_t>(k)].trunk.triangles() +
                               protos[static_cast<std::size_t>(k)].crown.triangles();
    if (triangles + cost / 2 > o.targetTriangles) break;
    double x = 0.0, z = 0.0;
    for (int attempt = 0; attempt < 1000; ++attempt) {
      x = forest.uniform(-kTreeLimit, kTreeLimit);
      z = forest.uniform(-kTreeLimit, kTreeLimit);
      bool ok = !inStreet(x, z, 3.0) && !inClearing(clearings, x, z, 2.0);
      for (const Building& b : keepOut)
        if (ok && overlaps(b, x - 6.0, z - 6.0, x + 6.0, z + 6.0)) ok = false;
      if (ok) break;
    }
    const Quat yaw = rotationAboutY(forest.uniform(0.0, 2.0 * kPi));
    GenInstance in = instanceOf({x, 0.0, z}, yaw);
    in.scale = glm::vec3(static_cast<float>(forest.uniform(0.8, 1.3)));
    placed[static_cast<std::size_t>(k)].push_back(in);
    triangles += cost;
    ++trees;
  }
  usedPrototypes = 0;
  for (int k = 0; k < kPrototypes; ++k) {
    std::vector<GenInstance>& instances = placed[static_cast<std::size_t>(k)];
    if (instances.empty()) continue;  // an instanced node needs at least one instance
    ++usedPrototypes;
    for (GenMesh* m : {&protos[static_cast<std::size_t>(k)].trunk, &protos[static_cast<std::size_t>(k)].crown}) {
      GenNode n;
      n.name = m->name;
      n.mesh = static_cast<int>(scene.meshes.size());
      n.instances = instances;
      scene.nodes.push_back(std::move(n));
      scene.meshes.push_back(std::move(*m));
    }
  }

  return trees;
}

void addLights(GenScene& scene, const FoliageOptions& o, const std::vector<Clearing>& clearings) {
  // The sun, then the spots: above the streets (every 30 units) and the clearings' centres, shuffled.
  GenLight sun;
  sun.name = "sun";
  sun.intensity = 1.0;  // lux
  sun.color = {1.0, 0.96, 0.9};
  scene.lights.push_back(sun);
  GenNode sunNode;
  sunNode.name = "sun";
  sunNode.light = 0;
  sunNode.translation = {0.0, 200.0, 0.0};
  sunNode.rotation = rotationFromMinusZ({0.4, -1.0, 0.3});
  scene.nodes.push_back(sunNode);

  std::vector<glm::dvec2> spots;
  std::vector<int> alongX;  // 1: on the x-axis street, 0: on the z-axis street, -1: a clearing
  for (int k = 0; k <= 12; ++k) {
    const double t = -180.0 + 30.0 * k;
    spots.push_back({t, 0.0});
    alongX.push_back(1);
    if (t != 0.0) {
      spots.push_back({0.0, t});
      alongX.push_back(0);
    }
  }
  for (const Clearing& c : clearings) {
    spots.push_back(c.centre);
    alongX.push_back(-1);
  }
  Rng lights(hash64(o.seed, 0x53504F54ULL));  // "SPOT"
  const std::vector<std::size_t> order = lights.shuffledOrder(spots.size());
  for (int i = 0; i < o.spotLights; ++i) {
    const std::size_t c = order[static_cast<std::size_t>(i) % order.size()];
    glm::dvec2 p = spots[c];
    if (alongX[c] == 1) p.x += lights.uniform(-10.0, 10.0);
    if (alongX[c] == 0) p.y += lights.uniform(-10.0, 10.0);
    if (alongX[c] == -1) p += glm::dvec2(lights.uniform(-4.0, 4.0), lights.uniform(-4.0, 4.0));
    const double h = lights.uniform(14.0, 20.0);
    const double tilt = lights.uniform(0.0, 0.25);
    const SinCos st = detSinCos(tilt), sa = detSinCos(lights.uniform(0.0, 2.0 * kPi));
    GenLight l;
    l.name = "spot_" + std::to_string(i);
    l.type = GenLight::Type::Spot;
    l.color = {1.0, 0.9, 0.75};
    l.intensity = 200.0;  // candela: about 0.5 .. 1 lux on the ground below, beside the 1-lux sun
    l.range = 60.0;
    l.outerConeAngle = 0.7;
    l.innerConeAngle = 0.5;
    GenNode n;
    n.name = l.name;
    n.light = static_cast<int>(scene.lights.size());
    n.translation = {p.x, h, p.y};
    n.rotation = rotationFromMinusZ({st.s * sa.c, -st.c, st.s * sa.s});
    scene.lights.push_back(l);
    scene.nodes.push_back(n);
  }
}

}  // namespace

GenScene generateFoliage(const FoliageOptions& o, FoliageInfo* info) {
  Rng layout(hash64(o.seed, 0x464F4C49ULL));  // "FOLI"
  GenScene scene;

  // Materials (indices as in the enum above) and the leaf texture.
  scene.materials = {opaqueMaterial("Grass", {0.30, 0.42, 0.20, 1.0}), opaqueMaterial("Concrete", {0.62, 0.6, 0.56, 1.0}),
                     blendedMaterial("Glass", {0.6, 0.8, 0.9, 0.15}), opaqueMaterial("Bark", {0.33, 0.24, 0.16, 1.0}),
                     alphaTestedMaterial("Leaves", 0)};
  auto [texels, coverage] = leafTexture(o.seed);
  GenTexture leafTex;
  leafTex.name = "LeafCluster";
  leafTex.png = encodePngRgba(kLeafTexture, kLeafTexture, texels);
  scene.textures.push_back(std::move(leafTex));

  const std::vector<Clearing> clearings = placeClearings(layout);
  const std::vector<Building> buildings = placeBuildings(layout, clearings);
  std::uint64_t triangles = 0;
  const std::vector<Building> keepOut = addGroundAndBuildings(scene, buildings, layout, triangles);
  int usedPrototypes = 0;
  const int trees = plantTrees(scene, o, clearings, keepOut, triangles, usedPrototypes);
  addLights(scene, o, clearings);

  if (info) {
    info->trees = trees;
    info->prototypes = usedPrototypes;
    info->buildings = static_cast<int>(buildings.size());
    info->leafCoverage = coverage;
  }
  return scene;
}

}  // namespace cpvs::scenegen
