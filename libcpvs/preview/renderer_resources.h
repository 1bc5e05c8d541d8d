#pragma once
// What cpvs-view uploads once and every frame's passes share: the GL context and the common passes' programs,
// the scene's triangles (a vertex array and, for the per-frame shadow maps, their world corners), base-colour
// textures and coverage masks, every light's records, views and DAGs, and the G-buffer targets. The shadow
// techniques (shadow_pass.h) read these; each keeps its own programs and buffers.
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/gl/gl_context.h"
#include "libcpvs/preview/caster_culling.h"
#include "libcpvs/reference/shadow_reference.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/scene/scene.h"

namespace cpvs {

// Storage-buffer bindings shared with the shaders (scene_buffers.glsl, light_lists.comp, shading.comp).
namespace binding {
enum : GLuint {
  kTileBounds = 0, kLightReals = 1, kLightWords = 2, kTileCounts = 3, kTileOffsets = 4, kTileLights = 5,
  kViewReals = 6, kViewWords = 7, kDagNodes = 8, kDagLeaves = 9, kVisibility = 10, kCells = 11, kRadiance = 12,
  kStats = 13, kMaskHeaders = 14, kMaskBytes = 15, kSuperCounts = 16, kSuperLights = 17, kSuperBounds = 18,
  kTileBits = 19, kWorkCounters = 30,
  // ManyPSMs' traversal and splats (many_psm_traverse.comp, many_psm_splat.vert).
  kPsmNodes = 20, kPsmViews = 21, kPsmItemsIn = 22, kPsmItemsOut = 23, kPsmCounters = 24, kPsmTriangles = 25,
  kPsmPoints = 26, kPsmLeafTriangles = 27, kPsmViewCounters = 28, kPsmIndirect = 29, kPsmVertices = 31,
};
}  // namespace binding

// Floats per vertex of RendererResources::vertexBuffer (renderer_resources.cpp's uploadTriangles says which).
inline constexpr uint32_t kVertexFloats = 17;

// Screen tiles per super-tile side in the light lists' first level (light_lists.comp, super_bounds.comp).
inline constexpr uint32_t kSuperTile = 8;

// "#version 450\n" and the parts, in order: a compute shader's source (with CPVS_SUPER_TILE defined).
std::string computeSource(std::initializer_list<const char*> parts);

// GL buffers made for one frame (or one technique's frame), deleted together.
class FrameBuffers {
public:
  explicit FrameBuffers(const gl::Context& context) : context_(context) {}
  ~FrameBuffers();
  FrameBuffers(const FrameBuffers&) = delete;
  FrameBuffers& operator=(const FrameBuffers&) = delete;
  GLuint add(GLuint buffer) {
    names_.push_back(buffer);
    return buffer;
  }

private:
  const gl::Context& context_;
  std::vector<GLuint> names_;
};

class RendererResources {
public:
  // Creates the context (Error(NotSupported) without GL 4.5 compute shaders), links the common programs and
  // uploads the scene and the lights. `threads` bounds the CPU-side techniques (0: all cores).
  RendererResources(const Scene& scene, std::vector<LightShadow> lights, bool egl, unsigned threads);
  ~RendererResources();
  RendererResources(const RendererResources&) = delete;
  RendererResources& operator=(const RendererResources&) = delete;

  const gl::Functions& gl() const { return context->gl(); }
  // Threads for CPU work: the renderer's bound, or every core.
  unsigned threadCount() const;
  // The G-buffer targets at this size (recreated when it changes).
  void ensureTargets(uint32_t width, uint32_t height);
  std::vector<glm::vec4> readTarget(int attachment, uint32_t width, uint32_t height) const;
  // Throws Error(RuntimeFailure) when one storage buffer would exceed what the context allows (beyond it a
  // shader's reads and writes would silently go wrong).
  void requireStorage(size_t bytes, const std::string& what, const std::string& hint = "a smaller --size helps") const;
  // Embree over the scene, built on first use (the ray-traced technique and --compare).
  const ShadowReference& rays();
  // The lights' disabled flags as uploaded; re-uploaded when they change.
  void setDisabledLights(const std::vector<uint32_t>& disabled);

  std::unique_ptr<gl::Context> context;
  const Scene* scene = nullptr;
  std::vector<LightShadow> lights;
  unsigned threads = 0;
  Bounds bounds;  // the scene's, for the clip planes and the voxel grid (computed once)
  size_t triangles = 0, staticBytes = 0, shadowBytes = 0, textureBytes = 0;
  size_t maxStorageBlock = 0;  // GL_MAX_SHADER_STORAGE_BLOCK_SIZE
  size_t dagBufferBytes = 0;   // the larger of the GPU walk's two DAG buffers (nodes, leaves)

  GLuint gbufferProgram = 0, boundsProgram = 0, countProgram = 0, fillProgram = 0, prefixProgram = 0,
         shadingProgram = 0;
  // The light lists' first level: super-tiles of 8 x 8 tiles, their bounds, their lights (light_lists.comp).
  GLuint superBoundsProgram = 0, superListProgram = 0;
  // The triangles as the G-buffer draws them (one vertex per corner), and their world corners in that order
  // with whether each casts (the per-frame shadow maps draw from the same array).
  GLuint vertexArray = 0, vertexBuffer = 0;
  GLsizei vertexCount = 0;
  CasterTriangles casterTriangles;
  // Per instance (in Scene::instances order, cut-away meshes left out), the triangles it drew that cast:
  // ManyPSMs' scene tree keeps each instance a subtree of its own.
  std::vector<std::vector<uint32_t>> castingTrianglesOfInstance;
  GLuint baseColorArray = 0;              // one layer per Scene::textures entry (a 1-layer white array when none)
  GLuint maskHeaders = 0, maskBytes = 0;  // the coverage masks gbuffer.frag cuts with (kMaskHeaders, kMaskBytes)
  GLuint lightReals = 0, lightWords = 0, viewReals = 0, viewWords = 0;
  // The DAGs, uploaded by uploadDags() when the GPU walk first needs them (0 until then): the other shadow
  // techniques never read them, and a GPU may not hold them (llvmpipe allows 128 MiB per buffer).
  GLuint dagNodes = 0, dagLeaves = 0;
  // G-buffer targets: position, normal, base colour, depth.
  uint32_t targetWidth = 0, targetHeight = 0;
  GLuint framebuffer = 0, targets[4] = {};

private:
  void linkPrograms();
  void uploadTriangles(const Scene& scene);
  void uploadTextures(const std::vector<Texture>& textures);
  void uploadMasks(const Scene& scene);
  void uploadLights();

public:
  // Uploads the DAGs once (counted in staticBytes). Throws Error(RuntimeFailure) when they exceed the GPU's
  // storage-block size.
  void uploadDags();

private:
  std::optional<ShadowReference> reference_;
  std::vector<uint32_t> lightWordsData_;  // as uploaded; the disabled flags change between frames
  std::vector<uint32_t> disabled_;        // the flags last uploaded
};

}  // namespace cpvs
