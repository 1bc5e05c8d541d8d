// A glTF mesh's primitives into cpvs meshes: the primitive mode, triangulation of lists, strips and fans, the
// positions and indices, the material; each glTF mesh decoded once, on first use.
#include <optional>

#include "libcpvs/import/compressed_geometry.h"
#include "libcpvs/import/gltf_importer.h"

namespace cpvs::gltf {
namespace {

const char* modeName(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES: return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP: return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN: return "TRIANGLE_FAN";
    default: return "unknown";
  }
}

// Triangles of a primitive as a list, from its vertex sequence (the indices, or 0..n-1 without indices).
// Triangles that repeat a vertex are dropped: strips use them to restart, and they cast no shadow.
struct Triangulation {
  std::vector<uint32_t> indices;
  size_t droppedDegenerate = 0;
  size_t ignoredTrailing = 0;
};

Triangulation triangulate(int mode, const std::vector<uint32_t>& sequence) {
  Triangulation result;
  auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
    if (a == b || b == c || c == a) {
      ++result.droppedDegenerate;
      return;
    }
    result.indices.insert(result.indices.end(), {a, b, c});
  };
  const size_t n = sequence.size();
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    result.indices.reserve(n - n % 3);
    for (size_t i = 0; i + 2 < n; i += 3) emit(sequence[i], sequence[i + 1], sequence[i + 2]);
    result.ignoredTrailing = n % 3;
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    // glTF: triangle i is (v_i, v_{i+1+i%2}, v_{i+2-i%2}), which keeps every triangle's winding.
    for (size_t i = 0; i + 2 < n; ++i) emit(sequence[i], sequence[i + 1 + i % 2], sequence[i + 2 - i % 2]);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (size_t i = 1; i + 1 < n; ++i) emit(sequence[0], sequence[i], sequence[i + 1]);
  }
  return result;
}

}  // namespace

// The cpvs meshes made of a glTF mesh's triangle primitives, decoded on first use.
const std::vector<uint32_t>& GltfImporter::meshIds(int meshIndex) {
  if (meshCache_.empty()) meshCache_.resize(model_.meshes.size());
  auto& cached = meshCache_[size_t(meshIndex)];
  if (cached) return *cached;
  const tinygltf::Mesh& mesh = model_.meshes[size_t(meshIndex)];
  const std::string name = mesh.name.empty() ? "mesh" + std::to_string(meshIndex) : mesh.name;
  std::vector<uint32_t> ids;
  for (size_t p = 0; p < mesh.primitives.size(); ++p) {
    // A Draco-compressed primitive's accessors are first pointed at its decoded values.
    gltf::decodeDracoPrimitive(path_, "mesh '" + name + "' primitive " + std::to_string(p), mesh.primitives[p],
                               model_, dracoAccessors_);
    std::optional<Mesh> primitive = importPrimitive(mesh.primitives[p], name, p, mesh.primitives.size() > 1);
    if (!primitive) continue;
    ids.push_back(uint32_t(scene_.meshes.size()));
    scene_.meshes.push_back(std::move(*primitive));
  }
  cached = std::move(ids);
  return *cached;
}

std::optional<Mesh> GltfImporter::importPrimitive(const tinygltf::Primitive& primitive, const std::string& meshName,
                                                  size_t primitiveIndex, bool severalPrimitives) {
  const std::string where = "mesh '" + meshName + "' primitive " + std::to_string(primitiveIndex);
  const int mode = primitive.mode < 0 ? TINYGLTF_MODE_TRIANGLES : primitive.mode;
  if (mode > TINYGLTF_MODE_TRIANGLE_FAN) fail(where + ": unknown primitive mode " + std::to_string(mode));
  if (mode < TINYGLTF_MODE_TRIANGLES) {
    warn(where + ": " + modeName(mode) + " skipped (only triangles cast shadows)");
    return std::nullopt;
  }
  const auto position = primitive.attributes.find("POSITION");
  if (position == primitive.attributes.end()) {
    warn(where + ": no POSITION attribute; skipped");
    return std::nullopt;
  }
  if (!primitive.targets.empty()) warnOnce("morph targets are ignored (meshes are imported in their base shape)");

  Mesh mesh;
  mesh.name = severalPrimitives ? meshName + "#" + std::to_string(primitiveIndex) : meshName;
  mesh.positions = readPositions(position->second, where);
  std::vector<uint32_t> sequence;
  if (primitive.indices >= 0) {
    sequence = readIndices(primitive.indices, where);
    for (uint32_t index : sequence)
      if (index >= mesh.positions.size())
        fail(where + ": index " + std::to_string(index) + " out of range (POSITION accessor " +
             std::to_string(position->second) + " has " + std::to_string(mesh.positions.size()) + " vertices)");
  } else {
    sequence.resize(mesh.positions.size());
    for (size_t i = 0; i < sequence.size(); ++i) sequence[i] = uint32_t(i);
  }
  Triangulation triangles = triangulate(mode, sequence);
  if (triangles.ignoredTrailing)
    warn(where + ": " + std::to_string(triangles.ignoredTrailing) +
         " trailing vertices ignored (TRIANGLES needs a multiple of 3)");
  if (triangles.droppedDegenerate && mode == TINYGLTF_MODE_TRIANGLES) {
    if (degenerate_.primitives++ == 0) degenerate_.first = where;
    degenerate_.triangles += triangles.droppedDegenerate;
  }
  if (triangles.indices.empty()) {
    warn(where + ": no triangles; skipped");
    return std::nullopt;
  }
  mesh.indices = std::move(triangles.indices);
  mesh.baseColor = baseColorOf(primitive, where);
  // The base-colour texture first: an alpha-tested material then takes its alpha from that decode.
  if (options_.loadBaseColorTextures) attachBaseColorTexture(primitive, where, mesh);
  attachCasterAlpha(primitive, where, mesh);
  return mesh;
}

}  // namespace cpvs::gltf
