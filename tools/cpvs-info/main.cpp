// cpvs-info: prints what a scene holds (meshes and their closedness, instances, lights, bounds), as text
// or JSON. See --help.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "formats/gltf/gltf_import.h"
#include "libcpvs/scene.h"
#include "tools/common/cli.h"

namespace {

using cpvs::Light;
using cpvs::LightType;
using cpvs::Mesh;
using cpvs::Scene;
using cpvs::WorldGeometry;

constexpr const char* kTool = "cpvs-info";

std::string number(double value) {
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

std::string vec(const glm::dvec3& v) { return "(" + number(v.x) + ", " + number(v.y) + ", " + number(v.z) + ")"; }

nlohmann::ordered_json jsonVec(const glm::dvec3& v) { return nlohmann::ordered_json::array({v.x, v.y, v.z}); }

// A float as the shortest double that reads back as the same float (0.95f prints as 0.95, not 0.949999988).
double shortest(float value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", double(value));
  for (int digits = 1; digits <= 9; ++digits) {
    std::snprintf(text, sizeof text, "%.*g", digits, double(value));
    if (std::strtof(text, nullptr) == value) break;
  }
  return std::strtod(text, nullptr);
}

std::string topology(const Mesh& mesh) {
  std::string text = mesh.closed ? "closed" : "open";
  if (mesh.closed && mesh.insideOut) text += ", inside-out (flipped when baked)";
  if (!mesh.closed)
    text += " (" + std::to_string(mesh.boundaryEdges) + " boundary, " + std::to_string(mesh.nonManifoldEdges) +
            " non-manifold, " + std::to_string(mesh.inconsistentEdges) + " inconsistent edges)";
  return text;
}

bool hasPosition(const Light& light) { return light.type != LightType::Directional; }
bool hasDirection(const Light& light) { return light.type != LightType::Point; }

struct Totals {
  size_t closedMeshes = 0;
  size_t worldTriangles = 0;
  size_t closedWorldTriangles = 0;
};

void printText(const Scene& scene, const WorldGeometry& world, const Totals& totals) {
  std::cout << "scene: " << scene.source << "\n";
  std::cout << "meshes (" << scene.meshes.size() << "):\n";
  for (const Mesh& mesh : scene.meshes)
    std::cout << "  " << mesh.name << ": " << mesh.triangleCount() << " triangles, " << topology(mesh) << "\n";
  std::cout << "instances (" << scene.instances.size() << "):\n";
  for (const cpvs::Instance& instance : scene.instances)
    std::cout << "  " << instance.node << " -> " << scene.meshes[instance.mesh].name << "\n";
  std::cout << "lights (" << scene.lights.size() << "):\n";
  for (const Light& light : scene.lights) {
    std::cout << "  " << cpvs::lightTypeName(light.type) << " '" << light.name << "':";
    if (hasPosition(light)) std::cout << " position " << vec(light.position);
    if (hasDirection(light)) std::cout << " direction " << vec(light.direction);
    std::cout << " colour " << vec(glm::dvec3(light.color)) << " intensity " << number(light.intensity);
    if (hasPosition(light)) std::cout << " range " << number(light.range);
    if (light.type == LightType::Spot)
      std::cout << " cone " << number(light.innerConeAngle) << ".." << number(light.outerConeAngle) << " rad";
    std::cout << "\n";
  }
  std::cout << "bounds: min " << vec(world.bounds.min) << " max " << vec(world.bounds.max) << " extent "
            << vec(world.bounds.extent()) << "\n";
  std::cout << "totals: " << scene.meshes.size() << " meshes (" << totals.closedMeshes << " closed), "
            << scene.instances.size() << " instances, " << totals.worldTriangles << " triangles in the world ("
            << totals.closedWorldTriangles << " closed, " << totals.worldTriangles - totals.closedWorldTriangles
            << " open), " << scene.lights.size() << " lights\n";
}

void printJson(const Scene& scene, const WorldGeometry& world, const Totals& totals) {
  nlohmann::ordered_json meshes = nlohmann::ordered_json::array();
  for (const Mesh& mesh : scene.meshes)
    meshes.push_back({{"name", mesh.name},
                      {"triangles", mesh.triangleCount()},
                      {"vertices", mesh.positions.size()},
                      {"closed", mesh.closed},
                      {"insideOut", mesh.insideOut},
                      {"boundaryEdges", mesh.boundaryEdges},
                      {"nonManifoldEdges", mesh.nonManifoldEdges},
                      {"inconsistentEdges", mesh.inconsistentEdges}});
  nlohmann::ordered_json instances = nlohmann::ordered_json::array();
  for (const cpvs::Instance& instance : scene.instances)
    instances.push_back({{"node", instance.node}, {"mesh", scene.meshes[instance.mesh].name}, {"meshIndex", instance.mesh}});
  nlohmann::ordered_json lights = nlohmann::ordered_json::array();
  for (const Light& light : scene.lights) {
    nlohmann::ordered_json entry = {{"name", light.name},
                            {"type", cpvs::lightTypeName(light.type)},
                            {"color", {shortest(light.color.r), shortest(light.color.g), shortest(light.color.b)}},
                            {"intensity", shortest(light.intensity)}};
    if (hasPosition(light)) {
      entry["position"] = jsonVec(light.position);
      entry["range"] = std::isinf(light.range) ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(light.range);  // null: unlimited
    }
    if (hasDirection(light)) entry["direction"] = jsonVec(light.direction);
    if (light.type == LightType::Spot) {
      entry["innerConeAngle"] = light.innerConeAngle;
      entry["outerConeAngle"] = light.outerConeAngle;
    }
    lights.push_back(entry);
  }
  nlohmann::ordered_json bounds = world.bounds.empty() ? nlohmann::ordered_json(nullptr)
                                               : nlohmann::ordered_json{{"min", jsonVec(world.bounds.min)},
                                                                {"max", jsonVec(world.bounds.max)}};
  const nlohmann::ordered_json report = {
      {"source", scene.source},
      {"meshes", meshes},
      {"instances", instances},
      {"lights", lights},
      {"bounds", bounds},
      {"totals",
       {{"meshes", scene.meshes.size()},
        {"closedMeshes", totals.closedMeshes},
        {"instances", scene.instances.size()},
        {"triangles", totals.worldTriangles},
        {"closedTriangles", totals.closedWorldTriangles},
        {"openTriangles", totals.worldTriangles - totals.closedWorldTriangles},
        {"lights", scene.lights.size()}}},
      {"warnings", scene.warnings}};
  std::cout << report.dump(2) << "\n";
}

int printScene(const std::string& path, const cpvs::tools::LightOptions& lightOptions, bool json) {
  Scene scene = cpvs::importGltf(path);
  lightOptions.applyTo(scene);
  for (const std::string& warning : scene.warnings) std::cerr << kTool << ": warning: " << warning << "\n";
  const WorldGeometry world = cpvs::flatten(scene);
  Totals totals;
  for (const Mesh& mesh : scene.meshes) totals.closedMeshes += mesh.closed ? 1 : 0;
  totals.worldTriangles = world.triangleCount();
  totals.closedWorldTriangles = world.closedTriangleCount;
  if (json)
    printJson(scene, world, totals);
  else
    printText(scene, world, totals);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Prints what a scene holds: meshes (closed or open, from the geometry), instances, lights, "
               "bounds and totals.",
               kTool};
  app.footer(cpvs::tools::exitCodeHelp());
  cpvs::tools::addVersionFlag(app, kTool);
  std::string input;
  bool json = false;
  app.add_option("INPUT", input, "Scene file (.gltf or .glb)")->required();
  app.add_flag("--json", json, "Print JSON instead of text");
  cpvs::tools::LightOptions lightOptions;
  lightOptions.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help/version (code 0) or the usage error
    return code == 0 ? 0 : int(cpvs::ExitCode::Usage);
  }
  return cpvs::tools::runMain(kTool, [&] { return printScene(input, lightOptions, json); });
}
