#include "libcpvs/preview/preview_renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/preview/glsl_sources.h"
#include "libcpvs/preview/gpu_scene.h"
#include "libcpvs/preview/shadow_map_plan.h"
#include "libcpvs/views/view_fitting.h"
#include "libcpvs/raster/gl_context.h"
#include "libcpvs/raster/gl_program.h"
#include "libcpvs/raster/gpu_masks.h"
#include "libcpvs/eval/shadow_map.h"
#include "libcpvs/reference/shadow_reference.h"

#define STB_IMAGE_RESIZE_IMPLEMENTATION
#define STB_IMAGE_RESIZE_STATIC
#include <stb/stb_image_resize.h>

namespace cpvs {

ShadowMode parseShadowMode(const std::string& name) {
  if (name == "gpu") return ShadowMode::Gpu;
  if (name == "cpu") return ShadowMode::Cpu;
  if (name == "raytraced") return ShadowMode::RayTraced;
  if (name == "none") return ShadowMode::None;
  if (name == "shadowmap") return ShadowMode::ShadowMap;
  if (name == "lightcluster") return ShadowMode::LightCluster;
  throw Error(ErrorCategory::InvalidArgument,
              "unknown shadow mode '" + name + "' (expected gpu, cpu, raytraced, none, shadowmap or lightcluster)");
}

const char* shadowModeName(ShadowMode mode) {
  switch (mode) {
    case ShadowMode::Gpu: return "gpu";
    case ShadowMode::Cpu: return "cpu";
    case ShadowMode::RayTraced: return "raytraced";
    case ShadowMode::None: return "none";
    case ShadowMode::ShadowMap: return "shadowmap";
    case ShadowMode::LightCluster: return "lightcluster";
  }
  return "?";
}

Overlay parseOverlay(const std::string& name) {
  if (name == "none") return Overlay::None;
  if (name == "lights-per-tile") return Overlay::LightsPerTile;
  if (name == "difference") return Overlay::Difference;
  if (name == "shadow-count") return Overlay::ShadowCount;
  throw Error(ErrorCategory::InvalidArgument,
              "unknown overlay '" + name + "' (expected none, lights-per-tile, difference or shadow-count)");
}

const char* overlayName(Overlay overlay) {
  switch (overlay) {
    case Overlay::None: return "none";
    case Overlay::LightsPerTile: return "lights-per-tile";
    case Overlay::Difference: return "difference";
    case Overlay::ShadowCount: return "shadow-count";
  }
  return "?";
}

uint64_t ShadowMapFrame::trianglesDrawn() const {
  uint64_t total = 0;
  for (uint64_t t : triangles) total += t;
  return total;
}

double Frame::milliseconds(const std::string& pass) const {
  for (const PassTime& p : passes)
    if (p.pass == pass) return p.milliseconds;
  return 0;
}

namespace {

constexpr uint32_t kMaxImageEdge = 16384;
constexpr GLsizei kVertexFloats = 17;
constexpr GLuint kBaseColorUnit = 4;  // gbuffer.frag's sampler binding
// Base-colour textures share one sRGB array: each resampled to this edge at most (the largest texture's own
// size when smaller), mipmapped.
constexpr uint32_t kTextureEdge = 1024;
// Bindings shared with the shaders (scene_buffers.glsl, light_lists.comp, shading.comp).
enum Binding : GLuint {
  kTileBounds = 0, kLightReals = 1, kLightWords = 2, kTileCounts = 3, kTileOffsets = 4, kTileLights = 5,
  kViewReals = 6, kViewWords = 7, kDagNodes = 8, kDagLeaves = 9, kVisibility = 10, kCells = 11, kRadiance = 12,
  kStats = 13,
};

// A texture into one square layer of the array. Per axis: Catmull-Rom where it grows or keeps its size (the
// filter interpolates, so a kept axis keeps its texels), Mitchell where it shrinks (less aliasing); edges wrap
// as the sampler does; filtered in linear light.
void resampleIntoLayer(const Texture& t, uint8_t* layer, uint32_t edge, size_t index) {
  auto filterFor = [edge](uint32_t from) { return edge >= from ? STBIR_FILTER_CATMULLROM : STBIR_FILTER_MITCHELL; };
  if (!stbir_resize(t.rgba.data(), int(t.width), int(t.height), 0, layer, int(edge), int(edge), 0, STBIR_TYPE_UINT8, 4,
                    3, 0, STBIR_EDGE_WRAP, STBIR_EDGE_WRAP, filterFor(t.width), filterFor(t.height),
                    STBIR_COLORSPACE_SRGB, nullptr))
    throw Error(ErrorCategory::RuntimeFailure, "could not resample base-colour texture " + std::to_string(index) + " (" +
                                                   std::to_string(t.width) + "x" + std::to_string(t.height) + ")");
}

std::string computeSource(std::initializer_list<const char*> parts) {
  std::string s = "#version 450\n";
  for (const char* p : parts) s += p;
  return s;
}

// Buffers owned by the renderer, deleted with it.
struct Buffers {
  const gl::Context* context = nullptr;
  std::vector<GLuint> names;
  GLuint add(GLuint b) {
    names.push_back(b);
    return b;
  }
  void release() {
    if (!names.empty()) context->gl().DeleteBuffers(GLsizei(names.size()), names.data());
    names.clear();
  }
};

}  // namespace

struct PreviewRenderer::State {
  std::unique_ptr<gl::Context> context;
  std::vector<LightShadow> lights;
  std::vector<Light> lightList;
  unsigned threads = 0;
  const Scene* scene = nullptr;
  std::optional<ShadowReference> reference;  // built on first use
  size_t triangles = 0, staticBytes = 0, shadowBytes = 0;
  Bounds bounds;  // the scene's, for the clip planes and the voxel grid (computed once)
  size_t maxStorageBlock = 0;  // GL_MAX_SHADER_STORAGE_BLOCK_SIZE

  GLuint gbufferProgram = 0, boundsProgram = 0, countProgram = 0, fillProgram = 0, prefixProgram = 0,
         shadowProgram = 0, recordingShadowProgram = 0, shadingProgram = 0, mapDepthProgram = 0, mapLookupProgram = 0;
  // The per-frame shadow-map modes: the triangles as the maps draw them (the G-buffer's, in its order), the
  // voxel grid (built on first use), the LightCluster clusters and their cubes (for one count and size).
  CasterTriangles casterTriangles;
  std::unique_ptr<CasterGrid> casterGrid;
  uint32_t clusterCount = 0, clusterSize = 0;
  LightClusters clusters;
  std::vector<std::vector<LightView>> clusterViews;
  GLuint mapArray = 0, mapFramebuffer = 0;
  GLuint baseColorArray = 0;  // one layer per Scene::textures entry (a 1-layer white array when none)
  size_t textureBytes = 0;
  uint32_t mapSize = 0, mapLayers = 0;
  GLuint vertexArray = 0, vertexBuffer = 0;
  GLuint maskHeaders = 0, maskBytes = 0;  // the coverage masks gbuffer.frag cuts with (bindings 14, 15)
  GLsizei vertexCount = 0;
  GLuint lightReals = 0, lightWords = 0, viewReals = 0, viewWords = 0, dagNodes = 0, dagLeaves = 0;
  std::vector<uint32_t> lightWordsData;  // as uploaded; the disabled flags change between frames
  std::vector<uint32_t> disabled;        // the flags last uploaded
  // Render targets, resized with the image.
  uint32_t targetWidth = 0, targetHeight = 0;
  GLuint framebuffer = 0, textures[4] = {};  // position, normal, base colour, depth

  const gl::Functions& gl() const { return context->gl(); }

  void createTargets(uint32_t w, uint32_t h) {
    const gl::Functions& g = gl();
    if (framebuffer) {
      g.DeleteFramebuffers(1, &framebuffer);
      g.DeleteTextures(4, textures);
    }
    g.GenFramebuffers(1, &framebuffer);
    g.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    g.GenTextures(4, textures);
    for (int i = 0; i < 4; ++i) {
      g.BindTexture(GL_TEXTURE_2D, textures[i]);
      g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      if (i < 3) {
        g.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, GLsizei(w), GLsizei(h), 0, GL_RGBA, GL_FLOAT, nullptr);
        g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + GLenum(i), GL_TEXTURE_2D, textures[i], 0);
      } else {
        g.TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, GLsizei(w), GLsizei(h), 0, GL_DEPTH_COMPONENT,
                     GL_FLOAT, nullptr);
        g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, textures[i], 0);
      }
    }
    const GLenum draw[] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
    g.DrawBuffers(3, draw);
    if (g.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error(ErrorCategory::RuntimeFailure, "the G-buffer framebuffer is incomplete on " + context->description());
    gl::checkError(*context, "creating the " + std::to_string(w) + "x" + std::to_string(h) + " G-buffer");
    targetWidth = w;
    targetHeight = h;
  }

  std::vector<glm::vec4> readTexture(int attachment, uint32_t w, uint32_t h) const {
    const gl::Functions& g = gl();
    std::vector<glm::vec4> out(size_t(w) * h);
    g.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
    g.ReadBuffer(GL_COLOR_ATTACHMENT0 + GLenum(attachment));
    g.PixelStorei(GL_PACK_ALIGNMENT, 4);
    g.ReadPixels(0, 0, GLsizei(w), GLsizei(h), GL_RGBA, GL_FLOAT, out.data());
    gl::checkError(*context, "reading back the G-buffer");
    return out;
  }

  // Throws Error(RuntimeFailure) when one storage buffer would exceed what the context allows (beyond it a
  // shader's reads and writes would silently go wrong).
  void requireStorage(size_t bytes, const std::string& what) const {
    if (bytes <= maxStorageBlock) return;
    throw Error(ErrorCategory::RuntimeFailure, what + " need a " + std::to_string(bytes >> 20) + " MiB storage buffer; " +
                                                   context->description() + " allows " +
                                                   std::to_string(maxStorageBlock >> 20) + " MiB (a smaller --size helps)");
  }

  void uploadTextures(const std::vector<Texture>& textures) {
    const gl::Functions& g = gl();
    uint32_t edge = 1;
    for (const Texture& t : textures) edge = std::max({edge, t.width, t.height});
    edge = std::min(edge, kTextureEdge);
    const uint32_t layers = std::max<uint32_t>(1, uint32_t(textures.size()));
    std::vector<uint8_t> pixels(size_t(edge) * edge * 4 * layers, 255);
    for (size_t l = 0; l < textures.size(); ++l) {
      const Texture& t = textures[l];
      uint8_t* layer = pixels.data() + l * size_t(edge) * edge * 4;
      if (t.width == edge && t.height == edge) std::copy(t.rgba.begin(), t.rgba.end(), layer);
      else
        resampleIntoLayer(t, layer, edge, l);
    }
    g.GenTextures(1, &baseColorArray);
    g.BindTexture(GL_TEXTURE_2D_ARRAY, baseColorArray);
    g.TexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_SRGB8_ALPHA8, GLsizei(edge), GLsizei(edge), GLsizei(layers), 0, GL_RGBA,
                 GL_UNSIGNED_BYTE, pixels.data());
    g.GenerateMipmap(GL_TEXTURE_2D_ARRAY);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_REPEAT);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_REPEAT);
    gl::checkError(*context, "uploading " + std::to_string(textures.size()) + " base-colour textures");
    textureBytes = pixels.size();
  }

  // A depth texture array of at least `layers` layers of size x size.
  void ensureMapArray(uint32_t size, uint32_t layers) {
    const gl::Functions& g = gl();
    if (mapArray && mapSize == size && mapLayers >= layers) return;
    if (mapArray) g.DeleteTextures(1, &mapArray);
    if (!mapFramebuffer) g.GenFramebuffers(1, &mapFramebuffer);
    g.GenTextures(1, &mapArray);
    g.BindTexture(GL_TEXTURE_2D_ARRAY, mapArray);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    g.TexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_DEPTH_COMPONENT32F, GLsizei(size), GLsizei(size), GLsizei(std::max(1u, layers)),
                 0, GL_DEPTH_COMPONENT, GL_FLOAT, nullptr);
    gl::checkError(*context, "allocating " + std::to_string(layers) + " shadow maps of " + std::to_string(size) + "^2");
    mapSize = size;
    mapLayers = std::max(1u, layers);
  }

  const ShadowReference& rays() {
    if (!reference) reference.emplace(flatten(*scene));
    return *reference;
  }
};

PreviewRenderer::PreviewRenderer(const Scene& scene, std::vector<LightShadow> lights, RasterBackend backend,
                                 unsigned threads)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.scene = &scene;
  s.bounds = sceneBounds(scene);
  s.threads = threads;
  s.lights = std::move(lights);
  for (const LightShadow& l : s.lights) s.lightList.push_back(l.light());
  if (backend == RasterBackend::Cpu)
    throw Error(ErrorCategory::InvalidArgument, "cpvs-view renders with OpenGL: the backend is osmesa or egl");
  s.context = backend == RasterBackend::EGL ? gl::createEGLContext() : gl::createOSMesaContext();
  if (!gl::hasComputeShaders(*s.context))
    throw Error(ErrorCategory::NotSupported, "cpvs-view needs OpenGL 4.5 (compute shaders, 64-bit floats); " +
                                                 s.context->description() + " lacks them");
  gl::CurrentContext current(*s.context);
  const gl::Context& c = *s.context;
  const std::string version = "#version 450\n";
  s.gbufferProgram = gl::linkProgram(c, {{GL_VERTEX_SHADER, version + glsl::gbuffer_vert},
                                         {GL_FRAGMENT_SHADER, version + kMaskTexelGlsl + glsl::coverage_mask_glsl + glsl::gbuffer_frag}}, "G-buffer");
  s.boundsProgram = gl::linkProgram(c, {{GL_COMPUTE_SHADER, computeSource({glsl::tile_bounds_comp})}}, "tile bounds");
  s.countProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({"#define COUNT_PASS\n", glsl::lookup_records_glsl, glsl::light_cull_glsl,
                                             glsl::light_lists_comp})}}, "light count");
  s.fillProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({glsl::lookup_records_glsl, glsl::light_cull_glsl, glsl::light_lists_comp})}},
      "light list");
  s.prefixProgram = gl::linkProgram(c, {{GL_COMPUTE_SHADER, computeSource({glsl::prefix_sum_comp})}}, "prefix sum");
  const char* tileGroup = "layout(local_size_x = 8, local_size_y = 8) in;\n";
  for (bool record : {false, true})
    (record ? s.recordingShadowProgram : s.shadowProgram) = gl::linkProgram(
        c, {{GL_COMPUTE_SHADER, computeSource({record ? "#define RECORD_CELLS\n" : "", tileGroup, glsl::lookup_records_glsl,
                                               glsl::scene_buffers_glsl, glsl::lookup_cell_glsl, glsl::dag_walk_glsl_h,
                                               glsl::cpvs_shadows_comp})}},
        record ? "CPVS shadow (recording)" : "CPVS shadow");
  s.mapDepthProgram = gl::linkProgram(c, {{GL_VERTEX_SHADER, version + glsl::shadow_map_depth_vert},
                                           {GL_FRAGMENT_SHADER, version + kMaskTexelGlsl + glsl::coverage_mask_glsl + glsl::shadow_map_depth_frag}}, "shadow-map depth");
  s.mapLookupProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({tileGroup, glsl::lookup_records_glsl, glsl::scene_buffers_glsl,
                                             glsl::lookup_cell_glsl, glsl::shadow_map_lookups_comp})}}, "shadow-map lookup");
  s.shadingProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({tileGroup, glsl::lookup_records_glsl, glsl::scene_buffers_glsl,
                                             glsl::shading_comp})}}, "shading");

  // The scene's triangles, one vertex each corner: world position, face normal, base colour factor, texture
  // coordinates and layer (floats).
  std::vector<float> vertices;
  for (const Instance& instance : scene.instances) {
    const Mesh& mesh = scene.meshes[instance.mesh];
    if (mesh.cutAway) continue;  // the alpha test leaves nothing of it (clear glass): neither casts nor is seen
    const bool textured = mesh.baseColorTexture >= 0 && mesh.uvs.size() == mesh.positions.size();
    const bool masked = mesh.coverageMask >= 0 && mesh.maskUvs.size() == mesh.positions.size();
    const bool casts = mesh.castsShadows && instance.castsShadows;  // the shadow maps leave the others out
    for (size_t t = 0; t < mesh.triangleCount(); ++t) {
      glm::dvec3 p[3];
      for (int k = 0; k < 3; ++k)
        p[k] = glm::dvec3(instance.worldFromLocal * glm::dvec4(glm::dvec3(mesh.positions[mesh.indices[3 * t + k]]), 1.0));
      const glm::dvec3 cross = glm::cross(p[1] - p[0], p[2] - p[0]);
      const double length = glm::length(cross);
      if (!(length > 0) || !std::isfinite(length)) continue;  // degenerate: covers no pixel
      const glm::vec3 n(cross / length);
      for (int k = 0; k < 3; ++k) {
        const glm::vec3 q(p[k]);
        s.casterTriangles.corners.push_back(q);
        const glm::vec2 uv = textured ? mesh.uvs[mesh.indices[3 * t + k]] : glm::vec2(0.0f);
        const glm::vec2 maskUv = masked ? mesh.maskUvs[mesh.indices[3 * t + k]] : glm::vec2(0.0f);
        vertices.insert(vertices.end(), {q.x, q.y, q.z, n.x, n.y, n.z, mesh.baseColor.r, mesh.baseColor.g,
                                         mesh.baseColor.b, mesh.baseColor.a, uv.x, uv.y,
                                         textured ? float(mesh.baseColorTexture) : -1.0f, maskUv.x, maskUv.y,
                                         masked ? float(mesh.coverageMask) : -1.0f, casts ? 1.0f : 0.0f});
      }
      ++s.triangles;
    }
  }
  const gl::Functions& g = s.gl();
  g.GenVertexArrays(1, &s.vertexArray);
  g.BindVertexArray(s.vertexArray);
  g.GenBuffers(1, &s.vertexBuffer);
  g.BindBuffer(GL_ARRAY_BUFFER, s.vertexBuffer);
  g.BufferData(GL_ARRAY_BUFFER, GLsizeiptr(vertices.size() * sizeof(float)), vertices.data(), GL_STATIC_DRAW);
  constexpr GLsizei stride = kVertexFloats * sizeof(float);
  g.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
  g.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(3 * sizeof(float)));
  g.VertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(6 * sizeof(float)));
  g.VertexAttribPointer(3, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(10 * sizeof(float)));
  g.VertexAttribPointer(4, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(13 * sizeof(float)));
  for (GLuint a = 0; a < 5; ++a) g.EnableVertexAttribArray(a);
  g.BindVertexArray(0);
  s.vertexCount = GLsizei(vertices.size() / kVertexFloats);
  s.uploadTextures(scene.textures);
  {  // The coverage masks (raster/gpu_masks.h), padded to whole words and never empty.
    PackedMasks packed = packMasks(scene.coverageMasks);
    std::vector<int32_t>& headers = packed.headers;
    std::vector<uint8_t>& bytes = packed.bytes;
    headers.resize(std::max<size_t>(headers.size(), 4), 0);
    bytes.resize(std::max<size_t>((bytes.size() + 3) / 4 * 4, 4), 0);
    s.maskHeaders = gl::createStorageBuffer(c, headers.data(), headers.size() * sizeof(int32_t));
    s.maskBytes = gl::createStorageBuffer(c, bytes.data(), bytes.size());
    s.textureBytes += headers.size() * sizeof(int32_t) + bytes.size();
  }
  gl::checkError(c, "uploading " + std::to_string(s.triangles) + " triangles");

  const GpuSceneRecords records = packGpuScene(s.lights);
  GLint maxBlock = 0;
  g.GetIntegerv(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &maxBlock);
  s.maxStorageBlock = maxBlock > 0 ? size_t(uint32_t(maxBlock)) : size_t(1) << 27;
  s.requireStorage(std::max(records.nodes.size() * 4, records.leaves.size() * 8), "the DAGs");
  s.lightReals = gl::createStorageBuffer(c, records.lightReals.data(), records.lightReals.size() * 8);
  s.lightWords = gl::createStorageBuffer(c, records.lightWords.data(), records.lightWords.size() * 4);
  s.lightWordsData = records.lightWords;
  s.viewReals = gl::createStorageBuffer(c, records.viewReals.data(), records.viewReals.size() * 8);
  s.viewWords = gl::createStorageBuffer(c, records.viewWords.data(), records.viewWords.size() * 4);
  s.dagNodes = gl::createStorageBuffer(c, records.nodes.data(), records.nodes.size() * 4);
  s.dagLeaves = gl::createStorageBuffer(c, records.leaves.data(), records.leaves.size() * 8);
  s.staticBytes = records.bytes() + vertices.size() * sizeof(float) + s.textureBytes;
  s.shadowBytes = records.bytes();
}

void PreviewRenderer::warmUp(const FrameSettings& like) {
  // Tiny frames through every pass: llvmpipe compiles a shader on its first use, and again for textures whose
  // sides are or are not powers of two (a first 320x240 frame's shadow pass took 323 ms, the next 18 ms).
  const Bounds& bounds = state_->bounds;
  for (const auto& [w, h] : {std::pair{16u, 16u}, {24u, 24u}, {16u, 24u}, {24u, 16u}}) {
    FrameSettings tiny;
    tiny.width = w;
    tiny.height = h;
    render(defaultCamera(bounds, 1.0), tiny);
    // The shadow-map modes' programs and their map array at the frame's map size.
    if (like.shadows == ShadowMode::ShadowMap || like.shadows == ShadowMode::LightCluster) {
      tiny.shadows = ShadowMode::ShadowMap;
      tiny.shadowMapSize = like.shadowMapSize;
      render(defaultCamera(bounds, 1.0), tiny);
    }
  }
}

PreviewRenderer::~PreviewRenderer() = default;  // GL objects go with the context

const std::string& PreviewRenderer::contextDescription() const { return state_->context->description(); }
const std::vector<LightShadow>& PreviewRenderer::lights() const { return state_->lights; }
size_t PreviewRenderer::sceneTriangles() const { return state_->triangles; }
size_t PreviewRenderer::staticUploadBytes() const { return state_->staticBytes; }
size_t PreviewRenderer::shadowDataBytes() const { return state_->shadowBytes; }

namespace {

// Every (pixel, listed light) pair grouped by light: the pair indices and the surface points.
struct PairsOfLight {
  std::vector<size_t> pairs;
  std::vector<SurfacePoint> points;
};

std::vector<PairsOfLight> pairsByLight(const Frame& f, size_t lightCount) {
  std::vector<PairsOfLight> byLight(lightCount);
  f.forEachPair([&](uint32_t, uint32_t, size_t i, uint32_t light, size_t pair) {
    byLight[light].pairs.push_back(pair);
    byLight[light].points.push_back({glm::dvec3(glm::vec3(f.positions[i])), glm::dvec3(glm::vec3(f.normals[i]))});
  });
  return byLight;
}

}  // namespace

// The per-frame shadow-map modes: plan (which views, which triangles: timed as "culling", on the CPU), draw
// the maps ("shadow_maps"), look them up ("shadows"), into the frame's visibility buffer.
template <class Timed>
void PreviewRenderer::renderShadowMaps(Frame& f, const FrameSettings& settings, GLuint visibility, GLuint offsets,
                                       GLuint lists, Timed&& timed) {
  State& s = *state_;
  const gl::Context& c = *s.context;
  const gl::Functions& g = s.gl();
  const bool clustered = settings.shadows == ShadowMode::LightCluster;
  if (settings.shadowMapSize < 8 || settings.shadowMapSize > 8192)
    throw Error(ErrorCategory::InvalidArgument, "shadow map size " + std::to_string(settings.shadowMapSize) + " is not in 8..8192");
  if (clustered && (s.clusterCount != settings.clusters || s.clusterSize != settings.shadowMapSize)) {
    std::vector<Light> all;
    for (const LightShadow& l : s.lights) all.push_back(l.light());
    s.clusters = clusterLights(all, settings.clusters);
    s.clusterViews.clear();
    const WorldGeometry world = flatten(*s.scene);
    for (const Light& cluster : s.clusters.lights) s.clusterViews.push_back(makeLightViews(cluster, world, settings.shadowMapSize));
    s.clusterCount = settings.clusters;
    s.clusterSize = settings.shadowMapSize;
  }
  if (settings.casterCulling == CasterCulling::VoxelGrid && !s.casterGrid)
    s.casterGrid = std::make_unique<CasterGrid>(s.casterTriangles, s.bounds);
  ShadowMapScene scene;
  scene.lights = &s.lights;
  scene.triangles = &s.casterTriangles;
  scene.grid = s.casterGrid.get();
  scene.clusters = &s.clusters;
  scene.clusterViews = &s.clusterViews;
  const unsigned threads = s.threads ? s.threads : unsigned(tbb::this_task_arena::max_concurrency());
  tbb::task_arena arena(int(std::max(1u, threads)));
  Stopwatch clock;
  ShadowMapPlan plan;
  arena.execute([&] { plan = planShadowMaps(scene, f, settings, clustered); });
  f.passes.push_back({"culling", clock.ms(), false});

  // Upload: the records the lookups read, the index lists of the culled views.
  const uint32_t m = settings.shadowMapSize, layers = uint32_t(plan.views.size());
  Buffers buffers{&c, {}};
  struct Release {
    Buffers& b;
    ~Release() { b.release(); }
  } release{buffers};
  const GLuint lightReals = buffers.add(gl::createStorageBuffer(c, plan.records.lightReals.data(), plan.records.lightReals.size() * 8));
  const GLuint lightWords = buffers.add(gl::createStorageBuffer(c, plan.records.lightWords.data(), plan.records.lightWords.size() * 4));
  const GLuint viewReals = buffers.add(gl::createStorageBuffer(c, plan.records.viewReals.data(), plan.records.viewReals.size() * 8));
  const GLuint viewWords = buffers.add(gl::createStorageBuffer(c, plan.records.viewWords.data(), plan.records.viewWords.size() * 4));
  std::vector<uint32_t> indices;
  std::vector<size_t> firstIndex(layers, 0);
  for (uint32_t layer = 0; layer < layers; ++layer) {
    firstIndex[layer] = indices.size();
    for (uint32_t t : plan.views[layer].triangles) indices.insert(indices.end(), {3 * t, 3 * t + 1, 3 * t + 2});
  }
  GLuint elements = 0;
  g.GenBuffers(1, &elements);
  buffers.add(elements);
  g.BindVertexArray(s.vertexArray);
  g.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, elements);
  g.BufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(std::max<size_t>(indices.size(), 1) * 4), indices.data(), GL_STATIC_DRAW);
  s.ensureMapArray(m, layers);
  f.uploadedBytes += plan.records.bytes() + indices.size() * 4;
  f.shadowMaps.size = m;
  f.shadowMaps.trianglesPerLight = plan.trianglesPerLight;
  f.shadowMaps.bytes = uint64_t(layers) * m * m * 4 + indices.size() * 4;
  for (const MapView& mv : plan.views) {
    f.shadowMaps.shadowLight.push_back(mv.shadowLight);
    f.shadowMaps.views.push_back(mv.mapView);
    f.shadowMaps.triangles.push_back(mv.drawAll ? s.triangles : mv.triangles.size());
  }

  // The maps, one layer per view: eval/shadow_map.h's 16-bit depth as q / 65536 in a float depth buffer.
  timed("shadow_maps", [&] {
    g.BindFramebuffer(GL_FRAMEBUFFER, s.mapFramebuffer);
    const GLenum none = GL_NONE;
    g.DrawBuffers(1, &none);
    g.ReadBuffer(GL_NONE);
    g.Viewport(0, 0, GLsizei(m), GLsizei(m));
    g.Enable(GL_DEPTH_TEST);
    g.DepthFunc(GL_LESS);
    g.DepthMask(GL_TRUE);
    g.Disable(GL_CULL_FACE);
    g.UseProgram(s.mapDepthProgram);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 14, s.maskHeaders);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 15, s.maskBytes);
    const GLint viewFromWorld = g.GetUniformLocation(s.mapDepthProgram, "viewFromWorld");
    const GLint lateral = g.GetUniformLocation(s.mapDepthProgram, "lateral");
    const GLint orthographic = g.GetUniformLocation(s.mapDepthProgram, "orthographic");
    const GLint linearDepth = g.GetUniformLocation(s.mapDepthProgram, "linearDepth");
    const GLint nearDepth = g.GetUniformLocation(s.mapDepthProgram, "nearDepth");
    const GLint sliceScale = g.GetUniformLocation(s.mapDepthProgram, "sliceScale");
    const GLint mapSize = g.GetUniformLocation(s.mapDepthProgram, "mapSize");
    g.Uniform1f(mapSize, float(m));
    const GLfloat far = float(ShadowMap16::kFar) / 65536.0f;
    for (uint32_t layer = 0; layer < layers; ++layer) {
      const MapView& mv = plan.views[layer];
      g.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, s.mapArray, 0, GLint(layer));
      g.ClearBufferfv(GL_DEPTH, 0, &far);
      if (mv.mapView.empty || (!mv.drawAll && mv.triangles.empty())) continue;
      const ViewMapping vm(mv.mapView);
      const glm::mat4 matrix(mv.mapView.viewFromWorld);
      g.UniformMatrix4fv(viewFromWorld, 1, GL_FALSE, &matrix[0][0]);
      g.Uniform4f(lateral, float(mv.mapView.xMin), float(mv.mapView.yMin), float(mv.mapView.xMax - mv.mapView.xMin),
                  float(mv.mapView.yMax - mv.mapView.yMin));
      g.Uniform1i(orthographic, vm.orthographic ? 1 : 0);
      g.Uniform1i(linearDepth, vm.linear ? 1 : 0);
      g.Uniform1f(nearDepth, float(vm.near));
      g.Uniform1f(sliceScale, float(vm.sScale));
      if (mv.drawAll)
        g.DrawArrays(GL_TRIANGLES, 0, s.vertexCount);
      else
        g.DrawElements(GL_TRIANGLES, GLsizei(mv.triangles.size() * 3), GL_UNSIGNED_INT,
                       reinterpret_cast<const void*>(firstIndex[layer] * 4));
    }
  });
  g.BindVertexArray(0);
  gl::checkError(c, "rendering " + std::to_string(layers) + " shadow maps");
  if (settings.keepShadowMaps) {
    std::vector<float> depth(size_t(m) * m);
    f.shadowMaps.texels.resize(size_t(layers) * m * m);
    g.BindFramebuffer(GL_FRAMEBUFFER, s.mapFramebuffer);
    g.PixelStorei(GL_PACK_ALIGNMENT, 4);
    for (uint32_t layer = 0; layer < layers; ++layer) {
      g.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, s.mapArray, 0, GLint(layer));
      g.ReadPixels(0, 0, GLsizei(m), GLsizei(m), GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
      for (size_t i = 0; i < depth.size(); ++i)
        f.shadowMaps.texels[size_t(layer) * m * m + i] = uint16_t(std::lround(double(depth[i]) * 65536.0));
    }
    gl::checkError(c, "reading back the shadow maps");
  }

  // The lookups.
  timed("shadows", [&] {
    g.UseProgram(s.mapLookupProgram);
    const GLuint program = s.mapLookupProgram;
    g.Uniform2i(g.GetUniformLocation(program, "imageSize_"), GLint(f.width), GLint(f.height));
    g.Uniform2i(g.GetUniformLocation(program, "tileCount"), GLint(f.lists.tilesX), GLint(f.lists.tilesY));
    g.Uniform1i(g.GetUniformLocation(program, "pcfKernel"), settings.pcfKernel);
    g.Uniform1d(g.GetUniformLocation(program, "biasMargin"), settings.biasMargin);
    g.ActiveTexture(GL_TEXTURE0);
    g.BindTexture(GL_TEXTURE_2D, s.textures[0]);
    g.ActiveTexture(GL_TEXTURE1);
    g.BindTexture(GL_TEXTURE_2D, s.textures[1]);
    g.ActiveTexture(GL_TEXTURE3);
    g.BindTexture(GL_TEXTURE_2D_ARRAY, s.mapArray);
    for (auto [binding, buffer] : {std::pair{kLightReals, lightReals}, {kLightWords, lightWords}, {kTileOffsets, offsets},
                                   {kTileLights, lists}, {kViewReals, viewReals}, {kViewWords, viewWords},
                                   {kDagNodes, s.dagNodes}, {kDagLeaves, s.dagLeaves}, {kVisibility, visibility}})
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, buffer);
    g.DispatchCompute(f.lists.tilesX, f.lists.tilesY, 1);
    g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  });
  gl::checkError(c, "looking up the shadow maps");
  f.visibility.resize(size_t(f.lists.offsets.back()) * 64);
  gl::readStorageBuffer(c, visibility, f.visibility.data(), f.visibility.size() * 4);
}

Frame PreviewRenderer::render(const PreviewCamera& requested, const FrameSettings& settings) {
  State& s = *state_;
  if (settings.width == 0 || settings.height == 0 || settings.width > kMaxImageEdge || settings.height > kMaxImageEdge)
    throw Error(ErrorCategory::InvalidArgument, "image size " + std::to_string(settings.width) + "x" +
                                                    std::to_string(settings.height) + " is not in 1..16384 per side");
  if (const Outcome k = checkPcfKernel(settings.pcfKernel); !k) throw Error(k.category(), k.message());
  checkCamera(requested);
  for (uint32_t l : settings.disabledLights)
    if (l >= s.lights.size())
      throw Error(ErrorCategory::InvalidArgument, "light " + std::to_string(l) + " to switch off does not exist (" +
                                                      std::to_string(s.lights.size()) + " lights)");
  const PreviewCamera camera = withClipPlanes(requested, s.bounds);

  const gl::Context& c = *s.context;
  const gl::Functions& g = s.gl();
  gl::CurrentContext current(*s.context);
  if (s.targetWidth != settings.width || s.targetHeight != settings.height) s.createTargets(settings.width, settings.height);
  std::vector<uint32_t> disabled(s.lights.size(), 0);
  for (uint32_t l : settings.disabledLights) disabled[l] = 1;
  if (disabled != s.disabled && !s.lights.empty()) {
    for (size_t l = 0; l < s.lights.size(); ++l) s.lightWordsData[l * gpu_layout::kLightWords + gpu_layout::kLightDisabled] = disabled[l];
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, s.lightWords);
    g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(s.lightWordsData.size() * 4), s.lightWordsData.data());
    s.disabled = disabled;
  }
  gl::checkError(c, "preparing the frame");
  const size_t pixels = size_t(settings.width) * settings.height;
  s.requireStorage(pixels * 16, "the frame's " + std::to_string(settings.width) + "x" + std::to_string(settings.height) + " pixels");
  Frame f;
  f.width = settings.width;
  f.height = settings.height;
  f.lists.tilesX = (f.width + kTileSize - 1) / kTileSize;
  f.lists.tilesY = (f.height + kTileSize - 1) / kTileSize;
  const GLsizei tiles = GLsizei(f.lists.tiles());
  f.uploadedBytes = s.staticBytes;
  Buffers frameBuffers{&c, {}};
  struct Release {
    Buffers& b;
    ~Release() { b.release(); }
  } release{frameBuffers};
  gl::PassTimer timer(c);
  const bool gpuTimer = timer.usesGpuTimer();
  auto timed = [&](const std::string& pass, auto&& work) {
    timer.begin();
    work();
    timer.end();
    f.passes.push_back({pass, timer.milliseconds(), gpuTimer});
  };
  auto bindBuffer = [&](Binding binding, GLuint buffer) { g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, buffer); };
  auto bindTexture = [&](GLuint unit, GLuint texture) {
    g.ActiveTexture(GL_TEXTURE0 + unit);
    g.BindTexture(GL_TEXTURE_2D, texture);
  };
  auto setSizes = [&](GLuint program) {
    g.Uniform2i(g.GetUniformLocation(program, "imageSize_"), GLint(f.width), GLint(f.height));
    g.Uniform2i(g.GetUniformLocation(program, "tileCount"), GLint(f.lists.tilesX), GLint(f.lists.tilesY));
    g.Uniform1i(g.GetUniformLocation(program, "tiles"), tiles);
  };

  // 1. G-buffer.
  const double aspect = double(f.width) / double(f.height);
  timed("gbuffer", [&] {
    g.BindFramebuffer(GL_FRAMEBUFFER, s.framebuffer);
    g.Viewport(0, 0, GLsizei(f.width), GLsizei(f.height));
    const GLfloat zero[4] = {0, 0, 0, 0}, one = 1.0f;
    for (GLint i = 0; i < 3; ++i) g.ClearBufferfv(GL_COLOR, i, zero);
    g.ClearBufferfv(GL_DEPTH, 0, &one);
    g.Enable(GL_DEPTH_TEST);
    g.DepthFunc(GL_LESS);
    g.DepthMask(GL_TRUE);
    g.Disable(GL_CULL_FACE);
    g.Disable(GL_BLEND);
    g.UseProgram(s.gbufferProgram);
    g.ActiveTexture(GL_TEXTURE0 + kBaseColorUnit);
    g.BindTexture(GL_TEXTURE_2D_ARRAY, s.baseColorArray);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 14, s.maskHeaders);
    g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, 15, s.maskBytes);
    const glm::mat4 matrix(clipFromWorld(camera, aspect));
    g.UniformMatrix4fv(g.GetUniformLocation(s.gbufferProgram, "clipFromWorld"), 1, GL_FALSE, &matrix[0][0]);
    g.BindVertexArray(s.vertexArray);
    g.DrawArrays(GL_TRIANGLES, 0, s.vertexCount);
    g.BindVertexArray(0);
  });
  gl::checkError(c, "rendering the G-buffer");

  // 2. Tile bounds.
  const GLuint tileBounds = frameBuffers.add(gl::createStorageBuffer(c, nullptr, size_t(tiles) * 32));
  timed("tile_bounds", [&] {
    g.UseProgram(s.boundsProgram);
    setSizes(s.boundsProgram);
    bindTexture(0, s.textures[0]);
    bindBuffer(kTileBounds, tileBounds);
    g.DispatchCompute(GLuint((tiles + 255) / 256), 1, 1);
    g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
  });

  // 3. Light lists: count, prefix sum, (the total read back to size the list), fill.
  const GLuint counts = frameBuffers.add(gl::createStorageBuffer(c, nullptr, size_t(tiles) * 4));
  const GLuint offsets = frameBuffers.add(gl::createStorageBuffer(c, nullptr, size_t(tiles + 1) * 4));
  GLuint lists = 0;
  uint32_t totalPairs = 0;
  timed("light_lists", [&] {
    for (GLuint program : {s.countProgram, s.prefixProgram}) {
      g.UseProgram(program);
      setSizes(program);
      g.Uniform1i(g.GetUniformLocation(program, "lightCount"), GLint(s.lights.size()));
      for (auto [binding, buffer] : {std::pair{kTileBounds, tileBounds}, {kLightReals, s.lightReals},
                                     {kLightWords, s.lightWords}, {kTileCounts, counts}, {kTileOffsets, offsets}})
        bindBuffer(binding, buffer);
      g.DispatchCompute(program == s.prefixProgram ? 1 : GLuint((tiles + 255) / 256), 1, 1);
      g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    }
    f.lists.offsets.resize(size_t(tiles) + 1);
    gl::readStorageBuffer(c, offsets, f.lists.offsets.data(), f.lists.offsets.size() * 4);
    totalPairs = f.lists.offsets.back();
    lists = frameBuffers.add(gl::createStorageBuffer(c, nullptr, size_t(totalPairs) * 4));
    g.UseProgram(s.fillProgram);
    setSizes(s.fillProgram);
    g.Uniform1i(g.GetUniformLocation(s.fillProgram, "lightCount"), GLint(s.lights.size()));
    bindBuffer(kTileLights, lists);
    g.DispatchCompute(GLuint((tiles + 255) / 256), 1, 1);
    g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  });
  gl::checkError(c, "building the tile light lists");
  f.lists.lights.resize(totalPairs);
  gl::readStorageBuffer(c, lists, f.lists.lights.data(), f.lists.lights.size() * 4);
  f.positions = s.readTexture(0, f.width, f.height);
  f.normals = s.readTexture(1, f.width, f.height);
  f.baseColors = s.readTexture(2, f.width, f.height);

  // 4. Shadows: one visibility per (list entry, pixel of the tile).
  const size_t pairSlots = size_t(totalPairs) * 64;
  s.requireStorage(pairSlots * (settings.recordCells ? 16 : 4), std::to_string(totalPairs) + " (tile, light) pairs");
  const GLuint visibility = frameBuffers.add(gl::createStorageBuffer(c, nullptr, pairSlots * 4));
  const GLuint cells = settings.recordCells ? frameBuffers.add(gl::createStorageBuffer(c, nullptr, pairSlots * 16)) : 0;
  auto bindSceneBuffers = [&](GLuint program) {
    setSizes(program);
    bindTexture(0, s.textures[0]);
    bindTexture(1, s.textures[1]);
    bindTexture(2, s.textures[2]);
    for (auto [binding, buffer] : {std::pair{kLightReals, s.lightReals}, {kLightWords, s.lightWords},
                                   {kTileOffsets, offsets}, {kTileLights, lists}, {kViewReals, s.viewReals},
                                   {kViewWords, s.viewWords}, {kDagNodes, s.dagNodes}, {kDagLeaves, s.dagLeaves},
                                   {kVisibility, visibility}})
      bindBuffer(binding, buffer);
  };
  std::optional<std::vector<PairsOfLight>> pairs;
  auto pairsOfLights = [&]() -> const std::vector<PairsOfLight>& {
    if (!pairs) pairs = pairsByLight(f, s.lights.size());
    return *pairs;
  };
  const unsigned threads = s.threads ? s.threads : unsigned(tbb::this_task_arena::max_concurrency());
  tbb::task_arena arena(int(std::max(1u, threads)));
  auto rayVisibility = [&]() {
    std::vector<float> out(pairSlots, 0.0f);
    const ShadowReference& reference = s.rays();
    const auto& byLight = pairsOfLights();
    arena.execute([&] {
      parallelFor(byLight.size(), [&](size_t l) {
        std::vector<uint8_t> answers;
        reference.visibilityPackets(s.lights[l].light(), byLight[l].points, answers);
        for (size_t i = 0; i < answers.size(); ++i) out[byLight[l].pairs[i]] = float(answers[i]);
      }, 1);
    });
    return out;
  };
  switch (settings.shadows) {
    case ShadowMode::Gpu: {
      const GLuint program = settings.recordCells ? s.recordingShadowProgram : s.shadowProgram;
      timed("shadows", [&] {
        g.UseProgram(program);
        bindSceneBuffers(program);
        if (cells) bindBuffer(kCells, cells);
        g.Uniform1i(g.GetUniformLocation(program, "pcfKernel"), settings.pcfKernel);
        g.Uniform1d(g.GetUniformLocation(program, "biasMargin"), settings.biasMargin);
        g.DispatchCompute(f.lists.tilesX, f.lists.tilesY, 1);
        g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
      });
      gl::checkError(c, "running the CPVS shadow pass");
      f.visibility.resize(pairSlots);
      gl::readStorageBuffer(c, visibility, f.visibility.data(), pairSlots * 4);
      if (cells) {
        f.cells.resize(pairSlots);
        gl::readStorageBuffer(c, cells, f.cells.data(), pairSlots * 16);
      }
      break;
    }
    case ShadowMode::Cpu: {
      const auto& byLight = pairsOfLights();
      Stopwatch clock;
      f.visibility.assign(pairSlots, 0.0f);
      LookupOptions options;
      options.pcfKernel = settings.pcfKernel;
      options.biasMargin = settings.biasMargin;
      arena.execute([&] {
        // Batches of kLookupBatch points, as cpvs-query hands them to the runtime (its scratch stays in cache).
        std::vector<std::pair<uint32_t, size_t>> batches;  // (light, first point)
        for (uint32_t l = 0; l < byLight.size(); ++l)
          for (size_t first = 0; first < byLight[l].points.size(); first += kLookupBatch) batches.emplace_back(l, first);
        parallelFor(batches.size(), [&](size_t b) {
          const auto [l, first] = batches[b];
          const size_t count = std::min(kLookupBatch, byLight[l].points.size() - first);
          float answers[kLookupBatch];
          const Outcome o = s.lights[l].visibility(std::span(byLight[l].points).subspan(first, count), options,
                                                   std::span(answers, count));
          if (!o) throw Error(o.category(), o.message());
          for (size_t i = 0; i < count; ++i) f.visibility[byLight[l].pairs[first + i]] = answers[i];
        }, 1);
      });
      f.passes.push_back({"shadows", clock.ms(), false});
      break;
    }
    case ShadowMode::RayTraced: {
      pairsOfLights();
      s.rays();  // the BVH is built once, outside the timing
      Stopwatch clock;
      f.visibility = rayVisibility();
      f.passes.push_back({"shadows", clock.ms(), false});
      break;
    }
    case ShadowMode::None: f.visibility.assign(pairSlots, 1.0f); break;
    case ShadowMode::ShadowMap:
    case ShadowMode::LightCluster: {
      renderShadowMaps(f, settings, visibility, offsets, lists, timed);
      break;
    }
  }
  if (settings.shadows != ShadowMode::Gpu && settings.shadows != ShadowMode::ShadowMap &&
      settings.shadows != ShadowMode::LightCluster) {
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, visibility);
    if (pairSlots) g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(pairSlots * 4), f.visibility.data());
    f.uploadedBytes += pairSlots * 4;
  }

  // 5. Shading.
  const GLuint radiance = frameBuffers.add(gl::createStorageBuffer(c, nullptr, pixels * 16));
  const GLuint stats = frameBuffers.add(gl::createStorageBuffer(c, nullptr, pixels * 8));
  auto dispatchShading = [&] {
    g.UseProgram(s.shadingProgram);
    bindSceneBuffers(s.shadingProgram);
    bindBuffer(kRadiance, radiance);
    bindBuffer(kStats, stats);
    g.Uniform3f(g.GetUniformLocation(s.shadingProgram, "eye"), float(camera.eye.x), float(camera.eye.y), float(camera.eye.z));
    g.Uniform1f(g.GetUniformLocation(s.shadingProgram, "specular"), 0.25f);
    g.DispatchCompute(f.lists.tilesX, f.lists.tilesY, 1);
    g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  };
  timed("shading", dispatchShading);
  f.stats.resize(pixels);
  gl::readStorageBuffer(c, stats, f.stats.data(), pixels * 8);
  f.radiance.resize(pixels);
  gl::readStorageBuffer(c, radiance, f.radiance.data(), pixels * 16);
  gl::checkError(c, "shading");

  if (settings.compareWithRays) {
    f.rayVisibility = settings.shadows == ShadowMode::RayTraced ? f.visibility : rayVisibility();
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, visibility);
    if (pairSlots) g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(pairSlots * 4), f.rayVisibility.data());
    dispatchShading();
    f.rayRadiance.resize(pixels);
    gl::readStorageBuffer(c, radiance, f.rayRadiance.data(), pixels * 16);
    gl::checkError(c, "shading the ray-traced frame");
  }
  g.UseProgram(0);
  return f;
}

}  // namespace cpvs
