// Enter and exit depth maps with OpenGL (docs/depth-maps.md).
//
// Per region, all in GL textures of the region's size:
//  1. enter pass: closed and open triangles, depth test LESS into a 32-bit float depth texture holding
//     t / 2 (t = the view's normalised depth in [0, 1], so 1.0 = the clear value means "nothing"), and the kind
//     of the nearest surface (closed front / closed back / open) into an R8UI texture.
//  2. init pass: per texel state (front cursor, back cursor) + count; texels whose first surface is a closed
//     front face start active with count 1.
//  3. peel iterations: closed front faces and closed back faces peeled separately beyond their cursors, the
//     multiplicity of the nearest back layer counted, then a fullscreen pass consumes the nearer event
//     (ties: back first) into the other ping-pong state.
//  4. resolve pass: integer enter and exit slices, read back once.
#include "libcpvs/base/named_values.h"
#include "libcpvs/raster/depth_renderer.h"

#include <algorithm>
#include <cfloat>
#include <cstddef>
#include <limits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>


#include "libcpvs/base/error.h"
#include "libcpvs/base/parallel.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/raster/cpu_depth_renderer.h"
#include "libcpvs/gl/gl_context.h"
#include "libcpvs/gl/gl_program.h"
#include "libcpvs/raster/glsl_sources.h"
#include "libcpvs/raster/gpu_masks.h"
#include "libcpvs/raster/triangle_setup.h"

namespace cpvs {

namespace {
constexpr Named<RasterBackend> kBackends[] = {{RasterBackend::Cpu, "cpu"}, {RasterBackend::OSMesa, "osmesa"},
                                              {RasterBackend::EGL, "egl"}};
}  // namespace

RasterBackend parseRasterBackend(const std::string& name) { return parseNamed(kBackends, name, "raster backend"); }
const char* rasterBackendName(RasterBackend backend) { return nameOf(kBackends, backend); }

namespace {


// Kinds of the nearest surface (enter pass colour attachment).
constexpr unsigned kKindNone = 0, kKindClosedFront = 1, kKindClosedBack = 2, kKindOpen = 3;
static_assert(kKindNone == 0 && kKindClosedFront == 1 && kKindClosedBack == 2 && kKindOpen == 3);

// ------------------------------------------------------------------------------------------------ shaders

// The shaders are shaders/*.{vert,frag,glsl}, embedded at configure time (libcpvs/CMakeLists.txt).

// -------------------------------------------------------------------------------------------- renderer

struct GpuVertex {
  float clip[4];
  float plane[3];  // q0, dq/du, dq/dv
  float pad;
  int32_t origin[2];
  float range[2];
};
static_assert(sizeof(GpuVertex) == 48);

// Per triangle of `geometry` (closed, then open): three vertices with
//  * clip positions: for triangles wholly at d >= near / 2 (every orthographic one) the texel position is
//    computed here in double and snapped to 1/256 texel (the rasteriser's sub-pixel grid); p = u - block.x0
//    makes ndc = p * 2 / block.size - 1 exact in float, and GL's viewport transform (origin block.x0 - x0)
//    gives back exactly u - x0: a triangle covers the same texels whatever region of the block it is drawn
//    in. Triangles that reach closer than near / 2 to a perspective light are sent homogeneously (w = d) so
//    GL clips them (also the same in every region of the block).
//  * the depth plane: q (shaders/depth_function.glsl) is affine in the texel coordinates (u, v) over a planar triangle
//    (orthographic: d; perspective: 1 / d), stored around an integer reference texel near the triangle.
//  * the range of q over the triangle (vertex values), to clamp evaluations at pixels just outside a grazing
//    triangle.
struct ViewportBlock {
  uint32_t x0 = 0, y0 = 0, size = 0;  // texels [x0, x0 + size) x [y0, y0 + size) of the view
};

// An alpha-tested triangle's mask and its mask coordinates (MaskInterpolation) around the triangle's
// reference texel, three times (one per vertex, flat); mask -1 for the others.
struct GpuMaskVertex {
  int32_t mask;
  float u[3], v[3], w[3];
};
static_assert(sizeof(GpuMaskVertex) == 40);

void buildMaskVertices(const ViewGeometry& geometry, const LightView& view, GpuMaskVertex* out) {
  const size_t closedCount = geometry.closedIndices.size() / 3;
  const size_t count = closedCount + geometry.openIndices.size() / 3;
  for (size_t t = 0; t < count; ++t) {
    GpuMaskVertex m{-1, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    if (geometry.maskOf[t] >= 0) {
      const uint32_t* idx = t < closedCount ? &geometry.closedIndices[3 * t] : &geometry.openIndices[3 * (t - closedCount)];
      glm::dvec3 p[3];
      glm::dvec2 uv[3];
      for (int k = 0; k < 3; ++k) {
        p[k] = glm::dvec3(geometry.positions[idx[k]]);
        uv[k] = glm::dvec2(geometry.maskUvs[idx[k]]);
      }
      const TriangleSetup s = setUpTriangle(view, p[0], p[1], p[2]);
      const MaskInterpolation mi = setUpMaskInterpolation(view, p, uv);
      // Around the reference texel (u0, v0), as the depth plane: c0 + c1 x + c2 y = c0' + c1 (x - u0) + c2 (y - v0).
      // Clamped into float's range first (a converted double beyond it is undefined): such a triangle then
      // blocks light or not by a rounded coordinate, never by a crash.
      const auto toFloat = [](double v) {
        return std::isfinite(v) ? float(std::clamp(v, -double(FLT_MAX), double(FLT_MAX))) : float(v);
      };
      const auto around = [&](const double (&c)[3], float (&o)[3]) {
        o[0] = toFloat(c[0] + c[1] * s.u0 + c[2] * s.v0);
        o[1] = toFloat(c[1]);
        o[2] = toFloat(c[2]);
      };
      m.mask = geometry.maskOf[t];
      around(mi.U, m.u);
      around(mi.V, m.v);
      around(mi.W, m.w);
    }
    for (int k = 0; k < 3; ++k) out[3 * t + size_t(k)] = m;
  }
}

void buildVertices(const ViewGeometry& geometry, const LightView& view, const ViewportBlock& block, GpuVertex* out) {
  const double n = view.resolution, ex = view.xMax - view.xMin, ey = view.yMax - view.yMin;
  const double halfViewport = 0.5 * block.size;
  const double sx = 2.0 * n / (block.size * ex), sy = 2.0 * n / (block.size * ey);
  const double ac = view.xMin + (double(block.x0) + halfViewport) * ex / n;
  const double bc = view.yMin + (double(block.y0) + halfViewport) * ey / n;
  const size_t closedCount = geometry.closedIndices.size() / 3;
  const size_t count = closedCount + geometry.openIndices.size() / 3;

  auto one = [&](size_t t) {
    const uint32_t* idx = t < closedCount ? &geometry.closedIndices[3 * t]
                                          : &geometry.openIndices[3 * (t - closedCount)];
    glm::dvec3 p[3];
    for (int k = 0; k < 3; ++k) p[k] = glm::dvec3(geometry.positions[idx[k]]);
    const TriangleSetup s = setUpTriangle(view, p[0], p[1], p[2]);
    for (int k = 0; k < 3; ++k) {
      GpuVertex& out3 = out[3 * t + size_t(k)];
      if (s.safe) {
        const double px = std::round(s.u[k] * 256.0) / 256.0 - block.x0;
        const double py = std::round(s.v[k] * 256.0) / 256.0 - block.y0;
        out3.clip[0] = float(px / halfViewport - 1.0);
        out3.clip[1] = float(py / halfViewport - 1.0);
        out3.clip[2] = 0.0f;
        out3.clip[3] = 1.0f;
      } else {
        out3.clip[0] = float(sx * (p[k].x - ac * s.d[k]));
        out3.clip[1] = float(sy * (p[k].y - bc * s.d[k]));
        out3.clip[2] = float(s.d[k] - view.near);
        out3.clip[3] = float(s.d[k]);
      }
      out3.plane[0] = float(s.q0);
      out3.plane[1] = float(s.ku);
      out3.plane[2] = float(s.kv);
      out3.pad = 0.0f;
      out3.origin[0] = int32_t(s.u0);
      out3.origin[1] = int32_t(s.v0);
      out3.range[0] = float(s.qMin);
      out3.range[1] = float(s.qMax);
    }
  };
  if (count >= 16384) {
    parallelFor(count, one, 4096);
  } else {
    for (size_t t = 0; t < count; ++t) one(t);
  }
}


class GlDepthRenderer final : public DepthRenderer {
public:
  explicit GlDepthRenderer(std::unique_ptr<gl::Context> context) : context_(std::move(context)) {
    gl::CurrentContext current(*context_);
    const gl::Functions& g = context_->gl();
    GLint maxTexture = 0, maxRenderbuffer = 0, maxViewport[2] = {0, 0};
    g.GetIntegerv(GL_MAX_TEXTURE_SIZE, &maxTexture);
    g.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &maxRenderbuffer);
    g.GetIntegerv(GL_MAX_VIEWPORT_DIMS, maxViewport);
    // A power of two, so the (power-of-two) viewport of any region fits the limits too.
    const int limit = std::max(1, std::min({maxTexture, maxRenderbuffer, maxViewport[0], maxViewport[1], 8192}));
    maxRegion_ = 1;
    while (int(maxRegion_) * 2 <= limit) maxRegion_ *= 2;
    // The viewport: as large as allowed (a power of two), placed so that it covers an aligned block of the
    // view that contains the region (see render()).
    viewportSize_ = 1;
    while (int64_t(viewportSize_) * 2 <= std::min(maxViewport[0], maxViewport[1])) viewportSize_ *= 2;
    viewportMin_ = -int64_t(viewportSize_);
    if (context_->majorVersion() > 4 || (context_->majorVersion() == 4 && context_->minorVersion() >= 1)) {
      GLint bounds[2] = {0, 0};
      g.GetIntegerv(GL_VIEWPORT_BOUNDS_RANGE, bounds);
      viewportMin_ = bounds[0];
    }

    const std::string geomFS = std::string("#version 330 core\n") + glsl::depth_function_glsl;
    enterProgram_ = link(glsl::depth_geometry_vert, geomFS + kMaskTexelGlsl + glsl::depth_enter_frag, "enter");
    // The enter pass's two integer samplers on units of their own from the start: left both on unit 0, a
    // strict driver refuses every draw, masked or not.
    context_->gl().UseProgram(enterProgram_);
    context_->gl().Uniform1i(uniform(enterProgram_, "maskBytes"), 0);
    context_->gl().Uniform1i(uniform(enterProgram_, "maskHeaders"), 1);
    context_->gl().UseProgram(0);
    peelProgram_ = link(glsl::depth_geometry_vert, geomFS + glsl::depth_peel_frag, "peel");
    initProgram_ = link(glsl::depth_fullscreen_vert, std::string(glsl::peel_state_glsl) + glsl::peel_init_frag, "init");
    updateProgram_ = link(glsl::depth_fullscreen_vert, std::string(glsl::peel_state_glsl) + glsl::peel_update_frag, "update");
    resolveProgram_ = link(glsl::depth_fullscreen_vert, std::string(glsl::peel_state_glsl) + glsl::depth_resolve_frag, "resolve");
    activeProgram_ = link(glsl::depth_fullscreen_vert, std::string(glsl::peel_state_glsl) + glsl::peel_active_frag, "active");

    g.GenVertexArrays(1, &geometryVao_);
    g.GenVertexArrays(1, &emptyVao_);
    g.GenBuffers(1, &vertexBuffer_);
    g.BindVertexArray(geometryVao_);
    g.BindBuffer(GL_ARRAY_BUFFER, vertexBuffer_);
    const GLsizei stride = sizeof(GpuVertex);
    g.VertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(GpuVertex, clip)));
    g.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(GpuVertex, plane)));
    g.VertexAttribIPointer(2, 2, GL_INT, stride, reinterpret_cast<const void*>(offsetof(GpuVertex, origin)));
    g.VertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(offsetof(GpuVertex, range)));
    for (GLuint a = 0; a < 4; ++a) g.EnableVertexAttribArray(a);
    g.GenBuffers(1, &maskVertexBuffer_);
    g.BindBuffer(GL_ARRAY_BUFFER, maskVertexBuffer_);
    const GLsizei maskStride = sizeof(GpuMaskVertex);
    g.VertexAttribIPointer(4, 1, GL_INT, maskStride, reinterpret_cast<const void*>(offsetof(GpuMaskVertex, mask)));
    g.VertexAttribPointer(5, 3, GL_FLOAT, GL_FALSE, maskStride, reinterpret_cast<const void*>(offsetof(GpuMaskVertex, u)));
    g.VertexAttribPointer(6, 3, GL_FLOAT, GL_FALSE, maskStride, reinterpret_cast<const void*>(offsetof(GpuMaskVertex, v)));
    g.VertexAttribPointer(7, 3, GL_FLOAT, GL_FALSE, maskStride, reinterpret_cast<const void*>(offsetof(GpuMaskVertex, w)));
    g.BindVertexArray(0);
    g.GenBuffers(2, maskBuffers_);
    g.GenTextures(2, maskTextures_);
    g.GenQueries(3, queries_);
    checkError("creating the depth renderer");
  }

  ~GlDepthRenderer() override {
    try {
      gl::CurrentContext current(*context_);
      const gl::Functions& g = context_->gl();
      freeTargets();
      for (GLuint p : {enterProgram_, peelProgram_, initProgram_, updateProgram_, resolveProgram_, activeProgram_})
        if (p) g.DeleteProgram(p);
      g.DeleteQueries(3, queries_);
      g.DeleteBuffers(1, &vertexBuffer_);
      g.DeleteBuffers(1, &maskVertexBuffer_);
      g.DeleteBuffers(2, maskBuffers_);
      g.DeleteTextures(2, maskTextures_);
      g.DeleteVertexArrays(1, &geometryVao_);
      g.DeleteVertexArrays(1, &emptyVao_);
    } catch (...) {
      // The context is going away with everything in it.
    }
  }

  uint32_t maxRegionSize() const override { return maxRegion_; }
  std::string description() const override { return context_->description(); }

  DepthRegion render(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                     const PeelSettings& peel, RenderStats* stats, const RowSpans* needed,
                     bool summarizeTiles) override;

private:
  struct Targets {
    uint32_t width = 0, height = 0;
    GLuint enterDepth = 0, frontDepth = 0, backDepth = 0, kinds = 0, backCount = 0;
    GLuint cursors[2] = {0, 0}, counts[2] = {0, 0};
    GLuint enterFbo = 0, frontFbo = 0, backFbo = 0, stateFbo[2] = {0, 0}, resolveFbo = 0;
    bool peel = false;  // the peel state (front/back layers, cursors and counts) exists
  };

  void checkError(const std::string& what) const { gl::checkError(*context_, what); }

  GLuint link(const std::string& vs, const std::string& fs, const char* name) const {
    return gl::linkProgram(*context_, {{GL_VERTEX_SHADER, vs}, {GL_FRAGMENT_SHADER, fs}}, name);
  }

  GLint uniform(GLuint program, const char* name) const { return context_->gl().GetUniformLocation(program, name); }

  GLuint makeTexture(GLenum internalFormat, GLenum format, GLenum type, uint32_t w, uint32_t h) const {
    const gl::Functions& g = context_->gl();
    GLuint tex = 0;
    g.GenTextures(1, &tex);
    g.BindTexture(GL_TEXTURE_2D, tex);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    g.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    g.TexImage2D(GL_TEXTURE_2D, 0, GLint(internalFormat), GLsizei(w), GLsizei(h), 0, format, type, nullptr);
    g.BindTexture(GL_TEXTURE_2D, 0);
    return tex;
  }

  GLuint makeFramebuffer(GLuint depth, std::initializer_list<GLuint> colours) const {
    const gl::Functions& g = context_->gl();
    GLuint fbo = 0;
    g.GenFramebuffers(1, &fbo);
    g.BindFramebuffer(GL_FRAMEBUFFER, fbo);
    if (depth) g.FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
    std::vector<GLenum> buffers;
    for (GLuint c : colours) {
      const GLenum attachment = GLenum(GL_COLOR_ATTACHMENT0 + buffers.size());
      g.FramebufferTexture2D(GL_FRAMEBUFFER, attachment, GL_TEXTURE_2D, c, 0);
      buffers.push_back(attachment);
    }
    if (buffers.empty()) {
      const GLenum none = GL_NONE;
      g.DrawBuffers(1, &none);
      g.ReadBuffer(GL_NONE);
    } else {
      g.DrawBuffers(GLsizei(buffers.size()), buffers.data());
      g.ReadBuffer(GL_COLOR_ATTACHMENT0);
    }
    const GLenum status = g.CheckFramebufferStatus(GL_FRAMEBUFFER);
    g.BindFramebuffer(GL_FRAMEBUFFER, 0);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
      char code[16];
      std::snprintf(code, sizeof code, "0x%04X", unsigned(status));
      throw Error(ErrorCategory::RuntimeFailure, std::string("incomplete framebuffer (") + code + ") on " +
                                                context_->description());
    }
    return fbo;
  }

  // The region's render targets, kept while the region size stays. The peel state (29 of the 41 bytes per
  // texel) is made only once a region has closed triangles: Mesa zero-fills textures when it creates them,
  // which took a quarter of an open scene's bake at 8k.
  void ensureTargets(uint32_t w, uint32_t h, bool withPeel) {
    Targets& t = targets_;
    if (t.width != w || t.height != h) {
      freeTargets();
      context_->gl().GetError();
      t.enterDepth = makeTexture(GL_DEPTH_COMPONENT32F, GL_DEPTH_COMPONENT, GL_FLOAT, w, h);
      t.kinds = makeTexture(GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, w, h);
      t.cursors[1] = makeTexture(GL_RG32F, GL_RG, GL_FLOAT, w, h);  // also the resolve's output
      checkError("allocating " + std::to_string(w) + "x" + std::to_string(h) + " region buffers");
      t.width = w;
      t.height = h;
      t.enterFbo = makeFramebuffer(t.enterDepth, {t.kinds});
      t.resolveFbo = makeFramebuffer(0, {t.cursors[1]});
      checkError("creating region framebuffers");
    }
    if (!withPeel || t.peel) return;
    t.frontDepth = makeTexture(GL_DEPTH_COMPONENT32F, GL_DEPTH_COMPONENT, GL_FLOAT, w, h);
    t.backDepth = makeTexture(GL_DEPTH_COMPONENT32F, GL_DEPTH_COMPONENT, GL_FLOAT, w, h);
    t.backCount = makeTexture(GL_R32F, GL_RED, GL_FLOAT, w, h);
    t.cursors[0] = makeTexture(GL_RG32F, GL_RG, GL_FLOAT, w, h);
    for (int i = 0; i < 2; ++i) t.counts[i] = makeTexture(GL_R32F, GL_RED, GL_FLOAT, w, h);
    checkError("allocating " + std::to_string(w) + "x" + std::to_string(h) + " peel buffers");
    t.peel = true;
    t.frontFbo = makeFramebuffer(t.frontDepth, {});
    t.backFbo = makeFramebuffer(t.backDepth, {t.backCount});
    for (int i = 0; i < 2; ++i) t.stateFbo[i] = makeFramebuffer(0, {t.cursors[i], t.counts[i]});
    checkError("creating peel framebuffers");
  }

  void freeTargets() {
    const gl::Functions& g = context_->gl();
    Targets& t = targets_;
    for (GLuint* fbo : {&t.enterFbo, &t.frontFbo, &t.backFbo, &t.stateFbo[0], &t.stateFbo[1], &t.resolveFbo})
      if (*fbo) g.DeleteFramebuffers(1, fbo), *fbo = 0;
    for (GLuint* tex : {&t.enterDepth, &t.frontDepth, &t.backDepth, &t.kinds, &t.backCount, &t.cursors[0],
                        &t.cursors[1], &t.counts[0], &t.counts[1]})
      if (*tex) g.DeleteTextures(1, tex), *tex = 0;
    t.width = t.height = 0;
    t.peel = false;
  }

  // The masks' bytes and headers as buffer textures, uploaded again only when the masks change.
  void uploadMasks(const std::vector<CoverageMask>& masks) {
    std::vector<uint64_t> hashes;
    for (const CoverageMask& m : masks) hashes.push_back(m.hash());
    if (uploadedMasks_ == &masks && hashes == uploadedMaskHashes_) return;
    const gl::Functions& g = context_->gl();
    const PackedMasks packed = packMasks(masks);
    const std::vector<uint8_t>& bytes = packed.bytes;
    const std::vector<int32_t>& headers = packed.headers;
    GLint maxTexels = 0;
    g.GetIntegerv(GL_MAX_TEXTURE_BUFFER_SIZE, &maxTexels);
    if (bytes.size() > size_t(maxTexels))
      throw Error(ErrorCategory::NotSupported, "alpha-tested materials: " + std::to_string(bytes.size()) +
                                                   " mask texels exceed this GL's buffer texture limit (" +
                                                   std::to_string(maxTexels) + "); bake with --backend cpu");
    const auto upload = [&](int i, const void* data, size_t size, GLenum format) {
      g.BindBuffer(GL_TEXTURE_BUFFER, maskBuffers_[i]);
      const uint8_t none[16] = {};
      g.BufferData(GL_TEXTURE_BUFFER, GLsizeiptr(size ? size : sizeof none), size ? data : none, GL_STATIC_DRAW);
      g.BindTexture(GL_TEXTURE_BUFFER, maskTextures_[i]);
      g.TexBuffer(GL_TEXTURE_BUFFER, format, maskBuffers_[i]);
    };
    upload(0, bytes.data(), bytes.size(), GL_R8UI);
    upload(1, headers.data(), headers.size() * sizeof(int32_t), GL_RGBA32I);
    g.BindBuffer(GL_TEXTURE_BUFFER, 0);
    g.BindTexture(GL_TEXTURE_BUFFER, 0);
    checkError("uploading coverage masks");
    uploadedMasks_ = &masks;
    uploadedMaskHashes_ = std::move(hashes);
  }

  void bindTexture(GLuint program, const char* name, int unit, GLuint texture) const {
    const gl::Functions& g = context_->gl();
    g.ActiveTexture(GLenum(GL_TEXTURE0 + unit));
    g.BindTexture(GL_TEXTURE_2D, texture);
    g.Uniform1i(uniform(program, name), unit);
  }

  void setDepthUniforms(GLuint program, const LightView& view, const RegionRect& rect) const {
    const gl::Functions& g = context_->gl();
    const bool logarithmic = view.mapping == DepthMapping::Logarithmic;
    g.Uniform2i(uniform(program, "regionOrigin"), GLint(rect.x0), GLint(rect.y0));
    g.Uniform1i(uniform(program, "depthMode"), depthMode(view));
    g.Uniform1f(uniform(program, "nearDepth"), float(view.near));
    g.Uniform1f(uniform(program, "invNear"), float(1.0 / view.near));
    g.Uniform1f(uniform(program, "depthScale"),
                float(logarithmic ? 1.0 / std::log2(view.far / view.near) : 1.0 / (view.far - view.near)));
  }

  // The steps of render(), in the order of its GL calls.

  // Throws unless the region lies in the view and fits this context's targets.
  void checkRegion(uint32_t n, const RegionRect& rect) const {
    if (n == 0 || rect.width == 0 || rect.height == 0 || uint64_t(rect.x0) + rect.width > n ||
        uint64_t(rect.y0) + rect.height > n)
      throw Error(ErrorCategory::InvalidArgument, "depth renderer: region " + std::to_string(rect.x0) + "," +
                                                      std::to_string(rect.y0) + " " + std::to_string(rect.width) + "x" +
                                                      std::to_string(rect.height) + " is empty or outside the " +
                                                      std::to_string(n) + "^2 view");
    if (rect.width > maxRegion_ || rect.height > maxRegion_)
      throw Error(ErrorCategory::InvalidArgument, "depth renderer: region " + std::to_string(rect.width) + "x" +
                                                      std::to_string(rect.height) +
                                                      " exceeds the largest this context renders (" +
                                                      std::to_string(maxRegion_) + ")");
    if (n > (1u << 24))
      throw Error(ErrorCategory::NotSupported, "depth renderer: resolutions above 2^24 are not supported");
  }

  // The viewport covers the aligned block of viewportSize_ texels that holds the region, so vertices and GL's
  // clipping are the same for every region of the block (the whole view when N <= viewportSize_); only the
  // viewport's integer origin differs. A region that straddles blocks gets a viewport at its own origin.
  ViewportBlock viewportBlock(const RegionRect& rect) const {
    ViewportBlock block;
    block.size = viewportSize_;
    block.x0 = rect.x0 / viewportSize_ * viewportSize_;
    block.y0 = rect.y0 / viewportSize_ * viewportSize_;
    if (rect.x0 + rect.width > block.x0 + block.size || rect.y0 + rect.height > block.y0 + block.size ||
        int64_t(block.x0) - int64_t(rect.x0) < viewportMin_ || int64_t(block.y0) - int64_t(rect.y0) < viewportMin_) {
      block.x0 = rect.x0;
      block.y0 = rect.y0;
    }
    return block;
  }

  // The region's triangles (`triangles` of them, closed then open) into the vertex buffer, and their masks where
  // some are alpha-tested (then it returns true).
  bool uploadGeometry(const ViewGeometry& culled, const LightView& view, const ViewportBlock& block, size_t triangles) {
    const gl::Functions& g = context_->gl();
    std::vector<GpuVertex> vertices(3 * triangles);
    buildVertices(culled, view, block, vertices.data());
    g.BindVertexArray(geometryVao_);
    g.BindBuffer(GL_ARRAY_BUFFER, vertexBuffer_);
    g.BufferData(GL_ARRAY_BUFFER, GLsizeiptr(vertices.size() * sizeof(GpuVertex)), vertices.data(), GL_STREAM_DRAW);
    const bool masked = culled.hasMasks();
    if (masked) {
      uploadMasks(*culled.masks);
      std::vector<GpuMaskVertex> maskVertices(vertices.size());
      buildMaskVertices(culled, view, maskVertices.data());
      g.BindBuffer(GL_ARRAY_BUFFER, maskVertexBuffer_);
      g.BufferData(GL_ARRAY_BUFFER, GLsizeiptr(maskVertices.size() * sizeof(GpuMaskVertex)), maskVertices.data(),
                   GL_STREAM_DRAW);
      for (GLuint a = 4; a < 8; ++a) g.EnableVertexAttribArray(a);
    } else {
      for (GLuint a = 4; a < 8; ++a) g.DisableVertexAttribArray(a);
      g.VertexAttribI4i(4, -1, 0, 0, 0);  // every triangle opaque
    }
    checkError("uploading geometry");
    return masked;
  }

  void drawClosed(size_t closedCount) const {
    if (closedCount) context_->gl().DrawArrays(GL_TRIANGLES, 0, GLsizei(3 * closedCount));
  }
  void drawOpen(size_t closedCount, size_t openCount) const {
    if (openCount) context_->gl().DrawArrays(GL_TRIANGLES, GLint(3 * closedCount), GLsizei(3 * openCount));
  }
  void fullscreen(GLuint program) const {
    const gl::Functions& g = context_->gl();
    g.UseProgram(program);
    g.BindVertexArray(emptyVao_);
    g.DrawArrays(GL_TRIANGLES, 0, 3);
    g.BindVertexArray(geometryVao_);
  }

  // Front faces, viewport, scissor, blending and colour mask for the region's passes.
  void setUpRasterState(const LightView& view, const RegionRect& rect, const ViewportBlock& block) const {
    const gl::Functions& g = context_->gl();
    // A view transform with a reflection would swap what GL calls front (CCW in the window).
    const double det = glm::determinant(glm::dmat3(view.viewFromWorld));
    g.FrontFace(det < 0 ? GL_CW : GL_CCW);
    // Window x = texel u - x0 exactly; the scissor keeps the region.
    g.Viewport(GLint(int64_t(block.x0) - int64_t(rect.x0)), GLint(int64_t(block.y0) - int64_t(rect.y0)),
               GLsizei(block.size), GLsizei(block.size));
    g.Enable(GL_SCISSOR_TEST);
    g.Scissor(0, 0, GLsizei(rect.width), GLsizei(rect.height));
    g.Disable(GL_BLEND);
    g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  }

  // 1. Enter pass. Draw order decides exact ties (GL_LESS keeps the first): open, closed back, closed front,
  //    so a tie never makes the exit later.
  void enterPass(const LightView& view, const RegionRect& rect, bool masked, size_t closedCount,
                 size_t openCount) const {
    const gl::Functions& g = context_->gl();
    const Targets& t = targets_;
    const GLfloat clearDepth = 1.0f;
    const GLuint zeroU[4] = {0, 0, 0, 0};
    g.BindFramebuffer(GL_FRAMEBUFFER, t.enterFbo);
    g.ClearBufferfv(GL_DEPTH, 0, &clearDepth);
    g.ClearBufferuiv(GL_COLOR, 0, zeroU);
    g.Enable(GL_DEPTH_TEST);
    g.DepthFunc(GL_LESS);
    g.DepthMask(GL_TRUE);
    g.UseProgram(enterProgram_);
    setDepthUniforms(enterProgram_, view, rect);
    if (masked) {
      g.ActiveTexture(GL_TEXTURE0);
      g.BindTexture(GL_TEXTURE_BUFFER, maskTextures_[0]);
      g.Uniform1i(uniform(enterProgram_, "maskBytes"), 0);
      g.ActiveTexture(GL_TEXTURE1);
      g.BindTexture(GL_TEXTURE_BUFFER, maskTextures_[1]);
      g.Uniform1i(uniform(enterProgram_, "maskHeaders"), 1);
    }
    g.Disable(GL_CULL_FACE);
    g.Uniform1i(uniform(enterProgram_, "closedGeometry"), 0);
    drawOpen(closedCount, openCount);
    g.Uniform1i(uniform(enterProgram_, "closedGeometry"), 1);
    g.Enable(GL_CULL_FACE);
    g.CullFace(GL_FRONT);
    drawClosed(closedCount);
    g.CullFace(GL_BACK);
    drawClosed(closedCount);
    g.Finish();
    checkError("rendering enter depth");
  }

  // 2. Init state (with closed triangles only).
  void initPeelState(const PeelSettings& peel) const {
    const gl::Functions& g = context_->gl();
    const Targets& t = targets_;
    g.BindFramebuffer(GL_FRAMEBUFFER, t.stateFbo[0]);
    g.UseProgram(initProgram_);
    bindTexture(initProgram_, "enterDepth", 0, t.enterDepth);
    bindTexture(initProgram_, "kinds", 1, t.kinds);
    g.Uniform1i(uniform(initProgram_, "noPeel"), peel.maxPeels == 0 ? 1 : 0);
    fullscreen(initProgram_);
  }

  // 3. Peel iterations (only when there are closed triangles to peel). Returns the ping-pong state that holds
  // the result.
  int peelPasses(const LightView& view, const RegionRect& rect, const PeelSettings& peel, size_t texels,
                 size_t closedCount, RenderStats& local) const {
    const gl::Functions& g = context_->gl();
    const Targets& t = targets_;
    const GLfloat clearDepth = 1.0f, zero[4] = {0, 0, 0, 0};
    int cur = 0;
    for (uint32_t iteration = 0; iteration < peel.maxPeels; ++iteration) {
      ++local.peelIterations;
      g.Enable(GL_DEPTH_TEST);
      g.DepthFunc(GL_LESS);
      g.DepthMask(GL_TRUE);
      g.Enable(GL_CULL_FACE);
      g.UseProgram(peelProgram_);
      setDepthUniforms(peelProgram_, view, rect);
      bindTexture(peelProgram_, "cursors", 0, t.cursors[cur]);
      bindTexture(peelProgram_, "counts", 1, t.counts[cur]);
      // Front faces.
      g.BindFramebuffer(GL_FRAMEBUFFER, t.frontFbo);
      g.ClearBufferfv(GL_DEPTH, 0, &clearDepth);
      g.CullFace(GL_BACK);
      g.Uniform1i(uniform(peelProgram_, "side"), 0);
      g.BeginQuery(GL_ANY_SAMPLES_PASSED, queries_[0]);
      drawClosed(closedCount);
      g.EndQuery(GL_ANY_SAMPLES_PASSED);
      // Back faces: nearest layer, then its multiplicity (depth EQUAL, additive).
      g.BindFramebuffer(GL_FRAMEBUFFER, t.backFbo);
      g.ClearBufferfv(GL_DEPTH, 0, &clearDepth);
      g.ClearBufferfv(GL_COLOR, 0, zero);
      g.CullFace(GL_FRONT);
      g.Uniform1i(uniform(peelProgram_, "side"), 1);
      g.ColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
      g.BeginQuery(GL_ANY_SAMPLES_PASSED, queries_[1]);
      drawClosed(closedCount);
      g.EndQuery(GL_ANY_SAMPLES_PASSED);
      g.ColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
      GLuint anyFront = 0, anyBack = 0;
      g.GetQueryObjectuiv(queries_[0], GL_QUERY_RESULT, &anyFront);
      g.GetQueryObjectuiv(queries_[1], GL_QUERY_RESULT, &anyBack);
      if (anyBack) {
        g.DepthFunc(GL_EQUAL);
        g.DepthMask(GL_FALSE);
        g.Enable(GL_BLEND);
        g.BlendEquation(GL_FUNC_ADD);
        g.BlendFunc(GL_ONE, GL_ONE);
        drawClosed(closedCount);
        g.Disable(GL_BLEND);
        g.DepthMask(GL_TRUE);
        g.DepthFunc(GL_LESS);
      }
      // Consume the front and the back layer per active texel.
      const bool last = iteration + 1 == peel.maxPeels || !anyBack;
      g.Disable(GL_DEPTH_TEST);
      g.Disable(GL_CULL_FACE);
      g.BindFramebuffer(GL_FRAMEBUFFER, t.stateFbo[1 - cur]);
      g.UseProgram(updateProgram_);
      bindTexture(updateProgram_, "cursors", 0, t.cursors[cur]);
      bindTexture(updateProgram_, "counts", 1, t.counts[cur]);
      bindTexture(updateProgram_, "frontDepth", 2, t.frontDepth);
      bindTexture(updateProgram_, "backDepth", 3, t.backDepth);
      bindTexture(updateProgram_, "backCount", 4, t.backCount);
      g.Uniform1i(uniform(updateProgram_, "lastIteration"), iteration + 1 == peel.maxPeels ? 1 : 0);
      fullscreen(updateProgram_);
      cur = 1 - cur;
      if (last) break;
      // Texels left? None: the next iteration would find nothing to peel. A handful: not worth an iteration,
      // they keep the exit consumed so far (the resolve flags them as capped).
      g.BindFramebuffer(GL_FRAMEBUFFER, t.frontFbo);
      g.UseProgram(activeProgram_);
      bindTexture(activeProgram_, "counts", 0, t.counts[cur]);
      g.BeginQuery(GL_SAMPLES_PASSED, queries_[2]);
      fullscreen(activeProgram_);
      g.EndQuery(GL_SAMPLES_PASSED);
      GLuint active = 0;
      g.GetQueryObjectuiv(queries_[2], GL_QUERY_RESULT, &active);
      if (uint64_t(active) * 1000000u <= uint64_t(peel.stopBelowPerMillion) * texels) break;
    }
    return cur;
  }

  // 4. Resolve into the spare state texture and read back once.
  // Per texel its enter slice, and unless `openOnly` its exit slice (-(x + 1) where the peel cap left it).
  std::vector<float> resolveSlices(const RegionRect& rect, uint32_t n, size_t texels, bool openOnly, int cur) const {
    const gl::Functions& g = context_->gl();
    const Targets& t = targets_;
    g.BindFramebuffer(GL_FRAMEBUFFER, openOnly ? t.resolveFbo : t.stateFbo[1 - cur]);
    g.UseProgram(resolveProgram_);
    bindTexture(resolveProgram_, "enterDepth", 0, t.enterDepth);
    bindTexture(resolveProgram_, "kinds", 1, t.kinds);
    bindTexture(resolveProgram_, "cursors", 2, t.cursors[cur]);
    bindTexture(resolveProgram_, "counts", 3, t.counts[cur]);
    g.Uniform1f(uniform(resolveProgram_, "resolution"), float(n));
    fullscreen(resolveProgram_);
    std::vector<float> slices(openOnly ? texels : 2 * texels);
    g.ReadBuffer(GL_COLOR_ATTACHMENT0);
    g.PixelStorei(GL_PACK_ALIGNMENT, 4);
    g.ReadPixels(0, 0, GLsizei(rect.width), GLsizei(rect.height), openOnly ? GL_RED : GL_RG, GL_FLOAT, slices.data());
    for (int unit = 4; unit >= 0; --unit) {
      g.ActiveTexture(GLenum(GL_TEXTURE0 + unit));
      g.BindTexture(GL_TEXTURE_2D, 0);
    }
    g.BindFramebuffer(GL_FRAMEBUFFER, 0);
    g.BindVertexArray(0);
    g.UseProgram(0);
    g.Disable(GL_SCISSOR_TEST);
    checkError("peeling exit depth");
    return slices;
  }

  // The slices read back (resolveSlices) into the region's maps, and the texels left at the peel cap counted.
  static void unpackSlices(const std::vector<float>& slices, size_t texels, bool openOnly, uint32_t n,
                           DepthRegion& region, RenderStats& local) {
    region.enter.resize(texels);
    region.exit.resize(texels);
    for (size_t i = 0; i < texels; ++i) {
      if (openOnly) {
        const uint32_t e = uint32_t(slices[i]);
        region.enter[i] = e;
        region.exit[i] = e >= n ? n : e + 1;  // the resolve's x = e + 1, and N where nothing was hit
        continue;
      }
      const float e = slices[2 * i], x = slices[2 * i + 1];
      region.enter[i] = uint32_t(e);
      if (x < 0) {
        region.exit[i] = uint32_t(-x - 1.0f);
        ++local.texelsAtPeelCap;
      } else {
        region.exit[i] = uint32_t(x);
      }
    }
  }

  std::unique_ptr<gl::Context> context_;
  uint32_t maxRegion_ = 0;
  uint32_t viewportSize_ = 0;
  int64_t viewportMin_ = 0;  // lowest viewport origin GL accepts
  GLuint enterProgram_ = 0, peelProgram_ = 0, initProgram_ = 0, updateProgram_ = 0, resolveProgram_ = 0,
         activeProgram_ = 0;
  GLuint geometryVao_ = 0, emptyVao_ = 0, vertexBuffer_ = 0;
  GLuint maskVertexBuffer_ = 0, maskBuffers_[2] = {0, 0}, maskTextures_[2] = {0, 0};  // mask bytes, headers
  const std::vector<CoverageMask>* uploadedMasks_ = nullptr;  // what maskBuffers_ hold
  std::vector<uint64_t> uploadedMaskHashes_;
  GLuint queries_[3] = {0, 0, 0};
  Targets targets_;
};

DepthRegion GlDepthRenderer::render(const ViewGeometry& geometry, const LightView& view, const RegionRect& rect,
                                    const PeelSettings& peel, RenderStats* stats, const RowSpans*, bool) {
  const uint32_t n = view.resolution;
  checkRegion(n, rect);

  DepthRegion region;
  region.rect = rect;
  region.resolution = n;
  const size_t texels = size_t(rect.width) * rect.height;
  RenderStats local;

  const ViewGeometry culled = cullToRegion(geometry, rect);
  const size_t closedCount = culled.closedIndices.size() / 3, openCount = culled.openIndices.size() / 3;
  local.trianglesSubmitted = closedCount + openCount;
  if (view.empty || local.trianglesSubmitted == 0) {
    region.enter.assign(texels, n);
    region.exit.assign(texels, n);
    if (stats) *stats = local;
    return region;
  }

  gl::CurrentContext current(*context_);
  const gl::Functions& g = context_->gl();
  g.GetError();
  ensureTargets(rect.width, rect.height, closedCount > 0);

  g.Finish();
  Stopwatch phase;
  const ViewportBlock block = viewportBlock(rect);
  const bool masked = uploadGeometry(culled, view, block, closedCount + openCount);
  setUpRasterState(view, rect, block);
  enterPass(view, rect, masked, closedCount, openCount);
  local.enterMs = phase.ms();
  phase.restart();

  // 2. Init state.
  g.Disable(GL_DEPTH_TEST);
  g.Disable(GL_CULL_FACE);
  // Without closed triangles no texel is of kind 1: the resolve never reads the state, and every exit is
  // enter + 1 (N where nothing was hit), so the state passes are skipped and only the enter slices read back.
  const bool openOnly = closedCount == 0;
  if (!openOnly) initPeelState(peel);
  int cur = 0;

  // 3. Peel iterations (only when there are closed triangles to peel).
  if (closedCount > 0) cur = peelPasses(view, rect, peel, texels, closedCount, local);

  const std::vector<float> slices = resolveSlices(rect, n, texels, openOnly, cur);
  unpackSlices(slices, texels, openOnly, n, region, local);
  local.peelMs = phase.ms();
  if (stats) *stats = local;
  return region;
}

}  // namespace

std::unique_ptr<DepthRenderer> DepthRenderer::create(RasterBackend backend) {
  if (backend == RasterBackend::Cpu) return createCpuDepthRenderer();
  std::unique_ptr<gl::Context> context =
      backend == RasterBackend::EGL ? gl::createEGLContext() : gl::createOSMesaContext();
  return std::make_unique<GlDepthRenderer>(std::move(context));
}

}  // namespace cpvs
