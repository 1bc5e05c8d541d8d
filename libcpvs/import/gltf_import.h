#pragma once
// glTF 2.0 import (docs/architecture.md): triangle geometry, node transforms, instancing and KHR_lights_punctual.
#include <string>
#include <vector>

#include "libcpvs/scene/scene.h"

namespace cpvs {

// Loads a .gltf (JSON, external or embedded buffers) or .glb (binary) file; the kind is decided by the
// "glTF" magic at the start of the file, not by the extension.
//
// What becomes of the file:
// * The default scene is imported (`scene`, else scene 0, else every node that is no node's child).
// * Every triangle primitive (mode TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN; strips and fans become
//   triangle lists) of a mesh that a node of that scene uses becomes one cpvs Mesh. Points and lines are
//   skipped with a warning; triangles that repeat an index are dropped.
// * Mesh names: the glTF mesh name ("mesh<i>" when it has none). When a glTF mesh has several
//   primitives, each cpvs Mesh is named "<name>#<primitive index>", e.g. "Circle#1". excludeMeshes()
//   takes "Circle" to mean every primitive of that glTF mesh and "Circle#1" to mean just that one.
// * Every node that uses a mesh adds one Instance per primitive (node name, else "node<i>"), with its
//   world transform. A mesh shared by several nodes is decoded once. A node with EXT_mesh_gpu_instancing
//   places its mesh once per instance instead (world = node * TRANSLATION * ROTATION * SCALE of the
//   instance; named "<node>[<k>]"); every attribute accessor must have the same count.
// * Compressed geometry is decoded first (libcpvs/import/compressed_geometry.h): EXT_meshopt_compression and
//   KHR_meshopt_compression bufferViews (their fallback buffers are never read), KHR_draco_mesh_compression
//   primitives (every attribute the extension names, and the indices).
// * Positions: float VEC3, or the integer types of KHR_mesh_quantization (normalized or not). Sparse
//   accessors are applied. Indices: unsigned byte, short or int.
// * Each Mesh is classified by classifyMesh() (closed / open, from the geometry alone).
// * Lights: KHR_lights_punctual lights placed by nodes of the scene, in world space (position = node
//   origin, direction = node's local -Z), with the extension's defaults. Name: the light's name, else the
//   node's, else "light<i>". A light used by several nodes gives several lights.
// * Materials: each Mesh keeps its material's baseColorFactor (what cpvs-view shades with; textures are
//   not decoded; a factor outside [0, 1] is clamped with a warning). Cameras: perspective cameras placed by
//   nodes of the scene, in world space (eye = node origin, looking along the node's -Z with +Y up);
//   orthographic, malformed or degenerate ones are skipped with a warning (they never fail an import).
// * Anything that cannot be imported correctly (unreadable file, index or accessor out of range, NaN/Inf
//   positions, recursive node graph, a corrupt meshopt or Draco stream, a meshopt stream of a version this
//   build's libmeshoptimizer cannot decode, a scene without any triangle) throws
//   Error(ErrorCategory::InvalidInput) naming the file and the element. A file that uses a geometry
//   extension cpvs does not import (KHR_node_visibility, KHR_mesh_primitive_restart; in extensionsUsed or
//   extensionsRequired) throws Error(ErrorCategory::NotSupported) naming it, before any buffer is read.
//   Things that are ignored without harm (images, skins, morph targets, non-triangle primitives) go to
//   scene.warnings.
// Safe on untrusted input: every offset and size is checked before it is read, and the rules of
// libcpvs/import/untrusted_input.h (JSON depth and size, GLB and asset versions, which files buffers may come
// from) hold before tinygltf parses the file.
struct ImportOptions {
  // Buffers may be read from files outside the scene's folder (by default a uri such as "../../etc/passwd"
  // is refused; docs/robustness.md).
  bool allowExternalUris = false;
  // Decode the materials' base-colour textures (PNG, JPEG; at most 8192 on a side; TEXCOORD_0 only) into
  // Scene::textures and Mesh::uvs, for cpvs-view. Off by default: shadows never need images. An image that
  // cannot be read gives a warning and no texture, never a failed import.
  bool loadBaseColorTextures = false;
  // Alpha-tested shadow casters (docs/alpha.md): MASK materials cut at their alphaCutoff, BLEND ones by
  // `transparent`. Off: every material casts as OPAQUE.
  bool alphaTest = true;
  TransparentPolicy transparent = TransparentPolicy::Clip;
  // Meshes whose material name matches one of these shell patterns (fnmatch) cast no shadow. A pattern that
  // matches no material of the file is an error (Error(InvalidArgument)), so a typo does not go unnoticed.
  std::vector<std::string> excludeMaterials = {};
};

Scene importGltf(const std::string& path, const ImportOptions& options = {});

}  // namespace cpvs
