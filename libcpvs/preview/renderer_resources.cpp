#include "libcpvs/preview/renderer_resources.h"

#include <algorithm>
#include <cmath>

#include <tbb/task_arena.h>

#include "libcpvs/base/error.h"
#include "libcpvs/gl/gl_program.h"
#include "libcpvs/preview/glsl_sources.h"
#include "libcpvs/runtime/gpu_records.h"
#include "libcpvs/raster/gpu_masks.h"

#define STB_IMAGE_RESIZE_IMPLEMENTATION
#define STB_IMAGE_RESIZE_STATIC
#include <stb/stb_image_resize.h>

namespace cpvs {

namespace {

// Base-colour textures share one sRGB array: each resampled to this edge at most (the largest texture's own
// size when smaller), mipmapped.
constexpr uint32_t kTextureEdge = 1024;

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

}  // namespace

std::string computeSource(std::initializer_list<const char*> parts) {
  std::string s = "#version 450\n#define CPVS_SUPER_TILE " + std::to_string(kSuperTile) + "u\n";
  for (const char* p : parts) s += p;
  return s;
}

FrameBuffers::~FrameBuffers() {
  if (!names_.empty()) context_.gl().DeleteBuffers(GLsizei(names_.size()), names_.data());
}

RendererResources::RendererResources(const Scene& scene_, std::vector<LightShadow> lights_, bool egl,
                                     unsigned threads_)
    : scene(&scene_), lights(std::move(lights_)), threads(threads_), bounds(sceneBounds(scene_)) {
  context = egl ? gl::createEGLContext() : gl::createOSMesaContext();
  if (!gl::hasComputeShaders(*context))
    throw Error(ErrorCategory::NotSupported, "cpvs-view needs OpenGL 4.5 (compute shaders, 64-bit floats); " +
                                                 context->description() + " lacks them");
  gl::CurrentContext current(*context);
  linkPrograms();
  uploadTriangles(scene_);
  uploadTextures(scene_.textures);
  uploadMasks(scene_);
  gl::checkError(*context, "uploading " + std::to_string(triangles) + " triangles");
  uploadLights();
}

RendererResources::~RendererResources() = default;  // GL objects go with the context

unsigned RendererResources::threadCount() const {
  return threads ? threads : unsigned(tbb::this_task_arena::max_concurrency());
}

void RendererResources::linkPrograms() {
  const gl::Context& c = *context;
  const std::string version = "#version 450\n";
  gbufferProgram = gl::linkProgram(c, {{GL_VERTEX_SHADER, version + glsl::gbuffer_vert},
                                       {GL_FRAGMENT_SHADER, version + kMaskTexelGlsl + glsl::coverage_mask_glsl + glsl::gbuffer_frag}}, "G-buffer");
  boundsProgram = gl::linkProgram(c, {{GL_COMPUTE_SHADER, computeSource({glsl::tile_bounds_comp})}}, "tile bounds");
  countProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({"#define COUNT_PASS\n", glsl::light_glsl_h, glsl::lookup_records_glsl,
                                             glsl::light_cull_glsl, glsl::light_lists_comp})}}, "light count");
  fillProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({glsl::light_glsl_h, glsl::lookup_records_glsl, glsl::light_cull_glsl,
                                             glsl::light_lists_comp})}},
      "light list");
  prefixProgram = gl::linkProgram(c, {{GL_COMPUTE_SHADER, computeSource({glsl::prefix_sum_comp})}}, "prefix sum");
  superBoundsProgram =
      gl::linkProgram(c, {{GL_COMPUTE_SHADER, computeSource({glsl::super_bounds_comp})}}, "super-tile bounds");
  const char* superTiles = "#define SUPER_TILES\n#define CPVS_SPHERE_SCALE 2.0LF\n";
  superListProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({superTiles, glsl::light_glsl_h, glsl::lookup_records_glsl,
                                             glsl::light_cull_glsl, glsl::light_lists_comp})}}, "super-tile light list");
  shadingProgram = gl::linkProgram(
      c, {{GL_COMPUTE_SHADER, computeSource({"layout(local_size_x = 8, local_size_y = 8) in;\n", glsl::light_glsl_h,
                                             glsl::lookup_records_glsl, glsl::scene_buffers_glsl,
                                             glsl::shading_comp})}}, "shading");
}

// The scene's triangles, one vertex each corner: world position, face normal, base colour factor, texture
// coordinates and layer, mask coordinates and mask, whether it casts (floats).
void RendererResources::uploadTriangles(const Scene& s) {
  std::vector<float> vertices;
  for (const Instance& instance : s.instances) {
    const Mesh& mesh = s.meshes[instance.mesh];
    if (mesh.cutAway) continue;  // the alpha test leaves nothing of it (clear glass): neither casts nor is seen
    const bool textured = mesh.baseColorTexture >= 0 && mesh.uvs.size() == mesh.positions.size();
    const bool masked = mesh.coverageMask >= 0 && mesh.maskUvs.size() == mesh.positions.size();
    const bool casts = mesh.castsShadows && instance.castsShadows;  // the shadow maps leave the others out
    castingTrianglesOfInstance.emplace_back();
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
        casterTriangles.corners.push_back(q);
        if (k == 0 && casts) castingTrianglesOfInstance.back().push_back(uint32_t(triangles));
        const glm::vec2 uv = textured ? mesh.uvs[mesh.indices[3 * t + k]] : glm::vec2(0.0f);
        const glm::vec2 maskUv = masked ? mesh.maskUvs[mesh.indices[3 * t + k]] : glm::vec2(0.0f);
        vertices.insert(vertices.end(), {q.x, q.y, q.z, n.x, n.y, n.z, mesh.baseColor.r, mesh.baseColor.g,
                                         mesh.baseColor.b, mesh.baseColor.a, uv.x, uv.y,
                                         textured ? float(mesh.baseColorTexture) : -1.0f, maskUv.x, maskUv.y,
                                         masked ? float(mesh.coverageMask) : -1.0f, casts ? 1.0f : 0.0f});
      }
      ++triangles;
    }
  }
  const gl::Functions& g = gl();
  g.GenVertexArrays(1, &vertexArray);
  g.BindVertexArray(vertexArray);
  g.GenBuffers(1, &vertexBuffer);
  g.BindBuffer(GL_ARRAY_BUFFER, vertexBuffer);
  g.BufferData(GL_ARRAY_BUFFER, GLsizeiptr(vertices.size() * sizeof(float)), vertices.data(), GL_STATIC_DRAW);
  constexpr GLsizei stride = GLsizei(kVertexFloats * sizeof(float));
  g.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
  g.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(3 * sizeof(float)));
  g.VertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(6 * sizeof(float)));
  g.VertexAttribPointer(3, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(10 * sizeof(float)));
  g.VertexAttribPointer(4, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(13 * sizeof(float)));
  for (GLuint a = 0; a < 5; ++a) g.EnableVertexAttribArray(a);
  g.BindVertexArray(0);
  vertexCount = GLsizei(vertices.size() / kVertexFloats);
  staticBytes += vertices.size() * sizeof(float);
}

void RendererResources::uploadTextures(const std::vector<Texture>& textures) {
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

// The coverage masks (raster/gpu_masks.h), padded to whole words and never empty.
void RendererResources::uploadMasks(const Scene& s) {
  PackedMasks packed = packMasks(s.coverageMasks);
  std::vector<int32_t>& headers = packed.headers;
  std::vector<uint8_t>& bytes = packed.bytes;
  headers.resize(std::max<size_t>(headers.size(), 4), 0);
  bytes.resize(std::max<size_t>((bytes.size() + 3) / 4 * 4, 4), 0);
  maskHeaders = gl::createStorageBuffer(*context, headers.data(), headers.size() * sizeof(int32_t));
  maskBytes = gl::createStorageBuffer(*context, bytes.data(), bytes.size());
  textureBytes += headers.size() * sizeof(int32_t) + bytes.size();
  staticBytes += textureBytes;
}

void RendererResources::uploadLights() {
  const gl::Context& c = *context;
  const GpuSceneRecords records = orThrow(packGpuScene(lights));
  GLint maxBlock = 0;
  gl().GetIntegerv(GL_MAX_SHADER_STORAGE_BLOCK_SIZE, &maxBlock);
  maxStorageBlock = maxBlock > 0 ? size_t(uint32_t(maxBlock)) : size_t(1) << 27;
  lightReals = gl::createStorageBuffer(c, records.lightReals.data(), records.lightReals.size() * 8);
  lightWords = gl::createStorageBuffer(c, records.lightWords.data(), records.lightWords.size() * 4);
  lightWordsData_ = records.lightWords;
  viewReals = gl::createStorageBuffer(c, records.viewReals.data(), records.viewReals.size() * 8);
  viewWords = gl::createStorageBuffer(c, records.viewWords.data(), records.viewWords.size() * 4);
  staticBytes += records.bytes() - (records.nodes.size() * 4 + records.leaves.size() * 8);
  shadowBytes = records.bytes();
  dagBufferBytes = std::max(records.nodes.size() * 4, records.leaves.size() * 8);
}

void RendererResources::uploadDags() {
  if (dagNodes) return;
  const GpuSceneRecords records = orThrow(packGpuScene(lights));
  requireStorage(std::max(records.nodes.size() * 4, records.leaves.size() * 8), "the DAGs",
                 "--shadows cpu looks them up from the file instead");
  const gl::Context& c = *context;  // current: the GPU technique is made while a frame renders
  dagNodes = gl::createStorageBuffer(c, records.nodes.data(), records.nodes.size() * 4);
  dagLeaves = gl::createStorageBuffer(c, records.leaves.data(), records.leaves.size() * 8);
  staticBytes += records.nodes.size() * 4 + records.leaves.size() * 8;
}

void RendererResources::setDisabledLights(const std::vector<uint32_t>& disabled) {
  if (disabled == disabled_ || lights.empty()) return;
  for (size_t l = 0; l < lights.size(); ++l)
    lightWordsData_[l * gpu_layout::kLightWords + gpu_layout::kLightDisabled] = disabled[l];
  const gl::Functions& g = gl();
  g.BindBuffer(GL_SHADER_STORAGE_BUFFER, lightWords);
  g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(lightWordsData_.size() * 4), lightWordsData_.data());
  disabled_ = disabled;
}

void RendererResources::ensureTargets(uint32_t w, uint32_t h) {
  if (targetWidth == w && targetHeight == h) return;
  const gl::Functions& g = gl();
  if (framebuffer) {
    g.DeleteFramebuffers(1, &framebuffer);
    g.DeleteTextures(4, targets);
  }
  g.GenFramebuffers(1, &framebuffer);
  g.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  g.GenTextures(4, targets);
  for (int i = 0; i < 4; ++i) {
    g.BindTexture(GL_TEXTURE_2D, targets[i]);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    if (i < 3) {
      g.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, GLsizei(w), GLsizei(h), 0, GL_RGBA, GL_FLOAT, nullptr);
      g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + GLenum(i), GL_TEXTURE_2D, targets[i], 0);
    } else {
      g.TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, GLsizei(w), GLsizei(h), 0, GL_DEPTH_COMPONENT,
                   GL_FLOAT, nullptr);
      g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, targets[i], 0);
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

std::vector<glm::vec4> RendererResources::readTarget(int attachment, uint32_t w, uint32_t h) const {
  const gl::Functions& g = gl();
  std::vector<glm::vec4> out(size_t(w) * h);
  g.BindFramebuffer(GL_FRAMEBUFFER, framebuffer);
  g.ReadBuffer(GL_COLOR_ATTACHMENT0 + GLenum(attachment));
  g.PixelStorei(GL_PACK_ALIGNMENT, 4);
  g.ReadPixels(0, 0, GLsizei(w), GLsizei(h), GL_RGBA, GL_FLOAT, out.data());
  gl::checkError(*context, "reading back the G-buffer");
  return out;
}

void RendererResources::requireStorage(size_t bytes, const std::string& what, const std::string& hint) const {
  if (bytes <= maxStorageBlock) return;
  throw Error(ErrorCategory::RuntimeFailure, what + " need a " + std::to_string(bytes >> 20) + " MiB storage buffer; " +
                                                 context->description() + " allows " +
                                                 std::to_string(maxStorageBlock >> 20) + " MiB (" + hint + ")");
}

const ShadowReference& RendererResources::rays() {
  if (!reference_) reference_.emplace(flatten(*scene));
  return *reference_;
}

}  // namespace cpvs
