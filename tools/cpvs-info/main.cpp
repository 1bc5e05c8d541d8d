// cpvs-info: prints what a scene holds (meshes and their closedness, instances, lights, bounds) or what a
// .cpvs file holds (header, bake settings, lights, views, DAG levels, bytes, checksums), as text or JSON. The
// kind of input is decided by its first bytes, not by its name. See --help.
#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "formats/cpvs/cpvs_format.h"
#include "libcpvs/import/gltf_import.h"
#include "libcpvs/scene/scene.h"
#include "tools/common/cli.h"
#include "tools/common/input_kind.h"
#include "tools/common/bake_options.h"
#include "tools/common/ground_json.h"
#include "tools/cpvs-info/info_common.h"

namespace {

using cpvs::Light;
using cpvs::Mesh;
using cpvs::Scene;
using cpvs::WorldGeometry;
using cpvs::info::jsonVec;
using cpvs::info::kTool;
using cpvs::info::number;
using cpvs::info::vec;

std::string caster(const Mesh& mesh);

std::string topology(const Mesh& mesh) {
  std::string text = mesh.closed ? "closed" : "open";
  if (mesh.closed && mesh.insideOut) text += ", inside-out (flipped when baked)";
  if (!mesh.closed)
    text += " (" + std::to_string(mesh.boundaryEdges) + " boundary, " + std::to_string(mesh.nonManifoldEdges) +
            " non-manifold, " + std::to_string(mesh.inconsistentEdges) + " inconsistent edges)";
  return text + caster(mesh);
}

// What the mesh does as a shadow caster, when that is not simply "casts" (docs/alpha.md).
std::string caster(const Mesh& mesh) {
  if (mesh.cutAway) return "; alpha cuts it away entirely: casts nothing (clear glass)";
  if (!mesh.castsShadows) return "; casts no shadow";
  if (mesh.coverageMask >= 0) return "; alpha-tested (cut by its material's alpha, never a closed solid)";
  return "";
}

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
    std::cout << "  " << instance.node << " -> " << scene.meshes[instance.mesh].name
              << (instance.castsShadows ? "" : " (the node casts no shadow)") << "\n";
  std::cout << "lights (" << scene.lights.size() << ")"
            << (scene.lights.empty() ? ": none in the scene (KHR_lights_punctual); give --sun, --spot or --point to cpvs-bake"
                                     : ":")
            << "\n";
  for (const Light& light : scene.lights) std::cout << "  " << cpvs::info::lightText(light) << "\n";
  std::cout << "bounds: min " << vec(world.bounds.min) << " max " << vec(world.bounds.max) << " extent "
            << vec(world.bounds.extent()) << "\n";
  std::cout << "totals: " << scene.meshes.size() << " meshes (" << totals.closedMeshes << " closed), "
            << scene.instances.size() << " instances, " << totals.worldTriangles << " triangles cast shadows ("
            << totals.closedWorldTriangles << " closed, " << totals.worldTriangles - totals.closedWorldTriangles
            << " open, " << world.masked.count() << " alpha-tested), " << scene.lights.size() << " lights\n";
  if (world.groundSheets.empty()) std::cout << "ground sheets: none found (" << world.noGroundSheet << ")\n";
  for (const cpvs::GroundSheet& g : world.groundSheets)
    std::cout << "ground: " << g.mesh << " (node " << g.node << ") "
              << (g.used ? "is the top of solid ground: the voxels under it are free when baked"
                         : "spans the scene but is not taken as ground: " + g.reason)
              << "\n";
}

nlohmann::ordered_json groundJson(const WorldGeometry& world) {
  nlohmann::ordered_json sheets = nlohmann::ordered_json::array();
  for (const cpvs::GroundSheet& g : world.groundSheets)
    sheets.push_back(cpvs::tools::groundSheetJson(g));
  return sheets;
}

void printJson(const Scene& scene, const WorldGeometry& world, const Totals& totals, uint64_t inputHash) {
  nlohmann::ordered_json meshes = nlohmann::ordered_json::array();
  for (const Mesh& mesh : scene.meshes)
    meshes.push_back({{"name", mesh.name},
                      {"triangles", mesh.triangleCount()},
                      {"vertices", mesh.positions.size()},
                      {"closed", mesh.closed},
                      {"insideOut", mesh.insideOut},
                      {"boundaryEdges", mesh.boundaryEdges},
                      {"nonManifoldEdges", mesh.nonManifoldEdges},
                      {"inconsistentEdges", mesh.inconsistentEdges},
                      {"material", mesh.material},
                      {"castsShadows", mesh.castsShadows},
                      {"alphaTested", mesh.coverageMask >= 0},
                      {"cutAway", mesh.cutAway}});
  nlohmann::ordered_json instances = nlohmann::ordered_json::array();
  for (const cpvs::Instance& instance : scene.instances)
    instances.push_back({{"node", instance.node},
                         {"mesh", scene.meshes[instance.mesh].name},
                         {"meshIndex", instance.mesh},
                         {"castsShadows", instance.castsShadows}});
  nlohmann::ordered_json lights = nlohmann::ordered_json::array();
  for (const Light& light : scene.lights) lights.push_back(cpvs::info::lightJson(light));
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
        {"alphaTestedTriangles", world.masked.count()},
        {"lights", scene.lights.size()}}},
      {"groundSheets", groundJson(world)},
      // Why groundSheets is empty (null when it is not).
      {"noGroundSheet", world.groundSheets.empty() ? nlohmann::ordered_json(world.noGroundSheet) : nlohmann::ordered_json(nullptr)},
      {"warnings", scene.warnings},
      // What a cpvs-bake with the same lights and bake options writes into its file's BAKE block.
      {"input_hash", cpvs::hex64(inputHash)}};
  std::cout << report.dump(2) << "\n";
}

int printScene(const std::string& path, const cpvs::tools::LightOptions& lightOptions,
               const cpvs::ImportOptions& import, const cpvs::tools::BakeShapeOptions& shape, bool json) {
  cpvs::BakeSettings settings;
  shape.applyTo(settings);
  Scene scene = cpvs::importGltf(path, import);
  lightOptions.applyTo(scene);
  for (const std::string& warning : scene.warnings) std::cerr << kTool << ": warning: " << warning << "\n";
  const WorldGeometry world = cpvs::flatten(scene, settings.ground);
  Totals totals;
  for (const Mesh& mesh : scene.meshes) totals.closedMeshes += mesh.closed ? 1 : 0;
  // The scene's own triangles: a ground sheet's counts as open (as its mesh is), its closing ones not at all.
  totals.worldTriangles = world.sceneTriangleCount();
  totals.closedWorldTriangles = world.closedMeshTriangleCount();
  const uint64_t inputHash = cpvs::sceneInputHash(scene, settings);
  if (json) {
    printJson(scene, world, totals, inputHash);
  } else {
    printText(scene, world, totals);
    std::cout << "input hash (of a cpvs-bake with these lights and bake options): " << cpvs::hex64(inputHash) << "\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Prints what a scene (.gltf, .glb) holds: meshes (closed or open, from the geometry),\n"
               "instances, lights, bounds and totals.\n"
               "Or what a baked .cpvs file holds: format version, tool version, input hash and bake settings;\n"
               "per light its type, name, colour, intensity, range and cone; per view its cube face, resolution\n"
               "N, projection, near/far, depth mapping, nodes per DAG level, unique leaves and bytes; the\n"
               "sections with their XXH3-64 checksums. Format 1.x files are read too (their DAGs converted).\n"
               "The file is validated in full first: a corrupt, truncated or foreign file, or one of a major\n"
               "format version this build does not read, is reported with exit code 2, naming the file and\n"
               "what is wrong, with the checksum status of every section that can be located. The kind of\n"
               "input is decided by its first bytes, not by its name.\n"
               "Format: formats/cpvs/format.md.",
               kTool};
  cpvs::tools::addStandardFlags(app, kTool);
  std::string input;
  bool json = false;
  app.add_option("INPUT", input, "Scene file (.gltf or .glb) or baked file (.cpvs)")->required()->type_name("SCENE|FILE.cpvs");
  app.add_flag("--json", json, "Print JSON instead of text");
  cpvs::tools::LightOptions lightOptions;
  lightOptions.addTo(app);
  cpvs::ImportOptions importOptions;
  cpvs::tools::addImportOptions(app, importOptions);
  // The options that shape a bake's bytes, for the input hash a bake with them would write.
  cpvs::tools::BakeShapeOptions shape;
  shape.addTo(app);
  if (const auto done = cpvs::tools::parseCommandLine(app, argc, argv)) return *done;
  return cpvs::tools::runMain(kTool, [&] {
    // Everything that is no scene (an empty file included) goes to the .cpvs reader, whose message says
    // what it is not.
    std::error_code ec;
    if (!std::filesystem::exists(input, ec))
      throw cpvs::Error(cpvs::ErrorCategory::InvalidInput, input + ": cannot open: no such file");
    const cpvs::tools::InputKind kind = cpvs::tools::sniffInput(input);
    if (kind == cpvs::tools::InputKind::Scene) return printScene(input, lightOptions, importOptions, shape, json);
    if (lightOptions.any() || !lightOptions.excludedMeshes.empty())
      throw cpvs::Error(cpvs::ErrorCategory::InvalidArgument, input + ": --sun, --spot, --point and --exclude-mesh apply to "
                                               "scenes; a .cpvs file holds the lights it was baked with");
    return cpvs::info::printCpvs(input, json);
  });
}
