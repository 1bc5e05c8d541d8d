// cpvs-query end to end (docs/query.md): it runs the cpvs-bake and cpvs-query binaries.
//  * Inputs and outputs: CSV, PLY (ascii and binary, with and without normals) and EXR G-buffers give the same
//    answers; columns per light in file or --light order; NaN points answered 0 and counted; streaming.
//  * Errors: usage (1), bad input naming the file and line / element (2), unwritable output (3), and nothing
//    half-written under the output's name.
//  * Accuracy against Embree shadow rays (--reference) on four shipped scenes (closed, open, thin, terrain) with
//    a sun and a spot light, and hard cases: a sun along an axis and at a grazing 89 degrees, the same scene
//    translated by 1e5 and scaled by 1e-3 and 1e4, points exactly on voxel, tile and region boundaries.
//
// Query points are sampled on the scene's own triangles (area-weighted, uniform barycentric, fixed seed) with
// the triangle's geometric normal; points that lie inside a closed solid (Embree parity count) are dropped: no
// camera can see them and the baker may answer either way there (free voxels, docs/architecture.md, "The voxel convention").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/io/exr_image.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/base/error.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/reference/embree_scene.h"
#include "libcpvs/scene/surface_samples.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

namespace fs = std::filesystem;
using test::runTool;
using test::sourcePath;
using test::toolPath;

// ---- helpers -----------------------------------------------------------------------------------------------

std::string num(double v) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}
std::string vec(const glm::dvec3& v) { return num(v.x) + "," + num(v.y) + "," + num(v.z); }
std::string quote(const std::string& s) { return "'" + s + "'"; }

std::string sunArg(const glm::dvec3& direction) { return " --sun " + vec(glm::normalize(direction)); }
std::string spotArg(const glm::dvec3& position, const glm::dvec3& direction, double angle, double range) {
  return " --spot " + vec(position) + "," + vec(glm::normalize(direction)) + "," + num(angle) + "," + num(range);
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json readJson(const std::string& path) { return nlohmann::json::parse(slurp(path)); }

struct Table {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
};

Table readTable(const std::string& path) {
  Table t;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return t;
  std::stringstream header(line);
  for (std::string name; std::getline(header, name, ',');) t.columns.push_back(name);
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream fields(line);
    for (std::string f; std::getline(fields, f, ',');) row.push_back(std::strtod(f.c_str(), nullptr));
    t.rows.push_back(row);
  }
  return t;
}

void writeCsv(const std::string& path, const std::vector<SurfacePoint>& points, bool normals = true) {
  FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_TRUE(f);
  std::fprintf(f, normals ? "x,y,z,nx,ny,nz\n" : "x,y,z\n");
  for (const SurfacePoint& p : points) {
    std::fprintf(f, "%.17g,%.17g,%.17g", p.position.x, p.position.y, p.position.z);
    if (normals) std::fprintf(f, ",%.17g,%.17g,%.17g", p.normal.x, p.normal.y, p.normal.z);
    std::fprintf(f, "\n");
  }
  std::fclose(f);
}

// PLY with double coordinates, float normals, an extra uchar property and a face element after the vertices
// (read past by the reader).
void writePly(const std::string& path, const std::vector<SurfacePoint>& points, bool binary, bool normals) {
  std::ofstream out(path, std::ios::binary);
  out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\ncomment cpvs query_test\n";
  out << "element vertex " << points.size() << "\nproperty double x\nproperty double y\nproperty double z\n";
  if (normals) out << "property float nx\nproperty float ny\nproperty float nz\n";
  out << "property uchar quality\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  for (const SurfacePoint& p : points) {
    const double xyz[3] = {p.position.x, p.position.y, p.position.z};
    const float n[3] = {float(p.normal.x), float(p.normal.y), float(p.normal.z)};
    if (binary) {
      out.write(reinterpret_cast<const char*>(xyz), sizeof xyz);
      if (normals) out.write(reinterpret_cast<const char*>(n), sizeof n);
      out.put(char(7));
    } else {
      out << num(xyz[0]) << ' ' << num(xyz[1]) << ' ' << num(xyz[2]);
      if (normals) {
        char buffer[128];
        std::snprintf(buffer, sizeof buffer, " %.9g %.9g %.9g", double(n[0]), double(n[1]), double(n[2]));
        out << buffer;
      }
      out << " 7\n";
    }
  }
  if (binary) {
    const unsigned char count = 3;
    const int32_t indices[3] = {0, 1, 2};
    out.put(char(count));
    out.write(reinterpret_cast<const char*>(indices), sizeof indices);
  } else {
    out << "3 0 1 2\n";
  }
}

// Area-weighted points on the triangles with their geometric normals (libcpvs/scene/surface_samples.h, as
// cpvs-sample writes them), without the points inside closed solids (see the file comment).
std::vector<SurfacePoint> sampleSurface(const WorldGeometry& world, size_t count, uint32_t seed) {
  const EmbreeScene rt(world);
  const double epsilon = 1e-6 * glm::length(world.bounds.extent());
  std::vector<SurfacePoint> points;
  for (uint64_t round = 0; points.size() < count && round < 8; ++round)
    for (const SurfaceSample& s : sampleSurfaces(world, count, seed + 1000 * round)) {
      if (points.size() == count) break;
      if (!rt.isInsideClosedSolid(s.position + epsilon * s.normal)) points.push_back({s.position, s.normal});
    }
  EXPECT_EQ(points.size(), count);
  return points;
}

WorldGeometry worldOf(const std::string& scenePath) { return flatten(importGltf(scenePath)); }

// A fresh directory per test.
struct Dir {
  std::string path = test::tempDir();
  std::string operator/(const std::string& name) const { return path + "/" + name; }
};

void bake(const std::string& scene, const std::string& out, uint32_t resolution, const std::string& lights,
          const std::string& extra = "") {
  const auto r = runTool(toolPath("cpvs-bake") + " " + quote(scene) + " -o " + quote(out) + " --resolution " +
                         std::to_string(resolution) + lights + extra + " --quiet");
  ASSERT_EQ(r.exitCode, 0) << r.output;
}

test::ToolResult query(const std::string& args) { return runTool(toolPath("cpvs-query") + " " + args + " -q"); }

// ---- a small generated glTF writer (ground, boxes, thin parts) ----------------------------------------------

struct GltfMesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> indices;
};

std::string base64(const std::string& bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8 | uint8_t(bytes[i + 2]);
    for (int k = 3; k >= 0; --k) out += table[(v >> (6 * k)) & 63];
  }
  if (i < bytes.size()) {
    uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    out += table[(v >> 18) & 63];
    out += table[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? table[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// Writes the meshes under one root node with the given translation and uniform scale (applied by the importer
// in double precision, so the world geometry is the same scene at another place and size).
void writeGltf(const std::string& path, const std::vector<GltfMesh>& meshes, const glm::dvec3& translation = {},
               double scale = 1.0) {
  nlohmann::json j;
  j["asset"] = {{"version", "2.0"}};
  j["scene"] = 0;
  std::string buffer;
  nlohmann::json nodes = nlohmann::json::array(), jm = nlohmann::json::array(), accessors = nlohmann::json::array(),
                 views = nlohmann::json::array(), children = nlohmann::json::array();
  nodes.push_back({{"name", "root"},
                   {"translation", {translation.x, translation.y, translation.z}},
                   {"scale", {scale, scale, scale}}});
  for (const GltfMesh& m : meshes) {
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (const glm::vec3& p : m.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
    const size_t posOffset = buffer.size();
    buffer.append(reinterpret_cast<const char*>(m.positions.data()), m.positions.size() * sizeof(glm::vec3));
    const size_t idxOffset = buffer.size();
    buffer.append(reinterpret_cast<const char*>(m.indices.data()), m.indices.size() * sizeof(uint32_t));
    views.push_back({{"buffer", 0}, {"byteOffset", posOffset}, {"byteLength", m.positions.size() * 12}});
    views.push_back({{"buffer", 0}, {"byteOffset", idxOffset}, {"byteLength", m.indices.size() * 4}});
    accessors.push_back({{"bufferView", views.size() - 2},
                         {"componentType", 5126},
                         {"count", m.positions.size()},
                         {"type", "VEC3"},
                         {"min", {lo.x, lo.y, lo.z}},
                         {"max", {hi.x, hi.y, hi.z}}});
    accessors.push_back({{"bufferView", views.size() - 1},
                         {"componentType", 5125},
                         {"count", m.indices.size()},
                         {"type", "SCALAR"}});
    jm.push_back({{"name", m.name},
                  {"primitives", {{{"attributes", {{"POSITION", accessors.size() - 2}}},
                                   {"indices", accessors.size() - 1}}}}});
    children.push_back(nodes.size());
    nodes.push_back({{"name", m.name}, {"mesh", jm.size() - 1}});
  }
  nodes[0]["children"] = children;
  j["nodes"] = nodes;
  j["scenes"] = {{{"nodes", {0}}}};
  j["meshes"] = jm;
  j["accessors"] = accessors;
  j["bufferViews"] = views;
  j["buffers"] = {{{"byteLength", buffer.size()}, {"uri", "data:application/octet-stream;base64," + base64(buffer)}}};
  std::ofstream(path) << j.dump();
}

GltfMesh boxMesh(const std::string& name, const glm::vec3& lo, const glm::vec3& hi) {
  GltfMesh m;
  m.name = name;
  for (int i = 0; i < 8; ++i) m.positions.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  const uint32_t faces[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& f : faces) m.indices.insert(m.indices.end(), {f[0], f[1], f[2], f[0], f[2], f[3]});
  return m;
}

GltfMesh quadMesh(const std::string& name, const glm::vec3& a, const glm::vec3& b, const glm::vec3& c,
                  const glm::vec3& d) {
  return {name, {a, b, c, d}, {0, 1, 2, 0, 2, 3}};
}

// Ground (open, facing up) with closed boxes of several sizes, a thin closed slab on posts and a thin open
// leaf: shadows of every kind on the ground and on each other.
std::vector<GltfMesh> courtyard() {
  return {quadMesh("ground", {-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10}),
          boxMesh("tower", {-6, 0, -6}, {-3, 5, -3}),
          boxMesh("block", {1, 0, 2}, {5, 2, 4}),
          boxMesh("post1", {-1, 0, -1}, {-0.7f, 3, -0.7f}),
          boxMesh("post2", {2, 0, -1}, {2.3f, 3, -0.7f}),
          boxMesh("slab", {-1.5f, 3, -2}, {3, 3.1f, 0.5f}),
          quadMesh("leaf", {5, 4, -6}, {5, 4, -4}, {7, 4.5f, -4}, {7, 4.5f, -6})};
}

// Lights for a scene: a sun from the upper side and a spot above it whose cone holds the whole scene.
struct SceneLights {
  glm::dvec3 sun;
  glm::dvec3 spotPosition, spotDirection;
  double spotAngle = 0, spotRange = 0;
  std::string args() const { return sunArg(sun) + spotArg(spotPosition, spotDirection, spotAngle, spotRange); }
};

SceneLights lightsFor(const Bounds& bounds, const glm::dvec3& sun, const glm::dvec3& spotFrom) {
  SceneLights l;
  l.sun = glm::normalize(sun);
  const glm::dvec3 centre = bounds.center();
  const double radius = 0.5 * glm::length(bounds.extent());
  l.spotPosition = centre + 2.5 * radius * glm::normalize(spotFrom);
  l.spotDirection = glm::normalize(centre - l.spotPosition);
  l.spotAngle = std::atan(radius / (2.5 * radius)) + 0.05;
  l.spotRange = 6 * radius;
  return l;
}

struct Accuracy {
  double misclassified = 0, misclassifiedUniform = 0, uniformFraction = 0, meanAbsDiff = 0;
  uint64_t samples = 0;
};

Accuracy accuracyOf(const nlohmann::json& lightReport) {
  const auto& r = lightReport.at("reference");
  return {r.at("misclassified").get<double>(), r.at("misclassified_uniform").get<double>(),
          r.at("uniform_fraction").get<double>(), r.at("mean_abs_diff").get<double>(),
          r.at("samples").get<uint64_t>()};
}

// Bakes `scene` with `lights` at N, queries `points` against the Embree reference and checks the issue's
// thresholds per light: at most 0.1 % misclassified among points whose reference is uniform within two voxels,
// at most 1 % overall.
nlohmann::json checkAccuracy(const Dir& dir, const std::string& scene, const std::string& lights, uint32_t n,
                             const std::vector<SurfacePoint>& points, const std::string& label,
                             const std::string& extra = "") {
  const std::string cpvs = dir / "scene.cpvs", pts = dir / "points.csv";
  bake(scene, cpvs, n, lights);
  writeCsv(pts, points);
  const auto r = query(quote(cpvs) + " --points " + quote(pts) + " -o " + quote(dir / "out.csv") + " --reference " +
                       quote(scene) + " --report " + quote(dir / "report.json") + " --timing-rounds 0" + extra);
  EXPECT_EQ(r.exitCode, 0) << r.output;
  const nlohmann::json report = readJson(dir / "report.json");
  for (const auto& light : report.at("lights")) {
    const Accuracy a = accuracyOf(light);
    const std::string what = label + " " + light.at("name").get<std::string>() + " at " + std::to_string(n) +
                             ": " + std::to_string(100 * a.misclassified) + " % misclassified, " +
                             std::to_string(100 * a.misclassifiedUniform) + " % of the " +
                             std::to_string(100 * a.uniformFraction) + " % uniform points";
    const uint64_t inside = report.at("reference").at("inside_closed_points").get<uint64_t>();
    EXPECT_EQ(a.samples + inside, points.size()) << what;
    EXPECT_LE(inside, points.size() / 1000) << what << ": the sampled points are outside every closed solid";
    EXPECT_LE(a.misclassifiedUniform, 0.001) << what;
    EXPECT_LE(a.misclassified, 0.01) << what;
    EXPECT_GE(a.uniformFraction, 0.5) << what << " (too few uniform points for the figure to mean much)";
    std::cout << "[ accuracy ] " << what << "\n";
  }
  return report;
}

// ---- the tiny scene, baked once ----------------------------------------------------------------------------

const std::string& tinyCpvs() {
  static const std::string path = [] {
    const std::string dir = test::tempDir();
    const std::string out = dir + "/tiny.cpvs";
    const auto r = runTool(toolPath("cpvs-bake") + " " + quote(sourcePath("data/scenes/Tiny/tiny.gltf")) + " -o " +
                           quote(out) + " --resolution 256 --quiet");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    return out;
  }();
  return path;
}

const std::vector<SurfacePoint>& tinyPoints() {
  static const std::vector<SurfacePoint> points = sampleSurface(worldOf(sourcePath("data/scenes/Tiny/tiny.gltf")), 3000, 7);
  return points;
}

// ---- command line --------------------------------------------------------------------------------------------

TEST(QueryCli, HelpVersionAndUsageErrors) {
  auto r = runTool(toolPath("cpvs-query") + " --help");
  EXPECT_EQ(r.exitCode, 0);
  EXPECT_NE(r.output.find("--points"), std::string::npos);
  EXPECT_NE(r.output.find("Exit codes"), std::string::npos) << r.output;
  r = runTool(toolPath("cpvs-query") + " --version");
  EXPECT_EQ(r.exitCode, 0);
  EXPECT_NE(r.output.find("cpvs-query"), std::string::npos);

  const Dir dir;
  const std::string pts = dir / "p.csv";
  writeCsv(pts, tinyPoints());
  const std::string base = quote(tinyCpvs()) + " --points " + quote(pts) + " -o " + quote(dir / "o.csv");
  EXPECT_EQ(query(quote(tinyCpvs()) + " -o " + quote(dir / "o.csv")).exitCode, 1);  // no --points
  EXPECT_EQ(query(base + " --pcf 4").exitCode, 1);
  EXPECT_EQ(query(base + " --pcf 0").exitCode, 1);
  EXPECT_EQ(query(base + " --threads 0").exitCode, 1);
  EXPECT_EQ(query(base + " --reference-epsilon 0").exitCode, 1);
  EXPECT_EQ(query(base + " --reference-epsilon 0.5").exitCode, 1);
  EXPECT_EQ(query(base + " --bogus").exitCode, 1);
  EXPECT_EQ(query(base + " --exclude-mesh Box").exitCode, 1);  // only with --reference
  EXPECT_EQ(query(quote(tinyCpvs()) + " --points " + quote(pts) + " -o " + quote(dir / "o.exr")).exitCode, 1);
  r = query(base + " --light NoSuchLight");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.output.find("'Sun'"), std::string::npos) << "the message lists the file's lights: " << r.output;
  r = query(base + " --reference " + quote(sourcePath("data/scenes/Tiny/tiny.gltf")) + " --exclude-mesh NoMesh");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_FALSE(fs::exists(dir / "o.csv"));
}

// ---- inputs and outputs ------------------------------------------------------------------------------------

TEST(QueryIo, CsvPlyAsciiAndBinaryGiveTheSameAnswersInInputOrder) {
  const Dir dir;
  const std::vector<SurfacePoint>& points = tinyPoints();
  std::vector<SurfacePoint> bare = points;
  for (SurfacePoint& p : bare) p.normal = glm::dvec3(0.0);
  writeCsv(dir / "n.csv", points, true);
  writeCsv(dir / "p.csv", points, false);
  writePly(dir / "na.ply", points, false, true);
  writePly(dir / "nb.ply", points, true, true);
  writePly(dir / "pa.ply", points, false, false);
  writePly(dir / "pb.ply", points, true, false);
  auto run = [&](const std::string& in, const std::string& extra = "") {
    const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / in) + " -o " + quote(dir / (in + ".out")) +
                         " --report " + quote(dir / (in + ".json")) + " --timing-rounds 0" + extra);
    EXPECT_EQ(r.exitCode, 0) << in << ": " << r.output;
    return slurp(dir / (in + ".out"));
  };
  const std::string withNormals = run("n.csv");
  // PLY normals are float: the same floats in the CSV give the same bytes.
  std::vector<SurfacePoint> floatNormals = points;
  for (SurfacePoint& p : floatNormals) p.normal = glm::dvec3(glm::vec3(p.normal));
  writeCsv(dir / "nf.csv", floatNormals, true);
  const std::string floatCsv = run("nf.csv");
  EXPECT_EQ(run("na.ply"), floatCsv);
  EXPECT_EQ(run("nb.ply"), floatCsv);
  const std::string noNormals = run("p.csv");
  EXPECT_EQ(run("pa.ply"), noNormals);
  EXPECT_EQ(run("pb.ply"), noNormals);
  EXPECT_EQ(readJson(dir / "n.csv.json").at("inputs").at("normals"), true);
  EXPECT_EQ(readJson(dir / "pb.ply.json").at("inputs").at("normals"), false);
  EXPECT_EQ(readJson(dir / "nb.ply.json").at("inputs").at("format"), "ply");

  // One row per point, in input order: the answers of the reversed file are the reversed answers.
  const Table forward = readTable(dir / "n.csv.out");
  ASSERT_EQ(forward.columns, (std::vector<std::string>{"Sun", "SpotNode"}));
  ASSERT_EQ(forward.rows.size(), points.size());
  std::vector<SurfacePoint> reversed(points.rbegin(), points.rend());
  writeCsv(dir / "r.csv", reversed, true);
  run("r.csv");
  const Table backward = readTable(dir / "r.csv.out");
  ASSERT_EQ(backward.rows.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) ASSERT_EQ(backward.rows[i], forward.rows[points.size() - 1 - i]) << i;
  // Both lights light and shadow part of the scene: the answers mean something.
  for (size_t l = 0; l < 2; ++l) {
    size_t lit = 0;
    for (const auto& row : forward.rows) {
      ASSERT_TRUE(row[l] == 0.0 || row[l] == 1.0);
      lit += row[l] == 1.0;
    }
    EXPECT_GT(lit, points.size() / 10);
    EXPECT_LT(lit, points.size() * 97 / 100);
  }
  // Thread count does not change a byte.
  EXPECT_EQ(run("n.csv", " --threads 1"), withNormals);
  EXPECT_EQ(run("n.csv", " --threads 2"), withNormals);
  // Optional CSV details: BOM, CRLF, comments, extra columns in any order, blank lines.
  {
    std::ofstream out(dir / "odd.csv", std::ios::binary);
    out << "\xEF\xBB\xBF# a comment\r\nid, NZ ,ny,nx , z,y,x\r\n";
    for (size_t i = 0; i < points.size(); ++i) {
      const SurfacePoint& p = points[i];
      out << i << "," << num(p.normal.z) << "," << num(p.normal.y) << "," << num(p.normal.x) << "," << num(p.position.z)
          << "," << num(p.position.y) << "," << num(p.position.x) << "\r\n";
      if (i % 100 == 0) out << "\r\n# note\r\n";
    }
  }
  EXPECT_EQ(run("odd.csv"), withNormals);
}

TEST(QueryIo, ExrGBufferGivesAnExrOfTheSameSizeAndTheCsvAnswers) {
  const Dir dir;
  const std::vector<SurfacePoint>& points = tinyPoints();
  const uint32_t width = 50, height = 40;  // 2000 pixels: points, then background
  ExrImage g;
  g.width = width;
  g.height = height;
  g.channels = {"P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z"};
  std::vector<SurfacePoint> used;
  for (uint32_t i = 0; i < width * height; ++i) {
    SurfacePoint p = points[i % points.size()];
    // EXR holds float: use the float values everywhere so the CSV run sees the same points.
    p.position = glm::dvec3(glm::vec3(p.position));
    p.normal = glm::dvec3(glm::vec3(p.normal));
    const bool background = i % 17 == 5;
    const float nan = std::nanf("");
    const float px[6] = {background ? nan : float(p.position.x), float(p.position.y), float(p.position.z),
                         float(p.normal.x), float(p.normal.y), float(p.normal.z)};
    g.pixels.insert(g.pixels.end(), px, px + 6);
    if (background) p.position.x = std::nan("");
    used.push_back(p);
  }
  writeExr(dir / "g.exr", g);
  auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / "g.exr") + " -o " + quote(dir / "v.exr") +
                 " --report " + quote(dir / "g.json") + " --timing-rounds 0");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const ExrImage v = readExr(dir / "v.exr");
  EXPECT_EQ(v.width, width);
  EXPECT_EQ(v.height, height);
  ASSERT_EQ(v.channels.size(), 2u);
  const int sun = v.channelIndex("Sun"), spot = v.channelIndex("SpotNode");
  ASSERT_GE(sun, 0);
  ASSERT_GE(spot, 0);
  const nlohmann::json report = readJson(dir / "g.json");
  EXPECT_EQ(report.at("points"), width * height);
  EXPECT_EQ(report.at("invalid_points"), (width * height + 11) / 17);
  writeCsv(dir / "same.csv", used);
  r = query(quote(tinyCpvs()) + " --points " + quote(dir / "same.csv") + " -o " + quote(dir / "same.out"));
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const Table t = readTable(dir / "same.out");
  ASSERT_EQ(t.rows.size(), size_t(width) * height);
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const auto& row = t.rows[size_t(y) * width + x];
      ASSERT_EQ(double(v.at(x, y, size_t(sun))), row[0]) << x << "," << y;
      ASSERT_EQ(double(v.at(x, y, size_t(spot))), row[1]) << x << "," << y;
    }
  // CSV output from an EXR input: one row per pixel, row-major.
  r = query(quote(tinyCpvs()) + " --points " + quote(dir / "g.exr") + " -o " + quote(dir / "g.csv"));
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(slurp(dir / "g.csv"), slurp(dir / "same.out"));
}

TEST(QueryIo, NanPointsAreAnsweredZeroAndCounted) {
  const Dir dir;
  std::vector<SurfacePoint> points(tinyPoints().begin(), tinyPoints().begin() + 500);
  writeCsv(dir / "clean.csv", points);
  const double nan = std::nan("");
  const size_t bad[] = {3, 77, 78, 400};
  for (size_t i : bad) (i == 77 ? points[i].normal.y : points[i].position.z) = (i == 400 ? INFINITY : nan);
  writeCsv(dir / "nan.csv", points);
  ASSERT_EQ(query(quote(tinyCpvs()) + " --points " + quote(dir / "clean.csv") + " -o " + quote(dir / "clean.out")).exitCode, 0);
  const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / "nan.csv") + " -o " + quote(dir / "nan.out") +
                       " --report " + quote(dir / "nan.json") + " --timing-rounds 0");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("4 of 500 points"), std::string::npos) << r.output;
  const Table clean = readTable(dir / "clean.out"), withNan = readTable(dir / "nan.out");
  ASSERT_EQ(withNan.rows.size(), 500u);
  for (size_t i = 0; i < 500; ++i) {
    const bool isBad = std::find(std::begin(bad), std::end(bad), i) != std::end(bad);
    if (isBad)
      EXPECT_EQ(withNan.rows[i], (std::vector<double>{0.0, 0.0})) << i;
    else
      EXPECT_EQ(withNan.rows[i], clean.rows[i]) << i;
  }
  const nlohmann::json report = readJson(dir / "nan.json");
  EXPECT_EQ(report.at("points"), 500);
  EXPECT_EQ(report.at("invalid_points"), 4);
  EXPECT_EQ(report.at("first_invalid_points"), (std::vector<int>{3, 77, 78, 400}));
}

TEST(QueryIo, LightSelectionByNameAndIndexAndUnnamedLights) {
  const Dir dir;
  writeCsv(dir / "p.csv", tinyPoints());
  auto run = [&](const std::string& lights) {
    const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "o.csv") + lights);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    return readTable(dir / "o.csv");
  };
  const Table all = run("");
  ASSERT_EQ(all.columns, (std::vector<std::string>{"Sun", "SpotNode"}));
  const Table spot = run(" --light SpotNode");
  ASSERT_EQ(spot.columns, (std::vector<std::string>{"SpotNode"}));
  const Table swapped = run(" --light 1 --light Sun");
  ASSERT_EQ(swapped.columns, (std::vector<std::string>{"SpotNode", "Sun"}));
  for (size_t i = 0; i < all.rows.size(); ++i) {
    ASSERT_EQ(spot.rows[i], (std::vector<double>{all.rows[i][1]}));
    ASSERT_EQ(swapped.rows[i], (std::vector<double>{all.rows[i][1], all.rows[i][0]}));
  }

  // A file whose lights have no names: columns light0, light1; a name that looks like an index is a name first.
  Scene scene = importGltf(sourcePath("data/scenes/Tiny/tiny.gltf"));
  for (Light& l : scene.lights) l.name.clear();
  scene.lights[1].name = "0";
  Light third = scene.lights[0];
  third.direction = glm::normalize(glm::dvec3(0.5, -1, 0.1));
  scene.lights.push_back(third);
  BakeSettings settings;
  settings.resolution = 64;
  settings.threads = 1;
  try {
    std::ofstream(dir / "unnamed.cpvs", std::ios::binary) << writeCpvs(bakeScene(scene, settings));
  } catch (const Error& e) {
    GTEST_SKIP() << "no depth renderer here: " << e.what();
  }
  auto r = query(quote(dir / "unnamed.cpvs") + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "u.csv"));
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(readTable(dir / "u.csv").columns, (std::vector<std::string>{"light0", "0", "light2"}));
  r = query(quote(dir / "unnamed.cpvs") + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "u.csv") +
            " --light 0 --light 2");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(readTable(dir / "u.csv").columns, (std::vector<std::string>{"0", "light2"}));
}

TEST(QueryIo, PcfValuesAreFractionsOfTheKernelInZeroOne) {
  const Dir dir;
  writeCsv(dir / "p.csv", tinyPoints());
  const std::string scene = sourcePath("data/scenes/Tiny/tiny.gltf");
  Table tables[4];
  const int kernels[4] = {1, 3, 9, 15};
  for (int i = 0; i < 4; ++i) {
    const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "o.csv") +
                         " --pcf " + std::to_string(kernels[i]) + " --reference " + quote(scene) + " --report " +
                         quote(dir / "r.json") + " --timing-rounds 1");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    tables[i] = readTable(dir / "o.csv");
    const nlohmann::json report = readJson(dir / "r.json");
    EXPECT_EQ(report.at("settings").at("pcf"), kernels[i]);
    const double diff = report.at("reference").at("mean_abs_diff").get<double>();
    EXPECT_GE(diff, 0.0);
    EXPECT_LE(diff, 0.05) << "K=" << kernels[i];
    EXPECT_GT(report.at("lookups_per_s").get<double>(), 0.0);
    if (kernels[i] > 1) {
      EXPECT_GT(report.at("lookups_per_s_unfiltered").get<double>(), 0.0);
      EXPECT_GT(report.at("pcf_cost").get<double>(), 0.0);
    }
  }
  size_t fractional = 0;
  for (int i = 1; i < 4; ++i) {
    const double k2 = double(kernels[i]) * kernels[i];
    for (size_t p = 0; p < tables[i].rows.size(); ++p)
      for (size_t l = 0; l < 2; ++l) {
        const double v = tables[i].rows[p][l];
        ASSERT_GE(v, 0.0);
        ASSERT_LE(v, 1.0);
        // A fraction of K^2 texels (written as float).
        ASSERT_NEAR(v * k2, std::round(v * k2), 1e-3 * k2) << "K=" << kernels[i];
        fractional += v > 0 && v < 1;
      }
  }
  EXPECT_GT(fractional, 50u) << "shadow edges give PCF fractions";
}

// A CPVS_LOOKUP_ISA that names no path is refused, naming the value, before any work: a typo must not silently
// measure the widest path.
TEST(QueryIo, AnUnknownLookupIsaIsRefused) {
  const Dir dir;
  writeCsv(dir / "p.csv", tinyPoints());
  const auto r = runTool("CPVS_LOOKUP_ISA=avx " + toolPath("cpvs-query") + " " + quote(tinyCpvs()) + " --points " +
                         quote(dir / "p.csv") + " -o " + quote(dir / "o.csv") + " -q");
  EXPECT_EQ(r.exitCode, 1) << r.output;
  EXPECT_NE(r.output.find("CPVS_LOOKUP_ISA='avx'"), std::string::npos) << r.output;
}

// The whole query through each of the batch mapping's paths (CPVS_LOOKUP_ISA lowers the one picked at run time;
// on a CPU without a path it falls back, and the comparison holds trivially): the same CSV, byte for byte.
TEST(QueryIo, EveryLookupPathGivesTheSameCsv) {
  const Dir dir;
  writeCsv(dir / "p.csv", tinyPoints());
  for (int k : {1, 9}) {
    std::string expected;
    for (const char* isa : {"", "scalar", "avx2", "avx512"}) {
      const auto r = runTool(std::string(*isa ? "CPVS_LOOKUP_ISA=" : "") + isa + " " + toolPath("cpvs-query") + " " +
                             quote(tinyCpvs()) + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "o.csv") +
                             " --pcf " + std::to_string(k) + " -q");
      ASSERT_EQ(r.exitCode, 0) << r.output;
      const std::string csv = slurp(dir / "o.csv");
      ASSERT_GT(csv.size(), 100u);
      if (expected.empty()) expected = csv;
      EXPECT_EQ(csv, expected) << "CPVS_LOOKUP_ISA=" << isa << " K=" << k;
    }
  }
}

TEST(QueryIo, PointFilesAreStreamed) {
  const Dir dir;
  // 1.2 million points (about 29 MB as decoded points) against 20 thousand: the peak memory may not grow by more
  // than a few chunks.
  auto write = [&](const std::string& path, size_t count) {
    FILE* f = std::fopen(path.c_str(), "w");
    std::fprintf(f, "x,y,z\n");
    for (size_t i = 0; i < count; ++i) std::fprintf(f, "%.3f,0.%zu,%.3f\n", -4.5 + double(i % 9000) * 0.001, i % 7, 1.5);
    std::fclose(f);
  };
  write(dir / "small.csv", 20000);
  write(dir / "big.csv", 1200000);
  uint64_t rss[2];
  int i = 0;
  for (const char* name : {"small.csv", "big.csv"}) {
    const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / name) + " -o " + quote(dir / "o.csv") +
                         " --report " + quote(dir / "r.json") + " --timing-rounds 0 --threads 2");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const nlohmann::json report = readJson(dir / "r.json");
    rss[i++] = report.at("peak_rss_bytes").get<uint64_t>();
  }
  EXPECT_EQ(readTable(dir / "o.csv").rows.size(), 1200000u);
#ifdef CPVS_SANITIZED
  GTEST_SKIP() << "peak RSS under AddressSanitizer includes its quarantine of freed memory";
#endif
  EXPECT_LT(rss[1], rss[0] + (12u << 20)) << "peak RSS " << rss[0] << " -> " << rss[1];
}

// ---- errors --------------------------------------------------------------------------------------------------

TEST(QueryErrors, MalformedInputsNameTheFileAndLineAndExitTwo) {
  const Dir dir;
  auto expectBad = [&](const std::string& name, const std::string& content, const std::string& mention) {
    const std::string path = dir / name;
    std::ofstream(path, std::ios::binary) << content;
    const auto r = query(quote(tinyCpvs()) + " --points " + quote(path) + " -o " + quote(dir / "o.csv"));
    EXPECT_EQ(r.exitCode, 2) << name << ": " << r.output;
    EXPECT_NE(r.output.find(mention), std::string::npos) << name << ": expected '" << mention << "' in: " << r.output;
    EXPECT_FALSE(fs::exists(dir / "o.csv")) << name;
  };
  expectBad("num.csv", "x,y,z\n1,2,3\n4,abc,6\n", "num.csv:3");
  expectBad("fields.csv", "x,y,z\n1,2,3\n4,5\n", "fields.csv:3");
  expectBad("many.csv", "x,y,z\n1,2,3,4\n", "many.csv:2");
  expectBad("noheader.csv", "1,2,3\n", "header");
  expectBad("partial.csv", "x,y,z,nx,ny\n1,2,3,0,1\n", "nx, ny, nz");
  expectBad("empty.csv", "", "no header");
  expectBad("empty.field.csv", "x,y,z\n1,,3\n", "empty.field.csv:2");
  expectBad("trunc.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n" + std::string(12 + 5, '\0'),
            "vertex 1");
  expectBad("ascii.ply", "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n1 2 3\n4 five 6\n",
            "vertex 1");
  expectBad("big.ply", "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                       "property float z\nend_header\n" + std::string(12, '\0'),
            "big.ply:2");
  expectBad("novertex.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n",
            "vertex");
  expectBad("noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
            "x, y and z");
  expectBad("garbage.exr", std::string("\x76\x2f\x31\x01", 4) + std::string(100, '\x55'), "garbage.exr");
  {
    ExrImage image;
    image.width = 2;
    image.height = 2;
    image.channels = {"Y"};
    image.pixels = {1, 2, 3, 4};
    writeExr(dir / "nopos.exr", image);
    const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / "nopos.exr") + " -o " + quote(dir / "o.exr"));
    EXPECT_EQ(r.exitCode, 2) << r.output;
    EXPECT_NE(r.output.find("position"), std::string::npos) << r.output;
  }
  // Missing and damaged inputs.
  auto r = query(quote(dir / "none.cpvs") + " --points " + quote(dir / "num.csv") + " -o " + quote(dir / "o.csv"));
  EXPECT_EQ(r.exitCode, 2) << r.output;
  std::ofstream(dir / "bad.cpvs") << "this is not a cpvs file";
  r = query(quote(dir / "bad.cpvs") + " --points " + quote(dir / "num.csv") + " -o " + quote(dir / "o.csv"));
  EXPECT_EQ(r.exitCode, 2) << r.output;
  r = query(quote(tinyCpvs()) + " --points " + quote(dir / "nothing.csv") + " -o " + quote(dir / "o.csv"));
  EXPECT_EQ(r.exitCode, 2) << r.output;
  EXPECT_NE(r.output.find("nothing.csv"), std::string::npos);
  r = query(quote(tinyCpvs()) + " --points " + quote(dir / "num.csv") + " -o " + quote(dir / "o.csv") +
            " --reference " + quote(dir / "nothing.gltf"));
  EXPECT_EQ(r.exitCode, 2) << r.output;
}

TEST(QueryErrors, UnwritableOutputExitsThreeAndNothingIsHalfWritten) {
  const Dir dir;
  writeCsv(dir / "p.csv", tinyPoints());
  const std::string base = quote(tinyCpvs()) + " --points " + quote(dir / "p.csv");
  auto r = query(base + " -o " + quote(dir / "no/such/dir/o.csv"));
  EXPECT_EQ(r.exitCode, 3) << r.output;
  fs::create_directories(dir / "adir");
  r = query(base + " -o " + quote(dir / "adir"));
  EXPECT_EQ(r.exitCode, 3) << r.output;
  r = query(base + " -o " + quote(dir / "o.csv") + " --report " + quote(dir / "no/such/r.json"));
  EXPECT_EQ(r.exitCode, 3) << r.output;
  // A failure part-way through a stream leaves an existing output untouched and no temporary files behind.
  std::ofstream(dir / "keep.csv") << "old contents\n";
  std::string bad = slurp(dir / "p.csv");
  bad += "1,2,oops,0,1,0\n";
  std::ofstream(dir / "late.csv") << bad;
  r = query(quote(tinyCpvs()) + " --points " + quote(dir / "late.csv") + " -o " + quote(dir / "keep.csv"));
  EXPECT_EQ(r.exitCode, 2) << r.output;
  EXPECT_EQ(slurp(dir / "keep.csv"), "old contents\n");
  for (const auto& entry : fs::directory_iterator(dir.path))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
}

// ---- the report ------------------------------------------------------------------------------------------------

TEST(QueryReport, HoldsTheRequiredFieldsAsFractions) {
  const Dir dir;
  writeCsv(dir / "p.csv", tinyPoints());
  const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "o.csv") +
                       " --reference " + quote(sourcePath("data/scenes/Tiny/tiny.gltf")) + " --report " +
                       quote(dir / "r.json") + " --timing-rounds 2 --pcf 3");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const nlohmann::json j = readJson(dir / "r.json");
  EXPECT_EQ(j.at("points").get<uint64_t>(), tinyPoints().size());
  EXPECT_GT(j.at("lookups_per_s").get<double>(), 0.0);
  const auto& ref = j.at("reference");
  EXPECT_GT(ref.at("rays_per_s").get<double>(), 0.0);
  for (const char* rate : {"misclassified", "misclassified_uniform", "mean_abs_diff"}) {
    EXPECT_GE(ref.at(rate).get<double>(), 0.0) << rate;
    EXPECT_LE(ref.at(rate).get<double>(), 1.0) << rate;
  }
  EXPECT_EQ(j.at("lights").size(), 2u);
  for (const auto& l : j.at("lights")) {
    EXPECT_TRUE(l.contains("name"));
    EXPECT_GT(l.at("lookups_per_s").get<double>(), 0.0);
    EXPECT_LE(l.at("reference").at("misclassified").get<double>(), 1.0);
  }
  EXPECT_EQ(j.at("version").get<std::string>().empty(), false);
  // The reference's offset: 1e-6 of Tiny's diagonal (10 x 2 x 10), or what --reference-epsilon asks.
  const double diagonal = std::sqrt(10.0 * 10.0 + 2.0 * 2.0 + 10.0 * 10.0);
  EXPECT_NEAR(ref.at("epsilon").get<double>(), 1e-6 * diagonal, 1e-12);
  EXPECT_EQ(ref.at("relative_epsilon").get<double>(), 1e-6);
  const auto finer = query(quote(tinyCpvs()) + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "o.csv") +
                           " --reference " + quote(sourcePath("data/scenes/Tiny/tiny.gltf")) + " --report " +
                           quote(dir / "r2.json") + " --timing-rounds 0 --reference-epsilon 1e-5");
  ASSERT_EQ(finer.exitCode, 0) << finer.output;
  EXPECT_NEAR(readJson(dir / "r2.json").at("reference").at("epsilon").get<double>(), 1e-5 * diagonal, 1e-12);
  EXPECT_EQ(readJson(dir / "r2.json").at("reference").at("relative_epsilon").get<double>(), 1e-5);
}

// ---- accuracy against Embree -----------------------------------------------------------------------------------

struct ShippedScene {
  const char* label;
  const char* path;
  glm::dvec3 sun, spotFrom;
  uint32_t resolution = 1024;
};

void PrintTo(const ShippedScene& s, std::ostream* os) { *os << s.path << " at " << s.resolution; }

class QueryAccuracy : public ::testing::TestWithParam<ShippedScene> {};

TEST_P(QueryAccuracy, MisclassificationWithinTheIssueThresholds) {
  const ShippedScene& s = GetParam();
  const std::string scene = sourcePath(s.path);
  const WorldGeometry world = worldOf(scene);
  const Dir dir;
  checkAccuracy(dir, scene, lightsFor(world.bounds, s.sun, s.spotFrom).args(), s.resolution,
                sampleSurface(world, 12000, 3), s.label);
}

INSTANTIATE_TEST_SUITE_P(
    ShippedScenes, QueryAccuracy,
    ::testing::Values(ShippedScene{"closed", "data/scenes/TorusKnot/torusknot.gltf", {0.3, -1, 0.2}, {0.3, 1, -0.4}},
                      ShippedScene{"open", "data/scenes/JapaneseTemple/scene.gltf", {-0.4, -1, 0.3}, {0.5, 1, 0.6}},
                      ShippedScene{"thin", "data/scenes/FlightHelmet/FlightHelmet.gltf", {0.5, -1, -0.3}, {-0.6, 0.8, 0.7}},
                      ShippedScene{"terrain", "data/scenes/Terrain/terrain.gltf", {0.6, -0.5, 0.2}, {-0.3, 1, 0.2}, 2048}),
    [](const ::testing::TestParamInfo<ShippedScene>& info) { return std::string(info.param.label); });

// ---- hard cases ----------------------------------------------------------------------------------------------

TEST(QueryHardCases, SunAlongAnAxisAndAtGrazing89Degrees) {
  const Dir dir;
  writeGltf(dir / "court.gltf", courtyard());
  const WorldGeometry world = worldOf(dir / "court.gltf");
  const std::vector<SurfacePoint> points = sampleSurface(world, 12000, 5);
  const double grazing = 89.0 * 3.14159265358979323846 / 180.0;
  struct Case {
    const char* label;
    glm::dvec3 sun;
  };
  for (const Case& c : {Case{"sun -Y", {0, -1, 0}}, Case{"sun +X", {1, 0, 0}},
                        Case{"sun 89 degrees", {std::sin(grazing), -std::cos(grazing), 0.0}},
                        Case{"sun 89 degrees diagonal", glm::dvec3(std::sin(grazing) * 0.6, -std::cos(grazing),
                                                                   std::sin(grazing) * 0.8)}}) {
    const Dir caseDir;
    checkAccuracy(caseDir, dir / "court.gltf", sunArg(c.sun), 1024, points, c.label);
  }
  // TorusKnot (closed, curved) under an axis-aligned sun.
  const std::string knot = sourcePath("data/scenes/TorusKnot/torusknot.gltf");
  const Dir knotDir;
  checkAccuracy(knotDir, knot, sunArg({0, 0, -1}), 1024, sampleSurface(worldOf(knot), 8000, 6), "knot sun -Z");
}

TEST(QueryHardCases, TranslatedAndScaledScenesGiveTheSameAnswers) {
  const Dir dir;
  const std::vector<GltfMesh> meshes = courtyard();
  writeGltf(dir / "base.gltf", meshes);
  const WorldGeometry world = worldOf(dir / "base.gltf");
  const std::vector<SurfacePoint> points = sampleSurface(world, 6000, 9);
  const glm::dvec3 sun(0.35, -1, 0.25), spotPos(4, 12, 6), spotDir = glm::normalize(glm::dvec3(-0.3, -1, -0.4));
  struct Variant {
    const char* label;
    glm::dvec3 translation;
    double scale;
  };
  std::string expected;
  for (const Variant& v : {Variant{"original", {0, 0, 0}, 1.0}, Variant{"translated 1e5", {1e5, -1e5, 1e5}, 1.0},
                           Variant{"scaled 1e-3", {0, 0, 0}, 1e-3}, Variant{"scaled 1e4", {0, 0, 0}, 1e4},
                           Variant{"scaled 1e-3 at 1e5", {1e5, 2e5, -1e5}, 1e-3}}) {
    const std::string scene = dir / (std::string(v.label) + ".gltf");
    writeGltf(scene, meshes, v.translation, v.scale);
    std::vector<SurfacePoint> moved = points;
    for (SurfacePoint& p : moved) p.position = p.position * v.scale + v.translation;
    const std::string lights = sunArg(sun) + spotArg(spotPos * v.scale + v.translation, spotDir, 0.9, 40 * v.scale);
    const Dir vdir;
    checkAccuracy(vdir, scene, lights, 512, moved, v.label);
    const std::string answers = slurp(vdir / "out.csv");
    if (expected.empty()) {
      expected = answers;
    } else {
      const Table a = readTable(vdir / "out.csv");
      std::ofstream(vdir / "expected.csv") << expected;
      const Table e = readTable(vdir / "expected.csv");
      ASSERT_EQ(a.rows.size(), e.rows.size());
      size_t differ = 0;
      for (size_t i = 0; i < a.rows.size(); ++i) differ += a.rows[i] != e.rows[i];
      EXPECT_EQ(differ, 0u) << v.label << ": " << differ << " of " << a.rows.size() << " points answer differently";
    }
  }
}

TEST(QueryHardCases, PointsExactlyOnVoxelTileAndRegionBoundaries) {
  const Dir dir;
  writeGltf(dir / "court.gltf", courtyard());
  const std::string scene = dir / "court.gltf";
  const uint32_t n = 512, region = 128;
  // A sun straight down: the grid's u and v follow world x and z, so ground points (y = 0) can sit exactly on
  // texel boundaries. Regions of 128 texels, tiles of 8.
  bake(scene, dir / "b.cpvs", n, sunArg({0, -1, 0}) + spotArg({1, 14, -2}, {0.1, -1, 0.05}, 0.8, 40),
       " --region " + std::to_string(region));
  const auto file = orThrow(CpvsFile::open(dir / "b.cpvs"));
  // Ground under a box is inside a closed solid (free voxels, either answer allowed): left out, as in
  // sampleSurface.
  const EmbreeScene rt(worldOf(scene));
  std::vector<SurfacePoint> points;
  auto add = [&](const glm::dvec3& p) {
    if (std::abs(p.x) <= 10 && std::abs(p.z) <= 10 && !rt.isInsideClosedSolid(p + 1e-5 * glm::dvec3(0, 1, 0)))
      points.push_back({p, glm::dvec3(0, 1, 0)});
  };
  for (const auto& light : file->lights()) {
    const LightView& view = light.views[0].view;
    // Every 8th texel boundary in u and v (tile boundaries; every 16th of those is a region boundary) and
    // the voxel boundaries next to them, each exactly and one ulp-scale step either side.
    for (uint32_t u = 0; u <= n; u += 8)
      for (uint32_t v = 0; v <= n; v += 24)
        for (double du : {0.0, 1.0, -1e-9, 1e-9})
          for (double dv : {0.0, 3.0}) {
            const glm::dvec3 top = gridToWorld(view, {double(u) + du, double(v) + dv, 0.0});
            const glm::dvec3 bottom = gridToWorld(view, {double(u) + du, double(v) + dv, double(n)});
            // Where that texel line meets the ground plane y = 0.
            const double t = top.y / (top.y - bottom.y);
            if (!(t >= 0 && t <= 1)) continue;
            glm::dvec3 p = top + t * (bottom - top);
            p.y = 0.0;
            add(p);
            // The point exactly on a depth-slice boundary of that texel too.
            const GridPoint g = toGrid(view, p);
            const glm::dvec3 onSlice = gridToWorld(view, {g.uvs.x, g.uvs.y, std::floor(g.uvs.z)});
            add({onSlice.x, 0.0, onSlice.z});
          }
  }
  ASSERT_GT(points.size(), 2000u);
  writeCsv(dir / "edges.csv", points);
  const auto r = query(quote(dir / "b.cpvs") + " --points " + quote(dir / "edges.csv") + " -o " + quote(dir / "o.csv") +
                       " --reference " + quote(scene) + " --report " + quote(dir / "r.json") + " --timing-rounds 0");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const nlohmann::json report = readJson(dir / "r.json");
  for (const auto& light : report.at("lights")) {
    const Accuracy a = accuracyOf(light);
    EXPECT_LE(a.misclassifiedUniform, 0.001) << light.at("name");
    EXPECT_LE(a.misclassified, 0.01) << light.at("name");
  }
  // The same points with PCF stay in [0, 1] and answer lit where the whole ground around them is lit.
  const auto pcf = query(quote(dir / "b.cpvs") + " --points " + quote(dir / "edges.csv") + " -o " +
                         quote(dir / "pcf.csv") + " --pcf 9");
  ASSERT_EQ(pcf.exitCode, 0) << pcf.output;
  const Table unfiltered = readTable(dir / "o.csv"), filtered = readTable(dir / "pcf.csv");
  ASSERT_EQ(filtered.rows.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i)
    for (size_t l = 0; l < filtered.columns.size(); ++l) {
      ASSERT_GE(filtered.rows[i][l], 0.0);
      ASSERT_LE(filtered.rows[i][l], 1.0);
      if (filtered.rows[i][l] == 1.0) {
        EXPECT_EQ(unfiltered.rows[i][l], 1.0) << "point " << i << " light " << l;
      }
    }
}

TEST(QueryReference, ExcludedMeshesLeaveTheReferenceAndChangeTheError) {
  const Dir dir;
  writeCsv(dir / "p.csv", tinyPoints());
  const std::string scene = sourcePath("data/scenes/Tiny/tiny.gltf");
  auto run = [&](const std::string& extra) {
    const auto r = query(quote(tinyCpvs()) + " --points " + quote(dir / "p.csv") + " -o " + quote(dir / "o.csv") +
                         " --reference " + quote(scene) + " --report " + quote(dir / "r.json") +
                         " --timing-rounds 0" + extra);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    return readJson(dir / "r.json").at("reference");
  };
  const auto full = run("");
  const auto noBox = run(" --exclude-mesh Box");
  EXPECT_LE(full.at("misclassified").get<double>(), 0.01);
  // Without the boxes the reference sees no casters but the ground.
  EXPECT_GT(noBox.at("reference_lit_fraction").get<double>(), full.at("reference_lit_fraction").get<double>());
  // The boxes' shadows on the ground are now errors (about 3 % of Tiny's surface points).
  EXPECT_GT(noBox.at("misclassified").get<double>(), full.at("misclassified").get<double>() + 0.01);
  // Where to look: the first rows misclassified among the uniform points (inside the boxes' shadows), pooled
  // over the lights in input order, each once.
  const auto rows = noBox.at("first_misclassified_uniform_points").get<std::vector<uint64_t>>();
  ASSERT_GT(noBox.at("misclassified_uniform_count").get<uint64_t>(), 0u);
  ASSERT_FALSE(rows.empty());
  EXPECT_LE(rows.size(), 20u);
  for (size_t i = 1; i < rows.size(); ++i) EXPECT_LT(rows[i - 1], rows[i]);
  EXPECT_LT(rows.back(), tinyPoints().size());
  EXPECT_TRUE(full.at("first_misclassified_uniform_points").empty());
  // Over all points: as many rows as there are misclassified points (up to 20), each a misclassified one.
  const auto all = noBox.at("first_misclassified_points").get<std::vector<uint64_t>>();
  EXPECT_EQ(all.size(), std::min<uint64_t>(20, noBox.at("misclassified_count").get<uint64_t>()));
  for (uint64_t row : rows) {
    if (row > all.back()) break;
    EXPECT_TRUE(std::find(all.begin(), all.end(), row) != all.end()) << row;
  }
  EXPECT_EQ(full.at("first_misclassified_points").size(),
            std::min<uint64_t>(20, full.at("misclassified_count").get<uint64_t>()));
}

}  // namespace
}  // namespace cpvs
