// --shadows shadowmap | lightcluster: the per-frame techniques CPVS replaces (the culling demo,
// docs/culling-demo.md). Each frame: plan which light views get a map and with which triangles (the caster
// culling, on the CPU: timed as "culling"), draw every map into one depth array ("shadow_maps"), look them up
// with K x K PCF ("shadows"). LightCluster draws one cube map per cluster of lights instead of one map per light
// view; the rest is the same.
#include <cmath>

#include <tbb/task_arena.h>

#include "libcpvs/base/error.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/eval/shadow_map.h"
#include "libcpvs/gl/gl_program.h"
#include "libcpvs/preview/glsl_sources.h"
#include "libcpvs/preview/light_clusters.h"
#include "libcpvs/preview/shadow_map_plan.h"
#include "libcpvs/preview/shadow_pass.h"
#include "libcpvs/raster/gpu_masks.h"
#include "libcpvs/views/view_fitting.h"

namespace cpvs {

namespace {

class ShadowMapShadows final : public ShadowPass {
public:
  ShadowMapShadows(RendererResources& r, bool clustered) : clustered_(clustered) {
    const gl::Context& c = *r.context;
    const std::string version = "#version 450\n";
    depthProgram_ = gl::linkProgram(c, {{GL_VERTEX_SHADER, version + glsl::shadow_map_depth_vert},
                                        {GL_FRAGMENT_SHADER, version + kMaskTexelGlsl + glsl::coverage_mask_glsl +
                                                                 glsl::shadow_map_depth_frag}}, "shadow-map depth");
    lookupProgram_ = gl::linkProgram(
        c, {{GL_COMPUTE_SHADER, computeSource({"layout(local_size_x = 8, local_size_y = 8) in;\n",
                                               glsl::lookup_records_glsl, glsl::scene_buffers_glsl,
                                               glsl::lookup_cell_glsl, glsl::shadow_map_lookups_comp})}},
        "shadow-map lookup");
  }

  bool run(ShadowPassFrame& p) override {
    const ShadowMapSettings& maps = p.settings.shadowMaps;
    if (maps.size < 8 || maps.size > 8192)
      throw Error(ErrorCategory::InvalidArgument, "shadow map size " + std::to_string(maps.size) + " is not in 8..8192");
    const ShadowMapPlan plan = planFrame(p);
    FrameBuffers buffers(*p.resources.context);
    std::vector<size_t> firstIndex;
    const GpuRecords records = upload(p, plan, buffers, firstIndex);
    drawMaps(p, plan, firstIndex);
    if (maps.keepMaps) readMaps(p, uint32_t(plan.views.size()));
    lookUp(p, records);
    return true;
  }

private:
  struct GpuRecords {
    GLuint lightReals = 0, lightWords = 0, viewReals = 0, viewWords = 0;
  };

  // The clusters and their cubes for one count and size (LightCluster), the voxel grid (on first use), then the
  // frame's plan.
  ShadowMapPlan planFrame(ShadowPassFrame& p) {
    RendererResources& r = p.resources;
    const ShadowMapSettings& maps = p.settings.shadowMaps;
    if (clustered_ && (clusterCount_ != maps.clusters || clusterSize_ != maps.size)) {
      std::vector<Light> all;
      for (const LightShadow& l : r.lights) all.push_back(l.light());
      clusters_ = clusterLights(all, maps.clusters);
      clusterViews_.clear();
      const WorldGeometry world = flatten(*r.scene);
      for (const Light& cluster : clusters_.lights) clusterViews_.push_back(makeLightViews(cluster, world, maps.size));
      clusterCount_ = maps.clusters;
      clusterSize_ = maps.size;
    }
    if (maps.casterCulling == CasterCulling::VoxelGrid && !grid_)
      grid_ = std::make_unique<CasterGrid>(r.casterTriangles, r.bounds);
    ShadowMapScene scene;
    scene.lights = &r.lights;
    scene.triangles = &r.casterTriangles;
    scene.grid = grid_.get();
    scene.clusters = &clusters_;
    scene.clusterViews = &clusterViews_;
    tbb::task_arena arena(int(std::max(1u, r.threadCount())));
    Stopwatch clock;
    ShadowMapPlan plan;
    arena.execute([&] { plan = planShadowMaps(scene, p.frame, p.settings, clustered_); });
    p.frame.passes.push_back({"culling", clock.ms(), false});
    return plan;
  }

  // The records the lookups read and the index lists of the culled views; the frame's map figures.
  GpuRecords upload(ShadowPassFrame& p, const ShadowMapPlan& plan, FrameBuffers& buffers, std::vector<size_t>& firstIndex) {
    RendererResources& r = p.resources;
    const gl::Context& c = *r.context;
    const gl::Functions& g = c.gl();
    const uint32_t m = p.settings.shadowMaps.size, layers = uint32_t(plan.views.size());
    GpuRecords out;
    out.lightReals = buffers.add(gl::createStorageBuffer(c, plan.records.lightReals.data(), plan.records.lightReals.size() * 8));
    out.lightWords = buffers.add(gl::createStorageBuffer(c, plan.records.lightWords.data(), plan.records.lightWords.size() * 4));
    out.viewReals = buffers.add(gl::createStorageBuffer(c, plan.records.viewReals.data(), plan.records.viewReals.size() * 8));
    out.viewWords = buffers.add(gl::createStorageBuffer(c, plan.records.viewWords.data(), plan.records.viewWords.size() * 4));
    std::vector<uint32_t> indices;
    firstIndex.assign(layers, 0);
    for (uint32_t layer = 0; layer < layers; ++layer) {
      firstIndex[layer] = indices.size();
      for (uint32_t t : plan.views[layer].triangles) indices.insert(indices.end(), {3 * t, 3 * t + 1, 3 * t + 2});
    }
    GLuint elements = 0;
    g.GenBuffers(1, &elements);
    buffers.add(elements);
    g.BindVertexArray(r.vertexArray);
    g.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, elements);
    g.BufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(std::max<size_t>(indices.size(), 1) * 4), indices.data(), GL_STATIC_DRAW);
    ensureMapArray(c, m, layers);
    Frame& f = p.frame;
    f.uploadedBytes += plan.records.bytes() + indices.size() * 4;
    f.shadowMaps.size = m;
    f.shadowMaps.trianglesPerLight = plan.trianglesPerLight;
    f.shadowMaps.bytes = uint64_t(layers) * m * m * 4 + indices.size() * 4;
    for (const MapView& mv : plan.views) {
      f.shadowMaps.shadowLight.push_back(mv.shadowLight);
      f.shadowMaps.views.push_back(mv.mapView);
      f.shadowMaps.triangles.push_back(mv.drawAll ? r.triangles : mv.triangles.size());
    }
    return out;
  }

  // The maps, one layer per view: eval/shadow_map.h's 16-bit depth as q / 65536 in a float depth buffer.
  void drawMaps(ShadowPassFrame& p, const ShadowMapPlan& plan, const std::vector<size_t>& firstIndex) {
    RendererResources& r = p.resources;
    const gl::Functions& g = r.gl();
    const uint32_t m = p.settings.shadowMaps.size, layers = uint32_t(plan.views.size());
    std::vector<GLuint> queries(std::max(1u, layers));
    g.GenQueries(GLsizei(queries.size()), queries.data());
    std::vector<uint8_t> drawn(layers, 0);
    p.timed("shadow_maps", [&] {
      g.BindFramebuffer(GL_FRAMEBUFFER, mapFramebuffer_);
      const GLenum none = GL_NONE;
      g.DrawBuffers(1, &none);
      g.ReadBuffer(GL_NONE);
      g.Viewport(0, 0, GLsizei(m), GLsizei(m));
      g.Enable(GL_DEPTH_TEST);
      g.DepthFunc(GL_LESS);
      g.DepthMask(GL_TRUE);
      g.Disable(GL_CULL_FACE);
      g.UseProgram(depthProgram_);
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kMaskHeaders, r.maskHeaders);
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kMaskBytes, r.maskBytes);
      const auto uniform = [&](const char* name) { return g.GetUniformLocation(depthProgram_, name); };
      g.Uniform1f(uniform("mapSize"), float(m));
      const GLfloat far = float(ShadowMap16::kFar) / 65536.0f;
      for (uint32_t layer = 0; layer < layers; ++layer) {
        const MapView& mv = plan.views[layer];
        g.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, mapArray_, 0, GLint(layer));
        g.ClearBufferfv(GL_DEPTH, 0, &far);
        if (mv.mapView.empty || (!mv.drawAll && mv.triangles.empty())) continue;
        const ViewMapping vm(mv.mapView);
        const glm::mat4 matrix(mv.mapView.viewFromWorld);
        g.UniformMatrix4fv(uniform("viewFromWorld"), 1, GL_FALSE, &matrix[0][0]);
        g.Uniform4f(uniform("lateral"), float(mv.mapView.xMin), float(mv.mapView.yMin),
                    float(mv.mapView.xMax - mv.mapView.xMin), float(mv.mapView.yMax - mv.mapView.yMin));
        g.Uniform1i(uniform("orthographic"), vm.orthographic ? 1 : 0);
        g.Uniform1i(uniform("linearDepth"), vm.linear ? 1 : 0);
        g.Uniform1f(uniform("nearDepth"), float(vm.near));
        g.Uniform1f(uniform("sliceScale"), float(vm.sScale));
        g.BeginQuery(GL_SAMPLES_PASSED, queries[layer]);
        if (mv.drawAll)
          g.DrawArrays(GL_TRIANGLES, 0, r.vertexCount);
        else
          g.DrawElements(GL_TRIANGLES, GLsizei(mv.triangles.size() * 3), GL_UNSIGNED_INT,
                         reinterpret_cast<const void*>(firstIndex[layer] * 4));
        g.EndQuery(GL_SAMPLES_PASSED);
        drawn[layer] = 1;
      }
    });
    g.BindVertexArray(0);
    ShadowMapFrame& counters = p.frame.shadowMaps;
    counters.fragments.assign(layers, 0);
    for (uint32_t layer = 0; layer < layers; ++layer) {
      if (!drawn[layer]) continue;
      GLuint samples = 0;
      g.GetQueryObjectuiv(queries[layer], GL_QUERY_RESULT, &samples);
      counters.fragments[layer] = samples;
      ++counters.drawCalls;
    }
    counters.texelsCleared = uint64_t(layers) * m * m;
    g.DeleteQueries(GLsizei(queries.size()), queries.data());
    gl::checkError(*r.context, "rendering " + std::to_string(layers) + " shadow maps");
  }

  void readMaps(ShadowPassFrame& p, uint32_t layers) {
    const gl::Functions& g = p.resources.gl();
    const uint32_t m = p.settings.shadowMaps.size;
    std::vector<float> depth(size_t(m) * m);
    std::vector<uint16_t>& texels = p.frame.shadowMaps.texels;
    texels.resize(size_t(layers) * m * m);
    g.BindFramebuffer(GL_FRAMEBUFFER, mapFramebuffer_);
    g.PixelStorei(GL_PACK_ALIGNMENT, 4);
    for (uint32_t layer = 0; layer < layers; ++layer) {
      g.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, mapArray_, 0, GLint(layer));
      g.ReadPixels(0, 0, GLsizei(m), GLsizei(m), GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
      for (size_t i = 0; i < depth.size(); ++i)
        texels[size_t(layer) * m * m + i] = uint16_t(std::lround(double(depth[i]) * 65536.0));
    }
    gl::checkError(*p.resources.context, "reading back the shadow maps");
  }

  void lookUp(ShadowPassFrame& p, const GpuRecords& records) {
    RendererResources& r = p.resources;
    const gl::Functions& g = r.gl();
    Frame& f = p.frame;
    p.timed("shadows", [&] {
      g.UseProgram(lookupProgram_);
      const GLuint program = lookupProgram_;
      g.Uniform2i(g.GetUniformLocation(program, "imageSize_"), GLint(f.width), GLint(f.height));
      g.Uniform2i(g.GetUniformLocation(program, "tileCount"), GLint(f.lists.tilesX), GLint(f.lists.tilesY));
      g.Uniform1i(g.GetUniformLocation(program, "pcfKernel"), p.settings.pcfKernel);
      g.Uniform1d(g.GetUniformLocation(program, "biasMargin"), p.settings.biasMargin);
      g.ActiveTexture(GL_TEXTURE0);
      g.BindTexture(GL_TEXTURE_2D, r.targets[0]);
      g.ActiveTexture(GL_TEXTURE1);
      g.BindTexture(GL_TEXTURE_2D, r.targets[1]);
      g.ActiveTexture(GL_TEXTURE3);
      g.BindTexture(GL_TEXTURE_2D_ARRAY, mapArray_);
      for (auto [index, buffer] : {std::pair{binding::kLightReals, records.lightReals}, {binding::kLightWords, records.lightWords},
                                     {binding::kTileOffsets, p.offsets}, {binding::kTileLights, p.lists}, {binding::kViewReals, records.viewReals},
                                     {binding::kViewWords, records.viewWords}, {binding::kDagNodes, r.dagNodes},
                                     {binding::kDagLeaves, r.dagLeaves}, {binding::kVisibility, p.visibility}})
        g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, index, buffer);
      g.DispatchCompute(f.lists.tilesX, f.lists.tilesY, 1);
      g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
    });
    gl::checkError(*r.context, "looking up the shadow maps");
    f.visibility.resize(size_t(f.lists.offsets.back()) * 64);
    gl::readStorageBuffer(*r.context, p.visibility, f.visibility.data(), f.visibility.size() * 4);
  }

  // A depth texture array of at least `layers` layers of size x size.
  void ensureMapArray(const gl::Context& c, uint32_t size, uint32_t layers) {
    const gl::Functions& g = c.gl();
    if (mapArray_ && mapSize_ == size && mapLayers_ >= layers) return;
    if (mapArray_) g.DeleteTextures(1, &mapArray_);
    if (!mapFramebuffer_) g.GenFramebuffers(1, &mapFramebuffer_);
    g.GenTextures(1, &mapArray_);
    g.BindTexture(GL_TEXTURE_2D_ARRAY, mapArray_);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    g.TexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    g.TexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_DEPTH_COMPONENT32F, GLsizei(size), GLsizei(size), GLsizei(std::max(1u, layers)),
                 0, GL_DEPTH_COMPONENT, GL_FLOAT, nullptr);
    gl::checkError(c, "allocating " + std::to_string(layers) + " shadow maps of " + std::to_string(size) + "^2");
    mapSize_ = size;
    mapLayers_ = std::max(1u, layers);
  }

  const bool clustered_;
  GLuint depthProgram_ = 0, lookupProgram_ = 0;
  std::unique_ptr<CasterGrid> grid_;
  uint32_t clusterCount_ = 0, clusterSize_ = 0;
  LightClusters clusters_;
  std::vector<std::vector<LightView>> clusterViews_;
  GLuint mapArray_ = 0, mapFramebuffer_ = 0;
  uint32_t mapSize_ = 0, mapLayers_ = 0;
};

}  // namespace

std::unique_ptr<ShadowPass> makeShadowMapShadows(RendererResources& resources, bool clustered) {
  return std::make_unique<ShadowMapShadows>(resources, clustered);
}

}  // namespace cpvs
