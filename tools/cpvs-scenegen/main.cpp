// cpvs-scenegen: writes the benchmark scenes (closed city, open city, fractal landscape, city with spot
// lights, the alpha-test scene, the foliage level) as binary glTF. Same arguments, same bytes. See
// docs/scenegen.md.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "generators.h"
#include "glb_writer.h"
#include "tools/common/usage_errors.h"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitUsage = 1;
constexpr int kExitOutput = 3;
constexpr int kExitRuntime = 4;

constexpr const char* kGenerator = "cpvs-scenegen " CPVS_SCENEGEN_VERSION;

struct OutputError {
  std::string message;
};

// The temporary file being written, removed by the signal handler on Ctrl-C / SIGTERM.
char g_tempPath[4096] = {0};

extern "C" void removeTempAndDie(int sig) {
  if (g_tempPath[0] != '\0') ::unlink(g_tempPath);  // async-signal-safe
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

// Writes `bytes` to a temporary file beside `path`, flushes it to disk and renames it over `path`, so
// that `path` never holds a partial file. Throws OutputError.
void writeAtomically(const std::string& path, const std::string& bytes) {
  std::string tmpl = path + ".tmp-XXXXXX";
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0) throw OutputError{"cannot create a temporary file beside '" + path + "': " + std::strerror(errno)};
  if (tmpl.size() < sizeof g_tempPath) {
    std::memcpy(g_tempPath, tmpl.c_str(), tmpl.size() + 1);
    std::signal(SIGINT, removeTempAndDie);
    std::signal(SIGTERM, removeTempAndDie);
  }
  const auto fail = [&](const std::string& what) {
    const std::string reason = std::strerror(errno);
    ::close(fd);
    ::unlink(tmpl.c_str());
    g_tempPath[0] = '\0';
    throw OutputError{what + " '" + path + "': " + reason};
  };
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot write");
    }
    done += static_cast<std::size_t>(n);
  }
  const mode_t mask = ::umask(0);  // mkstemp makes 0600 files; give the usual 0666 & ~umask
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  if (::fsync(fd) != 0) fail("cannot flush");
  if (::close(fd) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(tmpl.c_str());
    g_tempPath[0] = '\0';
    throw OutputError{"cannot close '" + path + "': " + reason};
  }
  if (::rename(tmpl.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(tmpl.c_str());
    g_tempPath[0] = '\0';
    throw OutputError{"cannot rename the temporary file to '" + path + "': " + reason};
  }
  g_tempPath[0] = '\0';
}

std::string fmt(const char* format, double a, double b, double c) {
  char buf[128];
  std::snprintf(buf, sizeof buf, format, a, b, c);
  return buf;
}

struct Request {
  std::string kind, output;
  std::uint64_t triangles = 100000, seed = 1;
  int lights = 165;
  bool gpuInstancing = false;
  bool pointLights = false;
  int groundTiles = 1;
};

int run(const Request& r) {
  using namespace cpvs::scenegen;
  const auto start = std::chrono::steady_clock::now();
  const std::string& kind = r.kind;
  const std::string& output = r.output;
  const std::uint64_t triangles = r.triangles, seed = r.seed;
  GenScene scene;
  std::string layout;
  if (kind == "landscape") {
    scene = generateLandscape({seed, triangles});
  } else if (kind == "alpha-test") {
    scene = generateAlphaTest();
  } else if (kind == "foliage") {
    FoliageInfo info;
    scene = generateFoliage({seed, triangles, r.lights}, &info);
    layout = ", " + std::to_string(info.trees) + " trees of " + std::to_string(info.prototypes) +
             " prototypes, " + std::to_string(info.buildings) + " buildings" +
             fmt(" (leaf texture %.0f %% covered)", 100.0 * info.leafCoverage, 0.0, 0.0);
  } else {
    CityOptions o;
    o.seed = seed;
    o.targetTriangles = triangles;
    o.open = kind == "open-city";
    o.spotLights = kind == "city-spots" ? r.lights : 0;
    o.pointLights = r.pointLights;
    o.groundTiles = r.groundTiles;
    CityInfo info;
    scene = generateCity(o, &info);
    layout = ", " + std::to_string(info.blocksPerSide) + "x" + std::to_string(info.blocksPerSide) + " blocks of " +
             std::to_string(info.lotsPerBlockSide) + "x" + std::to_string(info.lotsPerBlockSide) + " lots" +
             fmt(" (lot %.1f, detail %.2f)", info.lotSize, info.detail, 0.0);
    if (r.gpuInstancing) {
      useGpuInstancing(scene);
      layout += ", GPU instancing";
    }
  }
  const SceneStats stats = computeStats(scene);
  if (kind != "open-city" && kind != "alpha-test" &&
      static_cast<double>(stats.triangles) < 0.8 * static_cast<double>(triangles))
    std::cerr << "cpvs-scenegen: warning: " << kind << " tops out at " << stats.triangles
              << " triangles, below the requested " << triangles << "\n";
  nlohmann::json extras = {{"kind", kind}, {"triangles", stats.triangles}};
  if (kind != "alpha-test") {  // the alpha-test scene is fixed
    extras["seed"] = std::to_string(seed);
    extras["requestedTriangles"] = triangles;
  }
  if (kind == "city-spots" || kind == "foliage") extras["lights"] = r.lights;
  if (r.gpuInstancing) extras["gpuInstancing"] = true;
  if (r.pointLights) extras["pointLights"] = true;
  if (r.groundTiles > 1) extras["groundTiles"] = r.groundTiles;
  const std::string bytes = writeGlb(scene, kGenerator, extras);
  writeAtomically(output, bytes);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::cout << kind << ": " << stats.triangles << " triangles (" << stats.storedTriangles << " stored), "
            << stats.meshes << " meshes, " << stats.instances << " instances, " << stats.lights
            << (stats.lights == 1 ? " light" : " lights") << layout << ", bounds "
            << fmt("(%.1f, %.1f, %.1f)", stats.boundsMin.x, stats.boundsMin.y, stats.boundsMin.z) << ".."
            << fmt("(%.1f, %.1f, %.1f)", stats.boundsMax.x, stats.boundsMax.y, stats.boundsMax.z) << " -> "
            << output << fmt(" (%.2f MB, %.2f s)", static_cast<double>(bytes.size()) / 1.0e6, seconds, 0.0)
            << "\n";
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "cpvs-scenegen: writes deterministic benchmark scenes as binary glTF (.glb), modelled on the scenes of\n"
      "Kaempe et al. (CPVS): a closed city, the same city open (single-sided, no caps), a closed fractal\n"
      "landscape, and the closed city lit by many spot lights (KHR_lights_punctual); and two scenes for\n"
      "alpha-tested casters: the small, fixed alpha-test scene (a masked, a blended and an opaque card over a\n"
      "ground quad) and a foliage level (trees of alpha-masked leaf cards placed by EXT_mesh_gpu_instancing,\n"
      "buildings with glass). y is up. The same arguments always give the same bytes.",
      "cpvs-scenegen"};
  Request r;
  app.add_option("kind", r.kind, "Scene to write: city, open-city, landscape, city-spots, alpha-test or foliage")
      ->required()
      ->type_name("KIND")
      ->check(CLI::IsMember({"city", "open-city", "landscape", "city-spots", "alpha-test", "foliage"}));
  app.add_option("-o,--output", r.output, "Output .glb file (written atomically)")->required();
  CLI::Option* trianglesOption =
      app.add_option("--triangles", r.triangles,
                     "Triangle budget after instancing (approximated; the actual count is printed; default "
                     "100000, foliage 200000)")
          ->check(CLI::Range(std::uint64_t{5000}, std::uint64_t{20000000}));
  CLI::Option* seedOption = app.add_option("--seed", r.seed, "Random seed (any 64-bit integer)")->capture_default_str();
  CLI::Option* lightsOption =
      app.add_option("--lights", r.lights, "Number of spot lights (city-spots: default 165; foliage: default 16)")
          ->check(CLI::Range(1, 10000));
  CLI::Option* instancingOption = app.add_flag(
      "--gpu-instancing", r.gpuInstancing,
      "city, open-city, city-spots: place the meshes through EXT_mesh_gpu_instancing (one node per mesh)");
  CLI::Option* pointsOption = app.add_flag(
      "--point-lights", r.pointLights,
      "city-spots: point lights (six views each) at the spots' places instead of spots (e.g. --lights 120: 720 views)");
  CLI::Option* tilesOption =
      app.add_option("--ground-tiles", r.groundTiles,
                     "city, city-spots: the ground slab as N x N instanced tiles (default 1: one slab; adds 12 N^2 - 12 "
                     "triangles), so that caster culling can leave out the ground a map does not need")
          ->check(CLI::Range(1, 256));
  app.set_version_flag("--version", kGenerator);
  app.footer(
      "Exit codes: 0 ok, 1 usage error, 3 output cannot be written, 4 runtime failure (e.g. out of memory).\n"
      "Example: cpvs-scenegen city --triangles 1000000 -o closed_city_1m.glb");
  try {
    app.parse(argc, argv);
    const bool city = r.kind == "city" || r.kind == "open-city" || r.kind == "city-spots";
    if (lightsOption->count() > 0 && r.kind != "city-spots" && r.kind != "foliage")
      throw CLI::ValidationError("--lights", "only applies to the city-spots and foliage scenes");
    if (tilesOption->count() > 0 && r.kind != "city" && r.kind != "city-spots")
      throw CLI::ValidationError("--ground-tiles", "only applies to the city and city-spots scenes");
    if (pointsOption->count() > 0 && r.kind != "city-spots")
      throw CLI::ValidationError("--point-lights", "only applies to the city-spots scene");
    if (instancingOption->count() > 0 && !city)
      throw CLI::ValidationError("--gpu-instancing", "only applies to the city, open-city and city-spots scenes");
    if (r.kind == "alpha-test" && (trianglesOption->count() > 0 || seedOption->count() > 0))
      throw CLI::ValidationError("--triangles/--seed", "do not apply to the fixed alpha-test scene");
    if (trianglesOption->count() == 0 && r.kind == "foliage") r.triangles = 200000;
    if (lightsOption->count() == 0 && r.kind == "foliage") r.lights = 16;
  } catch (const CLI::ParseError& e) {
    return cpvs::tools::reportParseError(app, e) == 0 ? kExitOk : kExitUsage;
  }
  try {
    return run(r);
  } catch (const OutputError& e) {
    std::cerr << "cpvs-scenegen: error: " << e.message << "\n";
    return kExitOutput;
  } catch (const std::bad_alloc&) {
    std::cerr << "cpvs-scenegen: error: out of memory\n";
    return kExitRuntime;
  } catch (const std::exception& e) {
    std::cerr << "cpvs-scenegen: error: " << e.what() << "\n";
    return kExitRuntime;
  }
}
