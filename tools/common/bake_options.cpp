#include "tools/common/bake_options.h"

#include "libcpvs/base/error.h"
#include "libcpvs/base/memory_limit.h"
#include "libcpvs/dag/leaf_table.h"
#include "tools/common/cli.h"

namespace cpvs::tools {
namespace {

// For --help: a CPVS_MEMORY_LIMIT that is not a size is reported when a bake starts, not here.
MemoryLimit defaultBudgetOrNone() {
  try {
    return defaultMemoryBudget();
  } catch (const Error&) {
    return {};
  }
}

// Where ulimit -v or -d is set, the second budget it gives (checked besides the first): for --help.
std::string mappedNote() {
  const MemoryLimit mapped = defaultMappedBudget();
  return mapped.bytes ? ", here " + formatMemorySize(mapped.bytes) + " (" + mapped.source + ")" : "";
}

}  // namespace

void BakeShapeOptions::addTo(CLI::App& app) {
  app.add_option("-r,--resolution", resolution, "Voxel grid N per view: a power of two, 8..256k (e.g. 4k, 16k)")
      ->capture_default_str();
  app.add_option("--voxel-size", voxelSize,
                 "Per light, the smallest resolution whose voxels are at most this big (scene units) at the farthest "
                 "geometry it reaches; --resolution is then the most any light gets")
      ->type_name("SIZE");
  app.add_option("--undefined", undefinedMode,
                 "Free voxels inside closed solids: kampe (Kämpe et al. 2015, §3.4), sintorn (2014), none")
      ->capture_default_str();
  app.add_flag("--no-cone-crop", noConeCrop,
               "Bake a spot light's whole square view, also where it lies outside the cone (never looked up), to "
               "measure it");
  app.add_flag("--no-node-reuse", noNodeReuse, "Build every node (skip Kämpe et al. 2015, §3.2), to measure it");
  app.add_flag("--per-texel", perTexel,
               "Rasterise every tile texel by texel, also uniform ones whose slices follow from planes (same bytes; "
               "the reference path, to measure the fast one)");
  app.add_option("--region", regionSize, "Largest region rendered at once (power of two); bounds memory")
      ->capture_default_str();
  const MemoryLimit budget = defaultBudgetOrNone();
  app.add_option("--max-memory", maxMemory,
                 "Memory budget (e.g. 2G), or none: smaller regions where they help, else stop with exit 4 before "
                 "the system runs out (resident memory, plus what encoding the DAG would need, checked after every "
                 "region). Default: the memory this process may use (cgroup limit, CPVS_MEMORY_LIMIT, else physical memory) less an "
                 "eighth (64 MiB to 4 GiB), here " +
                     (budget.bytes ? formatMemorySize(budget.bytes) + " (" + budget.source + ")" : std::string("none")) +
                     "; where ulimit -v or -d is set, also that limit less an eighth, counted in mapped memory" +
                     mappedNote())
      ->type_name("SIZE|none");
  app.add_option("--max-peels", maxPeels,
                 "Cap on exit-depth peel iterations: each resolves one level of nested closed solids; beyond it exits "
                 "are set early (never wrong, less compression)")
      ->capture_default_str();
  app.add_option("--max-voxel-error", maxVoxelError,
                 "Lossy bake (off by default): a shadow may start up to this many voxels behind the surface that "
                 "casts it, and anywhere in the empty space in front of the next surface behind it (no receiver "
                 "lies there). 0 keeps nearly every unfiltered answer on a surface (wide PCF reads some of the empty "
                 "space); docs/lossy.md")
      ->type_name("VOXELS");
  app.add_option("--max-edge-error", maxEdgeError,
                 "Lossy leaves (off by default): an 8x8 texel slice of a light's view may be answered by one baked "
                 "before it that differs in at most this many texels (0, 1 or 2), each on a shadow edge; "
                 "docs/lossy.md")
      ->type_name("TEXELS");
  app.add_option("--ground", ground,
                 "auto: an open mesh that is a height field spanning the scene (a terrain, a ground plane) is the "
                 "top of solid ground, so the voxels under it are free (docs/depth-maps.md); off: every open mesh "
                 "is a sheet with air on both sides")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "off"}));
  app.add_option("--format-version", formatVersion,
                 "The .cpvs major version to write: 2 (a DAG per view, what every cpvs runtime reads) or 3 (one pool "
                 "of nodes and leaves for the whole file: many-light files about a third smaller; readers from "
                 "cpvs 0.5 on; formats/cpvs/format.md)")
      ->capture_default_str()
      ->type_name("2|3");
}

void BakeShapeOptions::applyTo(BakeSettings& settings) const {
  if (maxPeels < 1 || maxPeels > 1024) throw Error(ErrorCategory::InvalidArgument, "--max-peels must be in 1..1024");
  if (voxelSize != 0 && !(voxelSize > 0 && voxelSize < 1e18))
    throw Error(ErrorCategory::InvalidArgument, "--voxel-size must be a positive, finite size in scene units");
  settings.resolution = forFlag("--resolution", [&] { return parseResolution(resolution); });
  settings.voxelSize = voxelSize;
  settings.undefinedMode = forFlag("--undefined", [&] { return parseUndefinedMode(undefinedMode); });
  settings.nodeReuse = !noNodeReuse;
  settings.perTexel = perTexel;
  settings.cropToCone = !noConeCrop;
  settings.regionSize = forFlag("--region", [&] { return parseResolution(regionSize); });
  settings.peel.maxPeels = maxPeels;
  if (maxMemory.empty()) {
    const MemoryLimit budget = defaultMemoryBudget();
    settings.maxMemoryBytes = budget.bytes;
    settings.maxMemorySource = budget.bytes ? "default: " + budget.source : "";
    settings.maxMemoryOnlyStops = true;
  } else if (maxMemory == "none") {
    settings.maxMemoryBytes = 0;
    settings.maxMemorySource = "none";
  } else {
    settings.maxMemoryBytes = forFlag("--max-memory", [&] { return parseByteSize(maxMemory); });
    settings.maxMemorySource = "--max-memory " + maxMemory;
  }
  if (maxMemory != "none") {  // a limit on mapped memory holds whatever budget was asked for
    const MemoryLimit mapped = defaultMappedBudget();
    settings.maxMappedBytes = mapped.bytes;
    settings.maxMappedMeasure = mapped.measure;
    settings.maxMappedSource = mapped.bytes ? "default: " + mapped.source : "";
  }
  settings.ground = forFlag("--ground", [&] { return parseGroundSheets(ground); });
  if (maxVoxelError != -1) {
    if (maxVoxelError < 0 || maxVoxelError > (int64_t(1) << 18))
      throw Error(ErrorCategory::InvalidArgument, "--max-voxel-error must be a number of voxels in 0..262144");
    if (settings.undefinedMode != UndefinedMode::Kampe)
      throw Error(ErrorCategory::InvalidArgument, "--max-voxel-error needs --undefined kampe (the default)");
    settings.maxVoxelError = uint32_t(maxVoxelError);
  }
  if (maxEdgeError < 0 || maxEdgeError > int64_t(LeafTable::kMaxEdgeFlips))
    throw Error(ErrorCategory::InvalidArgument, "--max-edge-error must be 0, 1 or 2 texels");
  settings.maxEdgeError = uint32_t(maxEdgeError);
  if (!canWriteMajor(formatVersion))
    throw Error(ErrorCategory::InvalidArgument, "--format-version must be 2 or 3 (got " + std::to_string(formatVersion) + ")");
  settings.formatMajor = uint16_t(formatVersion);
}

}  // namespace cpvs::tools
