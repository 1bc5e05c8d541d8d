#include "libcpvs/preview/preview_renderer.h"

#include <map>

#include "libcpvs/base/error.h"
#include "libcpvs/gl/gl_program.h"
#include "libcpvs/preview/renderer_resources.h"
#include "libcpvs/preview/shadow_pass.h"

namespace cpvs {

namespace {

constexpr uint32_t kMaxImageEdge = 16384;
constexpr GLuint kBaseColorUnit = 4;  // gbuffer.frag's sampler binding

}  // namespace

struct PreviewRenderer::State {
  std::unique_ptr<RendererResources> resources;
  std::map<ShadowMode, std::unique_ptr<ShadowPass>> techniques;  // made on first use
};

// One frame's passes over the shared resources, in order; each step leaves its results in the frame.
class PreviewRenderer::FramePasses {
public:
  FramePasses(RendererResources& r, const FrameSettings& settings)
      : r_(r), g_(r.gl()), settings_(settings), buffers_(*r.context), timer_(*r.context) {}

  Frame start() {
    Frame f;
    f.width = settings_.width;
    f.height = settings_.height;
    f.lists.tilesX = (f.width + kTileSize - 1) / kTileSize;
    f.lists.tilesY = (f.height + kTileSize - 1) / kTileSize;
    f.uploadedBytes = r_.staticBytes;
    return f;
  }

  void timed(Frame& f, const std::string& pass, const std::function<void()>& work) {
    timer_.begin();
    work();
    timer_.end();
    f.passes.push_back({pass, timer_.milliseconds(), timer_.usesGpuTimer()});
  }

  // 1. G-buffer: world position, normal facing the camera, base colour.
  void gbuffer(Frame& f, const PreviewCamera& camera) {
    timed(f, "gbuffer", [&] {
      g_.BindFramebuffer(GL_FRAMEBUFFER, r_.framebuffer);
      g_.Viewport(0, 0, GLsizei(f.width), GLsizei(f.height));
      const GLfloat zero[4] = {0, 0, 0, 0}, one = 1.0f;
      for (GLint i = 0; i < 3; ++i) g_.ClearBufferfv(GL_COLOR, i, zero);
      g_.ClearBufferfv(GL_DEPTH, 0, &one);
      g_.Enable(GL_DEPTH_TEST);
      g_.DepthFunc(GL_LESS);
      g_.DepthMask(GL_TRUE);
      g_.Disable(GL_CULL_FACE);
      g_.Disable(GL_BLEND);
      g_.UseProgram(r_.gbufferProgram);
      g_.ActiveTexture(GL_TEXTURE0 + kBaseColorUnit);
      g_.BindTexture(GL_TEXTURE_2D_ARRAY, r_.baseColorArray);
      g_.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kMaskHeaders, r_.maskHeaders);
      g_.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kMaskBytes, r_.maskBytes);
      const glm::mat4 matrix(clipFromWorld(camera, double(f.width) / double(f.height)));
      g_.UniformMatrix4fv(g_.GetUniformLocation(r_.gbufferProgram, "clipFromWorld"), 1, GL_FALSE, &matrix[0][0]);
      g_.BindVertexArray(r_.vertexArray);
      g_.DrawArrays(GL_TRIANGLES, 0, r_.vertexCount);
      g_.BindVertexArray(0);
    });
    gl::checkError(*r_.context, "rendering the G-buffer");
  }

  // 2. Tile bounds: per 8 x 8 tile, the world bounds of its pixels.
  void tileBounds(Frame& f) {
    tileBounds_ = buffers_.add(gl::createStorageBuffer(*r_.context, nullptr, f.lists.tiles() * 32));
    timed(f, "tile_bounds", [&] {
      g_.UseProgram(r_.boundsProgram);
      setSizes(f, r_.boundsProgram);
      g_.ActiveTexture(GL_TEXTURE0);
      g_.BindTexture(GL_TEXTURE_2D, r_.targets[0]);
      g_.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kTileBounds, tileBounds_);
      g_.DispatchCompute(GLuint((f.lists.tiles() + 255) / 256), 1, 1);
      g_.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
    });
  }

  // 3. Light lists: per super-tile (kSuperTile x kSuperTile tiles) the lights its bounds meet, at most every
  // light; then per tile those of its super-tile's that meet the tile (light_lists.comp): count (marking each
  // candidate that meets it in the tile's bits), prefix sum (prefix_sum.comp), the total read back to size the
  // list, fill from the bits. Then the G-buffer read back.
  void lightLists(Frame& f) {
    const gl::Context& c = *r_.context;
    const size_t tiles = f.lists.tiles(), lights = std::max<size_t>(1, r_.lights.size());
    const size_t supers = size_t((f.lists.tilesX + kSuperTile - 1) / kSuperTile) * ((f.lists.tilesY + kSuperTile - 1) / kSuperTile);
    r_.requireStorage(supers * lights * 4, "the light lists of " + std::to_string(supers) + " super-tiles");
    const GLuint superBounds = buffers_.add(gl::createStorageBuffer(c, nullptr, supers * 32));
    const GLuint superCounts = buffers_.add(gl::createStorageBuffer(c, nullptr, supers * 4));
    const GLuint superLights = buffers_.add(gl::createStorageBuffer(c, nullptr, supers * lights * 4));
    const GLuint counts = buffers_.add(gl::createStorageBuffer(c, nullptr, tiles * 4));
    const size_t wordsPerTile = (lights + 31) / 32;
    r_.requireStorage(tiles * wordsPerTile * 4, "the light lists of " + std::to_string(tiles) + " tiles");
    const GLuint tileBits = buffers_.add(gl::createStorageBuffer(c, nullptr, tiles * wordsPerTile * 4));
    offsets_ = buffers_.add(gl::createStorageBuffer(c, nullptr, (tiles + 1) * 4));
    timed(f, "light_lists", [&] {
      g_.UseProgram(r_.superBoundsProgram);
      setSizes(f, r_.superBoundsProgram);
      bind({{binding::kTileBounds, tileBounds_}, {binding::kSuperBounds, superBounds}});
      dispatch(supers, 64);
      g_.UseProgram(r_.superListProgram);
      setSizes(f, r_.superListProgram);
      g_.Uniform1i(g_.GetUniformLocation(r_.superListProgram, "tiles"), GLint(supers));
      g_.Uniform1i(g_.GetUniformLocation(r_.superListProgram, "lightCount"), GLint(r_.lights.size()));
      bind({{binding::kTileBounds, superBounds}, {binding::kLightReals, r_.lightReals},
            {binding::kLightWords, r_.lightWords}, {binding::kTileCounts, superCounts},
            {binding::kTileLights, superLights}});
      dispatch(supers, 256);
      lists_ = tileLists(f, tiles, {r_.countProgram, r_.fillProgram},
                         {{binding::kTileBounds, tileBounds_}, {binding::kTileCounts, counts},
                          {binding::kTileOffsets, offsets_}, {binding::kSuperCounts, superCounts},
                          {binding::kSuperLights, superLights}, {binding::kTileBits, tileBits}},
                         GLint(wordsPerTile));
    });
    gl::checkError(c, "building the tile light lists");
    f.lists.lights.resize(f.lists.offsets.back());
    gl::readStorageBuffer(c, lists_, f.lists.lights.data(), f.lists.lights.size() * 4);
    f.positions = r_.readTarget(0, f.width, f.height);
    f.normals = r_.readTarget(1, f.width, f.height);
    f.baseColors = r_.readTarget(2, f.width, f.height);
  }

  // 4. Shadows: the technique fills one visibility per (list entry, pixel of the tile).
  ShadowPassFrame shadowFrame(Frame& f) {
    const size_t pairs = size_t(f.lists.offsets.back());
    r_.requireStorage(pairs * 64 * (settings_.recordCells ? 16 : 4), std::to_string(pairs) + " (tile, light) pairs");
    ShadowPassFrame p(f, settings_, r_, [this, &f](const std::string& pass, const std::function<void()>& work) {
      timed(f, pass, work);
    });
    p.offsets = offsets_;
    p.lists = lists_;
    p.visibility = visibility_ = buffers_.add(gl::createStorageBuffer(*r_.context, nullptr, pairs * 64 * 4));
    if (settings_.recordCells) p.cells = buffers_.add(gl::createStorageBuffer(*r_.context, nullptr, pairs * 64 * 16));
    return p;
  }

  // Puts CPU-side visibility where the shading pass reads it.
  void uploadVisibility(const std::vector<float>& visibility) {
    g_.BindBuffer(GL_SHADER_STORAGE_BUFFER, visibility_);
    if (!visibility.empty())
      g_.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(visibility.size() * 4), visibility.data());
  }

  // 5. Shading: KHR_lights_punctual with the visibility, read back as linear radiance (and the per-pixel
  // counts the overlays show).
  std::vector<glm::vec4> shade(Frame& f, ShadowPassFrame& p, const PreviewCamera& camera, bool timedPass) {
    const gl::Context& c = *r_.context;
    const size_t pixels = size_t(f.width) * f.height;
    if (!radiance_) radiance_ = buffers_.add(gl::createStorageBuffer(c, nullptr, pixels * 16));
    if (!stats_) stats_ = buffers_.add(gl::createStorageBuffer(c, nullptr, pixels * 8));
    const auto dispatch = [&] {
      g_.UseProgram(r_.shadingProgram);
      p.bindSceneBuffers(r_.shadingProgram);
      g_.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kRadiance, radiance_);
      g_.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kStats, stats_);
      g_.Uniform3f(g_.GetUniformLocation(r_.shadingProgram, "eye"), float(camera.eye.x), float(camera.eye.y),
                   float(camera.eye.z));
      g_.Uniform1f(g_.GetUniformLocation(r_.shadingProgram, "specular"), 0.25f);
      g_.DispatchCompute(f.lists.tilesX, f.lists.tilesY, 1);
      g_.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    };
    if (timedPass) {
      timed(f, "shading", dispatch);
      f.stats.resize(pixels);
      gl::readStorageBuffer(c, stats_, f.stats.data(), pixels * 8);
    } else {
      dispatch();
    }
    std::vector<glm::vec4> radiance(pixels);
    gl::readStorageBuffer(c, radiance_, radiance.data(), pixels * 16);
    gl::checkError(c, "shading");
    return radiance;
  }

private:
  using Bindings = std::initializer_list<std::pair<GLuint, GLuint>>;  // (binding, buffer)
  void bind(Bindings bindings) {
    for (const auto& [index, buffer] : bindings) g_.BindBufferBase(GL_SHADER_STORAGE_BUFFER, index, buffer);
  }
  void dispatch(size_t invocations, size_t groupSize) {
    g_.DispatchCompute(GLuint((invocations + groupSize - 1) / groupSize), 1, 1);
    g_.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  }
  // The tiles' lists from their super-tiles' candidates: count, prefix sum, the total read back (into
  // Frame::lists.offsets) to size the list, fill. Returns the list buffer.
  GLuint tileLists(Frame& f, size_t cells, std::pair<GLuint, GLuint> countAndFill, Bindings bindings,
                   GLint wordsPerTile) {
    const gl::Context& c = *r_.context;
    GLuint offsets = 0;
    for (const auto& [index, buffer] : bindings)
      if (index == binding::kTileOffsets) offsets = buffer;
    for (GLuint program : {countAndFill.first, r_.prefixProgram}) {
      g_.UseProgram(program);
      setSizes(f, program);
      g_.Uniform1i(g_.GetUniformLocation(program, "tiles"), GLint(cells));
      g_.Uniform1i(g_.GetUniformLocation(program, "lightCount"), GLint(r_.lights.size()));
      g_.Uniform1i(g_.GetUniformLocation(program, "wordsPerTile"), wordsPerTile);
      bind(bindings);
      bind({{binding::kLightReals, r_.lightReals}, {binding::kLightWords, r_.lightWords}});
      dispatch(program == r_.prefixProgram ? 1 : cells, program == r_.prefixProgram ? 1 : 256);
    }
    std::vector<uint32_t>& out = f.lists.offsets;
    out.resize(cells + 1);
    gl::readStorageBuffer(c, offsets, out.data(), out.size() * 4);
    const GLuint lights = buffers_.add(gl::createStorageBuffer(c, nullptr, size_t(out.back()) * 4));
    g_.UseProgram(countAndFill.second);
    setSizes(f, countAndFill.second);
    g_.Uniform1i(g_.GetUniformLocation(countAndFill.second, "tiles"), GLint(cells));
    g_.Uniform1i(g_.GetUniformLocation(countAndFill.second, "lightCount"), GLint(r_.lights.size()));
    g_.Uniform1i(g_.GetUniformLocation(countAndFill.second, "wordsPerTile"), wordsPerTile);
    bind(bindings);
    bind({{binding::kLightReals, r_.lightReals}, {binding::kLightWords, r_.lightWords}, {binding::kTileLights, lights}});
    dispatch(cells, 256);
    return lights;
  }

  void setSizes(const Frame& f, GLuint program) {
    g_.Uniform2i(g_.GetUniformLocation(program, "imageSize_"), GLint(f.width), GLint(f.height));
    g_.Uniform2i(g_.GetUniformLocation(program, "tileCount"), GLint(f.lists.tilesX), GLint(f.lists.tilesY));
    g_.Uniform1i(g_.GetUniformLocation(program, "tiles"), GLint(f.lists.tiles()));
  }

  RendererResources& r_;
  const gl::Functions& g_;
  const FrameSettings& settings_;
  FrameBuffers buffers_;
  gl::PassTimer timer_;
  GLuint tileBounds_ = 0, offsets_ = 0, lists_ = 0, visibility_ = 0, radiance_ = 0, stats_ = 0;
};

PreviewRenderer::PreviewRenderer(const Scene& scene, std::vector<LightShadow> lights, RasterBackend backend,
                                 unsigned threads)
    : state_(std::make_unique<State>()) {
  if (backend == RasterBackend::Cpu)
    throw Error(ErrorCategory::InvalidArgument, "cpvs-view renders with OpenGL: the backend is osmesa or egl");
  state_->resources = std::make_unique<RendererResources>(scene, std::move(lights), backend == RasterBackend::EGL, threads);
}

PreviewRenderer::~PreviewRenderer() = default;

void PreviewRenderer::warmUp(const FrameSettings& like) {
  // Tiny frames through every pass: llvmpipe compiles a shader on its first use, and again for textures whose
  // sides are or are not powers of two (a first 320x240 frame's shadow pass took 323 ms, the next 18 ms).
  const Bounds& bounds = state_->resources->bounds;
  for (const auto& [w, h] : {std::pair{16u, 16u}, {24u, 24u}, {16u, 24u}, {24u, 16u}}) {
    FrameSettings tiny;
    tiny.width = w;
    tiny.height = h;
    // The GPU walk only when it will be used: it needs the DAGs on the GPU.
    if (like.shadows != ShadowMode::Gpu) tiny.shadows = ShadowMode::None;
    render(defaultCamera(bounds, 1.0), tiny);
    // The shadow-map modes' programs and their map array at the frame's map size.
    if (like.shadows == ShadowMode::ShadowMap || like.shadows == ShadowMode::LightCluster) {
      tiny.shadows = ShadowMode::ShadowMap;
      tiny.shadowMaps.size = like.shadowMaps.size;
      render(defaultCamera(bounds, 1.0), tiny);
    }
  }
}

const std::string& PreviewRenderer::contextDescription() const { return state_->resources->context->description(); }
const std::vector<LightShadow>& PreviewRenderer::lights() const { return state_->resources->lights; }
size_t PreviewRenderer::sceneTriangles() const { return state_->resources->triangles; }
size_t PreviewRenderer::staticUploadBytes() const { return state_->resources->staticBytes; }
size_t PreviewRenderer::shadowDataBytes() const { return state_->resources->shadowBytes; }

PreviewRenderer::ShadowChoice PreviewRenderer::automaticShadows() const {
  const RendererResources& r = *state_->resources;
  const std::string& gl = r.context->description();
  for (const char* software : {"llvmpipe", "softpipe", "swrast", "Software Rasterizer", "SwiftShader"})
    if (gl.find(software) != std::string::npos)
      return {ShadowMode::Cpu, gl + " rasterises on the CPU: the CPU runtime's lookups are faster than a compute "
                                    "shader there (--shadows gpu walks the DAGs on it anyway)"};
  if (r.dagBufferBytes > r.maxStorageBlock)
    return {ShadowMode::Cpu, "the DAGs need a " + std::to_string(r.dagBufferBytes >> 20) + " MiB storage buffer, " + gl +
                                 " allows " + std::to_string(r.maxStorageBlock >> 20) + " MiB"};
  return {ShadowMode::Gpu, gl + " holds the DAGs (" + std::to_string(r.dagBufferBytes >> 20) + " MiB of " +
                               std::to_string(r.maxStorageBlock >> 20) + " MiB a storage buffer)"};
}

Frame PreviewRenderer::render(const PreviewCamera& camera, const FrameSettings& settings) {
  std::unique_ptr<ShadowPass>& technique = state_->techniques[settings.shadows];
  if (!technique) {
    gl::CurrentContext current(*state_->resources->context);
    technique = makeShadowPass(settings.shadows, *state_->resources);
  }
  return render(camera, settings, *technique);
}

void PreviewRenderer::checkFrame(const PreviewCamera& camera, const FrameSettings& settings) const {
  if (settings.width == 0 || settings.height == 0 || settings.width > kMaxImageEdge || settings.height > kMaxImageEdge)
    throw Error(ErrorCategory::InvalidArgument, "image size " + std::to_string(settings.width) + "x" +
                                                    std::to_string(settings.height) + " is not in 1..16384 per side");
  if (const Outcome k = checkPcfKernel(settings.pcfKernel); !k) throw Error(k.category(), k.message());
  checkCamera(camera);
  for (uint32_t l : settings.disabledLights)
    if (l >= lights().size())
      throw Error(ErrorCategory::InvalidArgument, "light " + std::to_string(l) + " to switch off does not exist (" +
                                                      std::to_string(lights().size()) + " lights)");
}

Frame PreviewRenderer::render(const PreviewCamera& requested, const FrameSettings& settings, ShadowPass& technique) {
  checkFrame(requested, settings);
  RendererResources& r = *state_->resources;
  const PreviewCamera camera = withClipPlanes(requested, r.bounds);
  gl::CurrentContext current(*r.context);
  r.ensureTargets(settings.width, settings.height);
  std::vector<uint32_t> disabled(r.lights.size(), 0);
  for (uint32_t l : settings.disabledLights) disabled[l] = 1;
  r.setDisabledLights(disabled);
  gl::checkError(*r.context, "preparing the frame");
  r.requireStorage(size_t(settings.width) * settings.height * 16,
                   "the frame's " + std::to_string(settings.width) + "x" + std::to_string(settings.height) + " pixels");

  FramePasses passes(r, settings);
  Frame f = passes.start();
  f.eye = camera.eye;
  passes.gbuffer(f, camera);
  passes.tileBounds(f);
  passes.lightLists(f);
  ShadowPassFrame shadows = passes.shadowFrame(f);
  if (!technique.run(shadows)) {
    passes.uploadVisibility(f.visibility);
    f.uploadedBytes += f.visibility.size() * 4;
  }
  f.radiance = passes.shade(f, shadows, camera, true);
  if (settings.compareWithRays) {
    if (settings.shadows == ShadowMode::RayTraced && settings.raysPerSide == settings.compareRaysPerSide) {
      f.rayVisibility = f.visibility;
    } else {
      f.rayVisibility.assign(f.visibility.size(), 0.0f);
      rayTracedVisibility(shadows, settings.compareRaysPerSide, f.rayVisibility.data());
    }
    passes.uploadVisibility(f.rayVisibility);  // the comparison's upload is not counted as the frame's
    f.rayRadiance = passes.shade(f, shadows, camera, false);
    gl::checkError(*r.context, "shading the ray-traced frame");
  }
  r.gl().UseProgram(0);
  return f;
}

}  // namespace cpvs
