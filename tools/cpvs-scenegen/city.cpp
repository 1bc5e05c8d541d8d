// The closed city, the open city and the city with spot lights (Kämpe et al. 2015, §5, "ClosedCity").
//
// Layout: a square of 1000 x 1000 units centred on the origin, cut by streets into G x G blocks of L x L
// lots. A lot holds one building, chosen at random (taller near the centre):
//   * office    — box with vertical fins, horizontal ledges, roof units and sometimes a pyramid crown
//                 (all separate closed solids that intersect the body: exercises the union of solids);
//   * setback   — one watertight stepped tower (terraces between tiers), sometimes with a spire;
//   * complex   — two or three intersecting boxes (L/T shapes, a box stacked into another, a gable wing);
//   * round     — N-sided tower with a flat, conical or domed roof and balcony rings   } instanced
//   * gable/hip — houses with prism or pyramid roofs and chimneys                       } prototypes
// Unique buildings are merged into one mesh per district (a square of blocks); round towers and houses
// come from a small library of prototype meshes placed by instancing (translation + rotation about y).
// The ground is a separate mesh: a closed slab 2 units thick (open city: a single quad).
//
// The triangle budget is met by choosing the facade detail from the budget, then searching the number
// of lots per city side whose exact triangle count (a count-only run of the same code) is closest.
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "det_math.h"
#include "generators.h"
#include "mesh_builder.h"

namespace cpvs::scenegen {

glm::dvec3 sunDirection() { return glm::normalize(glm::dvec3(-0.4, -1.0, -0.3)); }

namespace {

constexpr double kHalf = 500.0;        // the city spans [-500, 500] in x and z
constexpr double kGroundHalf = 520.0;  // the ground slab reaches a little beyond
constexpr double kBase = -1.0;         // closed buildings start inside the ground slab (top at y = 0)

struct Detail {
  double lambda = 0.0;
  double finSpacing = 14.0;
  double ledgeSpacing = 45.0;
  int roundSides = 10;
  int domeRings = 2;
  int roofUnitsMax = 1;
  int maxTiers = 3;
};

// lambda = 0: plain boxes and coarse towers; 1: fins every 1.5 units, a ledge every 3.5, 36-sided
// towers (about the 1M city); 2: the finest a budget up to ~3.5M triangles uses (fins every 0.9). Continuous,
// so that the triangle count can be tuned finely. Beyond 2 (only for budgets the city cannot otherwise reach,
// such as a 10M-triangle level) the facades only grow finer: fins, ledges and round sides densify while tiers,
// domes and roofs stay as at 2, so the city keeps its shape.
constexpr double kMaxDetail = 2.0;
constexpr double kFinestDetail = 8.0;
Detail detailFor(double lambda) {
  Detail d;
  d.lambda = lambda;
  const double l = std::min(lambda, kMaxDetail);
  d.finSpacing = lambda <= kMaxDetail ? std::max(0.9, 14.0 / (1.0 + 8.33 * l)) : 0.9 * kMaxDetail / lambda;
  d.ledgeSpacing = lambda <= kMaxDetail ? std::max(2.0, 45.0 / (1.0 + 12.0 * l)) : 2.0 * kMaxDetail / lambda;
  d.roundSides = 10 + static_cast<int>(20.0 * lambda + 0.5);
  d.domeRings = 2 + static_cast<int>(2.0 * l + 0.5);
  d.roofUnitsMax = 1 + static_cast<int>(3.0 * l + 0.5);
  d.maxTiers = 3 + static_cast<int>(2.0 * l + 0.5);
  return d;
}

// The density for a budget: about 20 lots per city side at 20k triangles, growing with the cube root
// (about 74 at 1M: lots of ~10 units); the detail makes up the rest.
int lotsPerSideFor(std::uint64_t target) {
  const double ratio = static_cast<double>(target) / 2.0e4;
  int m = 4;
  while (m < 200) {
    const double q = (m + 0.5) / 20.0;
    if (q * q * q > ratio) break;
    ++m;
  }
  return m;
}

struct Layout {
  int lotsPerSide = 0;  // requested density
  int G = 1;            // blocks per side
  int L = 1;            // lots per block side
  double pitch = 0.0, street = 0.0, block = 0.0, alley = 0.0, lot = 0.0, margin = 0.0;
  int districtBlocks = 1;  // blocks per district side
  int districtsPerSide = 1;

  double blockMin(int b) const { return -kHalf + b * pitch + 0.5 * street; }
  double lotMin(int b, int l) const { return blockMin(b) + l * (lot + alley); }
};

Layout layoutFor(int lotsPerSide) {
  Layout y;
  y.lotsPerSide = lotsPerSide;
  y.L = lotsPerSide >= 24 ? 3 : (lotsPerSide >= 6 ? 2 : 1);
  y.G = std::max(1, (lotsPerSide + y.L / 2) / y.L);
  y.pitch = 2.0 * kHalf / y.G;
  y.street = std::clamp(0.15 * y.pitch, 3.0, 24.0);
  y.block = y.pitch - y.street;
  y.alley = y.L > 1 ? std::clamp(0.05 * y.block, 1.0, 4.0) : 0.0;
  y.lot = (y.block - (y.L - 1) * y.alley) / y.L;
  y.margin = 0.6 + 0.06 * y.lot;
  y.districtBlocks = (y.G + 7) / 8;
  y.districtsPerSide = (y.G + y.districtBlocks - 1) / y.districtBlocks;
  return y;
}

enum class ProtoKind { Round, Gable, Hip };

struct Prototype {
  ProtoKind kind;
  std::string name;
  MeshBuilder mesh;
  double height = 0.0;  // round towers only
};

struct Instance {
  int proto;
  glm::dvec3 position;
  double yaw;
};

struct CityBuild {
  std::vector<MeshBuilder> districts;
  std::vector<glm::dvec3> districtOrigins;
  std::vector<Prototype> protos;
  std::vector<int> protosOfKind[3];
  std::vector<Instance> instances;
  MeshBuilder ground{false, true};
  std::uint64_t triangles = 0;
};

// ---- buildings -------------------------------------------------------------------------------------

// Round prototype `index` of `count`: heights rise with the index (15..110), so that a site can pick among
// the ones short enough for it.
double buildRoundPrototype(MeshBuilder& m, Rng& rng, const Layout& y, const Detail& d, int index, int count) {
  const double avail = y.lot - 2.0 * y.margin;
  const double r = 0.5 * avail * rng.uniform(0.6, 0.95);
  const double h = 15.0 + 95.0 * (index + rng.unit()) / count;
  const int sides = d.roundSides + 2 * rng.range(0, 3);
  const double base = m.open() ? 0.0 : kBase;
  const glm::dvec2 c(0.0);
  const Polygon p = circlePolygon(c, r, sides);
  std::vector<Ring> rings{{p, base}, {p, h}};
  const int roof = rng.range(0, 2);
  if (roof == 0) {
    m.loft(rings, Top::Flat);
  } else if (roof == 1) {
    m.loft(rings, Top::Apex, {0.0, h + r * rng.uniform(0.6, 1.8), 0.0});
  } else {
    const double domeHeight = r * rng.uniform(0.5, 1.0);
    for (int k = 1; k <= d.domeRings; ++k) {
      const double phi = 0.5 * kPi * k / (d.domeRings + 1);
      const SinCos sc = detSinCos(phi);
      rings.push_back({scaled(p, c, sc.c), h + domeHeight * sc.s});
    }
    m.loft(rings, Top::Apex, {0.0, h + domeHeight, 0.0});
  }
  // Balcony rings: thin prisms slightly wider than the tower, intersecting it.
  if (rng.chance(0.4)) {
    const Polygon ring = circlePolygon(c, r + 0.5, sides);
    const double spacing = 3.0 * d.ledgeSpacing;
    for (double yy = spacing; yy + 0.4 < h - 2.0; yy += spacing) m.prism(ring, yy, yy + 0.4);
  }
  return h;
}

void addChimneys(MeshBuilder& m, Rng& rng, double x0, double z0, double x1, double z1, double wallTop,
                 double roofTop, int count) {
  for (int i = 0; i < count; ++i) {
    const double s = rng.uniform(0.5, 0.9);
    if (x1 - x0 < 2.0 * s + 2.0 || z1 - z0 < 2.0 * s + 2.0) return;
    const double cx = rng.uniform(x0 + 1.0 + s, x1 - 1.0 - s);
    const double cz = rng.uniform(z0 + 1.0 + s, z1 - 1.0 - s);
    m.box({cx - s, wallTop - 0.5, cz - s}, {cx + s, roofTop + rng.uniform(0.8, 2.0), cz + s});
  }
}

void buildHousePrototype(MeshBuilder& m, Rng& rng, const Layout& y, const Detail& d, bool gable) {
  const double avail = y.lot - 2.0 * y.margin;
  const double w = avail * rng.uniform(0.5, 1.0), dep = avail * rng.uniform(0.45, 0.9);
  const double x0 = -0.5 * w, x1 = 0.5 * w, z0 = -0.5 * dep, z1 = 0.5 * dep;
  const double wall = rng.uniform(4.0, 12.0);
  const double roof = std::min(w, dep) * rng.uniform(0.25, 0.6);
  const double base = m.open() ? 0.0 : kBase;
  if (gable) {
    m.gableHouse(x0, z0, x1, z1, base, wall, roof, w >= dep);
  } else {
    const Polygon p = rectPolygon(x0, z0, x1, z1);
    m.loft({{p, base}, {p, wall}}, Top::Apex, {0.0, wall + roof, 0.0});
  }
  addChimneys(m, rng, x0, z0, x1, z1, wall, wall + roof, rng.range(0, 1 + d.roofUnitsMax / 2));
}

void buildOffice(MeshBuilder& m, Rng& rng, const Detail& d, double x0, double z0, double x1, double z1,
                 double h) {
  const double base = m.open() ? 0.0 : kBase;
  const double finBase = m.open() ? 0.0 : -0.6;
  m.box({x0, base, z0}, {x1, h, z1});
  if (rng.chance(0.35 + 0.45 * std::min(1.0, d.lambda))) {  // vertical fins crossing the facades
    const double t = 0.18, out = 0.45, in = 0.25, top = h - 0.35;
    const int nx = static_cast<int>((x1 - x0) / d.finSpacing) - 1;
    for (int k = 1; k <= nx; ++k) {
      const double p = x0 + (x1 - x0) * k / (nx + 1);
      m.box({p - t, finBase, z0 - out}, {p + t, top, z0 + in});
      m.box({p - t, finBase, z1 - in}, {p + t, top, z1 + out});
    }
    const int nz = static_cast<int>((z1 - z0) / d.finSpacing) - 1;
    for (int k = 1; k <= nz; ++k) {
      const double p = z0 + (z1 - z0) * k / (nz + 1);
      m.box({x0 - out, finBase, p - t}, {x0 + in, top, p + t});
      m.box({x1 - in, finBase, p - t}, {x1 + out, top, p + t});
    }
  }
  if (rng.chance(0.3 + 0.4 * std::min(1.0, d.lambda))) {  // horizontal ledges all around
    const double o = 0.6;
    for (double yy = d.ledgeSpacing; yy + 0.5 < h - 1.5; yy += d.ledgeSpacing)
      m.box({x0 - o, yy, z0 - o}, {x1 + o, yy + 0.5, z1 + o});
  }
  if (x1 - x0 > 6.0 && z1 - z0 > 6.0) {  // roof units
    const int units = rng.range(0, d.roofUnitsMax);
    for (int i = 0; i < units; ++i) {
      const double sx = rng.uniform(1.5, std::min(4.0, 0.3 * (x1 - x0)));
      const double sz = rng.uniform(1.5, std::min(4.0, 0.3 * (z1 - z0)));
      const double ux = rng.uniform(x0 + 1.0, x1 - 1.0 - sx), uz = rng.uniform(z0 + 1.0, z1 - 1.0 - sz);
      m.box({ux, h - 0.4, uz}, {ux + sx, h + rng.uniform(1.0, 3.0), uz + sz});
    }
  }
  if (rng.chance(0.25)) {  // pyramid crown
    const double ix = (x1 - x0) * rng.uniform(0.12, 0.3), iz = (z1 - z0) * rng.uniform(0.12, 0.3);
    const Polygon p = rectPolygon(x0 + ix, z0 + iz, x1 - ix, z1 - iz);
    const double lift = rng.uniform(1.0, 3.0);
    const double peak = std::min(x1 - x0, z1 - z0) * rng.uniform(0.3, 0.9);
    m.loft({{p, h - 0.5}, {p, h + lift}}, Top::Apex, {0.5 * (x0 + x1), h + lift + peak, 0.5 * (z0 + z1)});
  }
}

void buildSetback(MeshBuilder& m, Rng& rng, const Detail& d, double x0, double z0, double x1, double z1,
                  double h) {
  const int tiers = rng.range(2, d.maxTiers);
  std::vector<Ring> rings;
  double y = m.open() ? 0.0 : kBase;
  double ax = x0, az = z0, bx = x1, bz = z1;
  double remaining = h;
  for (int t = 0; t < tiers; ++t) {
    const Polygon p = rectPolygon(ax, az, bx, bz);
    const double top = t + 1 == tiers ? h : y + remaining * rng.uniform(0.4, 0.65);
    rings.push_back({p, y});  // above the first tier: a terrace at the previous top
    rings.push_back({p, top});
    remaining = h - top;
    y = top;
    const double w = bx - ax, dd = bz - az;  // inset each side for the next tier
    ax += w * rng.uniform(0.06, 0.16);
    bx -= w * rng.uniform(0.06, 0.16);
    az += dd * rng.uniform(0.06, 0.16);
    bz -= dd * rng.uniform(0.06, 0.16);
  }
  if (rng.chance(0.4)) {
    const Polygon& last = rings.back().polygon;
    const glm::dvec2 c = 0.25 * (last[0] + last[1] + last[2] + last[3]);
    m.loft(rings, Top::Apex, {c.x, h + 0.25 * h * rng.uniform(0.3, 1.0), c.y});
  } else {
    m.loft(rings, Top::Flat);
  }
}

void buildComplex(MeshBuilder& m, Rng& rng, double x0, double z0, double x1, double z1, double h) {
  const double W = x1 - x0, D = z1 - z0;
  const double a = rng.uniform(0.55, 0.8), b = rng.uniform(0.55, 0.85);
  const double c = rng.uniform(0.25, a - 0.1), e = rng.uniform(0.2, b - 0.1);
  const bool open = m.open();
  const double ax1 = x0 + a * W, az1 = z0 + b * D;
  m.box({x0, open ? 0.0 : kBase, z0}, {ax1, h, az1});
  const double hb = h * rng.uniform(0.4, 0.9);
  const double bx0 = x0 + c * W, bz0 = z0 + e * D;
  if (rng.chance(0.3)) {
    const double roof = std::min(x1 - bx0, z1 - bz0) * rng.uniform(0.2, 0.5);
    m.gableHouse(bx0, bz0, x1, z1, open ? 0.0 : -1.3, hb, roof, (x1 - bx0) >= (z1 - bz0));
  } else {
    m.box({bx0, open ? 0.0 : -1.3, bz0}, {x1, hb, z1});
  }
  if (rng.chance(0.5)) {  // a box stacked into the top of the main one
    const double ix = (ax1 - x0) * rng.uniform(0.1, 0.3), iz = (az1 - z0) * rng.uniform(0.1, 0.3);
    m.box({x0 + ix, h - 0.7, z0 + iz}, {ax1 - ix, h + rng.uniform(4.0, 4.0 + 0.4 * h), az1 - iz});
  }
}

// Buildings are taller towards the centre: at most `hi` there, about a third of it at the corners.
double heightFalloff(double cx, double cz) {
  const double dist = std::min(1.0, detSqrt(cx * cx + cz * cz) / (kHalf * 1.41421356237309505));
  return 1.0 - 0.7 * dist;
}

double heightAt(Rng& rng, double cx, double cz, double lo, double hi) {
  const double u = rng.unit();
  return lo + (hi - lo) * u * detSqrt(u) * heightFalloff(cx, cz);
}

// ---- the whole city ------------------------------------------------------------------------------------

CityBuild buildCity(const CityOptions& o, const Layout& y, const Detail& d, bool countOnly) {
  CityBuild city;
  const bool open = o.open;
  // Prototype library (depends on the lot size, hence on the layout).
  {
    const struct {
      ProtoKind kind;
      const char* name;
      int count;
    } kinds[] = {{ProtoKind::Round, "round", 6}, {ProtoKind::Gable, "gable", 6}, {ProtoKind::Hip, "hip", 4}};
    for (const auto& k : kinds) {
      for (int i = 0; i < k.count; ++i) {
        Rng rng(hash64(o.seed, 0x50524F544FULL, static_cast<std::uint64_t>(y.lotsPerSide),
                       static_cast<std::uint64_t>(city.protos.size())));
        Prototype p{k.kind, std::string("proto_") + k.name + "_" + std::to_string(i), MeshBuilder(open, countOnly)};
        if (k.kind == ProtoKind::Round)
          p.height = buildRoundPrototype(p.mesh, rng, y, d, i, k.count);
        else
          buildHousePrototype(p.mesh, rng, y, d, k.kind == ProtoKind::Gable);
        city.protosOfKind[static_cast<int>(k.kind)].push_back(static_cast<int>(city.protos.size()));
        city.protos.push_back(std::move(p));
      }
    }
  }
  // Districts.
  const int nd = y.districtsPerSide;
  for (int dz = 0; dz < nd; ++dz) {
    for (int dx = 0; dx < nd; ++dx) {
      const int b0x = dx * y.districtBlocks, b1x = std::min(y.G, b0x + y.districtBlocks);
      const int b0z = dz * y.districtBlocks, b1z = std::min(y.G, b0z + y.districtBlocks);
      const glm::dvec3 origin(-kHalf + 0.5 * (b0x + b1x) * y.pitch, 0.0, -kHalf + 0.5 * (b0z + b1z) * y.pitch);
      city.districts.emplace_back(open, countOnly);
      city.districts.back().setOrigin(origin);
      city.districtOrigins.push_back(origin);
    }
  }
  const auto place = [&](Rng& rng, ProtoKind kind, double cx, double cz) {
    const std::vector<int>& list = city.protosOfKind[static_cast<int>(kind)];
    int eligible = static_cast<int>(list.size());
    if (kind == ProtoKind::Round) {  // only towers short enough for the site (heights rise in the list)
      const double cap = 10.0 + 110.0 * heightFalloff(cx, cz);
      eligible = 1;
      while (eligible < static_cast<int>(list.size()) &&
             city.protos[static_cast<std::size_t>(list[static_cast<std::size_t>(eligible)])].height <= cap)
        ++eligible;
    }
    const int proto = list[static_cast<std::size_t>(rng.range(0, eligible - 1))];
    const double yaw = kind == ProtoKind::Round ? rng.uniform(0.0, 2.0 * kPi) : 0.5 * kPi * rng.range(0, 3);
    city.instances.push_back({proto, {cx, 0.0, cz}, yaw});
  };
  for (int bz = 0; bz < y.G; ++bz) {
    for (int bx = 0; bx < y.G; ++bx) {
      // Every block and lot has its own generator, so that the detail level (which changes how many
      // random numbers a building draws) does not move the rest of the layout.
      const auto rngFor = [&](int lot) {
        return Rng(hash64(o.seed, static_cast<std::uint64_t>(bx), static_cast<std::uint64_t>(bz),
                          static_cast<std::uint64_t>(y.lotsPerSide) * 64 + static_cast<std::uint64_t>(lot)));
      };
      Rng blockRng = rngFor(63);
      MeshBuilder& m = city.districts[static_cast<std::size_t>((bz / y.districtBlocks) * nd + bx / y.districtBlocks)];
      if (y.L >= 2 && blockRng.chance(0.08)) {  // one big building on the whole block
        const double x0 = y.blockMin(bx) + y.margin, z0 = y.blockMin(bz) + y.margin;
        const double x1 = x0 + y.block - 2.0 * y.margin, z1 = z0 + y.block - 2.0 * y.margin;
        const double h = heightAt(blockRng, 0.5 * (x0 + x1), 0.5 * (z0 + z1), 25.0, 120.0);
        if (blockRng.chance(0.5))
          buildSetback(m, blockRng, d, x0, z0, x1, z1, h);
        else
          buildComplex(m, blockRng, x0, z0, x1, z1, h);
        continue;
      }
      for (int lz = 0; lz < y.L; ++lz) {
        for (int lx = 0; lx < y.L; ++lx) {
          Rng rng = rngFor(lz * y.L + lx);
          const double lotX = y.lotMin(bx, lx), lotZ = y.lotMin(bz, lz);
          const double cx = lotX + 0.5 * y.lot, cz = lotZ + 0.5 * y.lot;
          const double avail = y.lot - 2.0 * y.margin;
          const double r = rng.unit();
          if (r < 0.04) continue;  // a little park
          if (r < 0.64) {
            const double w = avail * rng.uniform(0.55, 1.0), dep = avail * rng.uniform(0.55, 1.0);
            const double x0 = lotX + y.margin + rng.uniform(0.0, avail - w);
            const double z0 = lotZ + y.margin + rng.uniform(0.0, avail - dep);
            const double h = heightAt(rng, cx, cz, 10.0, 120.0);
            if (r < 0.36 || (r < 0.50 && h < 25.0))
              buildOffice(m, rng, d, x0, z0, x0 + w, z0 + dep, h);
            else if (r < 0.50)
              buildSetback(m, rng, d, x0, z0, x0 + w, z0 + dep, h);
            else
              buildComplex(m, rng, x0, z0, x0 + w, z0 + dep, h);
          } else if (r < 0.78) {
            place(rng, ProtoKind::Round, cx, cz);
          } else if (r < 0.93) {
            place(rng, ProtoKind::Gable, cx, cz);
          } else {
            place(rng, ProtoKind::Hip, cx, cz);
          }
        }
      }
    }
  }
  // Ground.
  city.ground = MeshBuilder(open, countOnly);
  if (open) {
    const Polygon p = rectPolygon(-kGroundHalf, -kGroundHalf, kGroundHalf, kGroundHalf);
    std::uint32_t v[4];
    for (int i = 0; i < 4; ++i) v[i] = city.ground.vertex({p[i].x, 0.0, p[i].y});
    city.ground.triangle(v[0], v[1], v[2]);  // faces +y
    city.ground.triangle(v[0], v[2], v[3]);
  } else {
    city.ground.box({-kGroundHalf, -2.0, -kGroundHalf}, {kGroundHalf, 0.0, kGroundHalf});
  }
  city.triangles = city.ground.triangles();
  for (const MeshBuilder& m : city.districts) city.triangles += m.triangles();
  for (const Instance& i : city.instances) city.triangles += city.protos[static_cast<std::size_t>(i.proto)].mesh.triangles();
  return city;
}

void addSpots(GenScene& scene, const CityOptions& o, const Layout& y) {
  // Candidate positions on the street centre lines: crossings and the middles of street segments.
  std::vector<glm::dvec2> candidates;
  std::vector<int> axis;  // the street direction to jitter along: 0 = x, 1 = z
  for (int j = 0; j <= y.G; ++j) {
    for (int k = 0; k <= y.G; ++k) {
      const double x = -kHalf + j * y.pitch, z = -kHalf + k * y.pitch;
      candidates.push_back({x, z});
      axis.push_back((j + k) % 2);
      if (j < y.G) {
        candidates.push_back({x + 0.5 * y.pitch, z});
        axis.push_back(0);
      }
      if (k < y.G) {
        candidates.push_back({x, z + 0.5 * y.pitch});
        axis.push_back(1);
      }
    }
  }
  Rng rng(hash64(o.seed, 0x53504F54ULL, static_cast<std::uint64_t>(y.lotsPerSide)));
  const std::vector<std::size_t> order = rng.shuffledOrder(candidates.size());
  for (int i = 0; i < o.spotLights; ++i) {
    const std::size_t c = order[static_cast<std::size_t>(i) % order.size()];
    glm::dvec2 p = candidates[c];
    const double jitter = rng.uniform(-0.3, 0.3) * y.pitch;
    if (axis[c] == 0)
      p.x = std::clamp(p.x + jitter, -kHalf, kHalf);
    else
      p.y = std::clamp(p.y + jitter, -kHalf, kHalf);
    const double h = std::clamp(y.pitch * rng.uniform(1.0, 2.0), 25.0, 140.0);
    const double outer = rng.uniform(0.35, 0.75);  // 20..43 degrees
    const double tilt = rng.uniform(0.0, 0.3);
    const double azimuth = rng.uniform(0.0, 2.0 * kPi);
    const SinCos st = detSinCos(tilt), sa = detSinCos(azimuth);
    const glm::dvec3 dir(st.s * sa.c, -st.c, st.s * sa.s);

    GenLight l;
    l.name = "spot_" + std::to_string(i);
    l.type = GenLight::Type::Spot;
    l.color = {1.0, rng.uniform(0.8, 0.95), rng.uniform(0.6, 0.85)};
    l.intensity = rng.uniform(800.0, 3000.0);  // candela
    l.outerConeAngle = outer;
    l.innerConeAngle = outer * rng.uniform(0.6, 0.85);
    l.range = 1.3 * h / detCos(std::min(tilt + outer, 1.3));  // reaches the ground across the cone
    if (o.pointLights) {  // the same place and draws of the generator (so the same city), no cone
      l.name = "point_" + std::to_string(i);
      l.type = GenLight::Type::Point;
      l.outerConeAngle = l.innerConeAngle = 0.0;
      l.range = 1.5 * h;  // the ground within about a block around the light
    }
    GenNode n;
    n.name = l.name;
    n.light = static_cast<int>(scene.lights.size());
    n.translation = {p.x, h, p.y};
    n.rotation = rotationFromMinusZ(dir);
    scene.lights.push_back(l);
    scene.nodes.push_back(n);
  }
}

}  // namespace

GenScene generateCity(const CityOptions& o, CityInfo* info) {
  // Budget: first a density (lots per city side) from the budget, corrected where even the least or the
  // most detail cannot reach the budget; then bisect the detail. The counts come from count-only runs
  // of the same code, so they are exact. The open city uses the layout of the closed one (so the two
  // compare like for like); it just has fewer triangles.
  CityOptions closed = o;
  closed.open = false;
  const std::uint64_t target = o.targetTriangles;
  const auto count = [&](int lots, double lambda) {
    return buildCity(closed, layoutFor(lots), detailFor(lambda), true).triangles;
  };
  int maxLots = 400;
  while (maxLots > 1 && layoutFor(maxLots).lot < 6.0) --maxLots;  // keep lots big enough for a building
  int lots = std::min(maxLots, lotsPerSideFor(target));
  while (lots > 2 && count(lots, 0.0) > target) lots -= std::max(1, lots / 8);
  while (lots < maxLots && count(lots, kMaxDetail) < target) lots = std::min(maxLots, lots + std::max(1, lots / 8));
  double lo = 0.0, hi = kMaxDetail;
  if (lots == maxLots && count(lots, kMaxDetail) < target) {  // the densest layout needs finer facades
    lo = kMaxDetail;
    hi = kFinestDetail;
  }
  double best = lo;
  std::uint64_t bestErr = ~0ull;
  for (int i = 0; i < 24; ++i) {
    const double mid = i == 0 ? lo : 0.5 * (lo + hi);
    const std::uint64_t c = count(lots, mid);
    const std::uint64_t err = c > target ? c - target : target - c;
    if (err < bestErr) {
      bestErr = err;
      best = mid;
    }
    if (i == 0) continue;
    if (c < target)
      lo = mid;
    else
      hi = mid;
    if (err * 1000 <= target) break;  // within 0.1 %
  }
  const Detail d = detailFor(best);
  const Layout y = layoutFor(lots);
  CityBuild city = buildCity(o, y, d, false);

  GenScene scene;
  if (o.groundTiles > 1 && !o.open) {
    // The same slab as N x N closed tiles, one mesh placed N^2 times.
    const double half = kGroundHalf / o.groundTiles;
    MeshBuilder tile(false, false);
    tile.box({-half, -2.0, -half}, {half, 0.0, half});
    scene.meshes.push_back(tile.take("ground_tile"));
    for (int i = 0; i < o.groundTiles * o.groundTiles; ++i) {
      const glm::dvec3 at(-kGroundHalf + half * (2 * (i % o.groundTiles) + 1), 0.0, -kGroundHalf + half * (2 * (i / o.groundTiles) + 1));
      scene.nodes.push_back(GenNode{"ground." + std::to_string(i), 0, -1, at, Quat{}, {}});
    }
  } else {
    scene.meshes.push_back(city.ground.take("ground"));
    scene.nodes.push_back(GenNode{"ground", 0, -1, glm::dvec3(0.0), Quat{}, {}});
  }
  for (std::size_t i = 0; i < city.districts.size(); ++i) {
    if (city.districts[i].triangles() == 0) continue;
    const int dx = static_cast<int>(i) % y.districtsPerSide, dz = static_cast<int>(i) / y.districtsPerSide;
    const std::string name = "district_" + std::to_string(dx) + "_" + std::to_string(dz);
    scene.nodes.push_back(GenNode{name, static_cast<int>(scene.meshes.size()), -1, city.districtOrigins[i], Quat{}, {}});
    scene.meshes.push_back(city.districts[i].take(name));
  }
  std::vector<int> protoMesh(city.protos.size(), -1);
  std::vector<int> uses(city.protos.size(), 0);
  for (const Instance& in : city.instances) {
    const std::size_t p = static_cast<std::size_t>(in.proto);
    if (protoMesh[p] < 0) {
      protoMesh[p] = static_cast<int>(scene.meshes.size());
      scene.meshes.push_back(city.protos[p].mesh.take(city.protos[p].name));
    }
    scene.nodes.push_back(GenNode{scene.meshes[static_cast<std::size_t>(protoMesh[p])].name + "." +
                                      std::to_string(uses[p]++),
                                  protoMesh[p], -1, in.position, rotationAboutY(in.yaw), {}});
  }
  if (o.spotLights > 0) {
    addSpots(scene, o, y);
  } else {
    GenLight sun;
    sun.name = "sun";
    sun.intensity = 5.0;  // lux
    sun.color = {1.0, 0.96, 0.9};
    scene.lights.push_back(sun);
    scene.nodes.push_back(GenNode{"sun", -1, 0, glm::dvec3(0.0, 400.0, 0.0), rotationFromMinusZ(sunDirection()), {}});
  }
  if (info) {
    info->lotsPerSide = lots;
    info->blocksPerSide = y.G;
    info->lotsPerBlockSide = y.L;
    info->blockPitch = y.pitch;
    info->lotSize = y.lot;
    info->detail = d.lambda;
  }
  return scene;
}

}  // namespace cpvs::scenegen
