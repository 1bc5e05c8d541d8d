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
#include "libcpvs/preview/shadow_map_array.h"
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
    depthProgram_ = gl::linkProgram(
        c, {{GL_VERTEX_SHADER, version + glsl::shadow_map_clip_glsl + glsl::shadow_map_depth_vert},
            {GL_FRAGMENT_SHADER, version + kMaskTexelGlsl + glsl::coverage_mask_glsl + glsl::shadow_map_depth_frag}},
        "shadow-map depth");
    lookupProgram_ = linkMapLookupProgram(c, r.lights.size());
  }

  bool run(ShadowPassFrame& p) override {
    const ShadowMapSettings& maps = p.settings.shadowMaps;
    if (maps.size < 8 || maps.size > 8192)
      throw Error(ErrorCategory::InvalidArgument, "shadow map size " + std::to_string(maps.size) + " is not in 8..8192");
    const ShadowMapPlan plan = planFrame(p);
    FrameBuffers buffers(*p.resources.context);
    std::vector<size_t> firstIndex;
    const MapRecordBuffers records = upload(p, plan, buffers, firstIndex);
    drawMaps(p, plan, firstIndex);
    if (maps.keepMaps) {
      std::vector<MapPlace> places;
      for (uint32_t layer = 0; layer < plan.views.size(); ++layer) places.push_back({layer, 0, 0, maps.size});
      p.frame.shadowMaps.texels = maps_.read(*p.resources.context, places);
    }
    lookUpMaps(p, lookupProgram_, maps_, records);
    return true;
  }

private:

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
  MapRecordBuffers upload(ShadowPassFrame& p, const ShadowMapPlan& plan, FrameBuffers& buffers, std::vector<size_t>& firstIndex) {
    RendererResources& r = p.resources;
    const gl::Context& c = *r.context;
    const gl::Functions& g = c.gl();
    const uint32_t m = p.settings.shadowMaps.size, layers = uint32_t(plan.views.size());
    const MapRecordBuffers out = uploadMapRecords(c, plan.records, buffers);
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
    maps_.ensure(c, m, layers);
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
      g.BindFramebuffer(GL_FRAMEBUFFER, maps_.framebuffer());
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
        g.FramebufferTextureLayer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, maps_.texture(), 0, GLint(layer));
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

  const bool clustered_;
  GLuint depthProgram_ = 0;
  MapLookupProgram lookupProgram_;
  std::unique_ptr<CasterGrid> grid_;
  uint32_t clusterCount_ = 0, clusterSize_ = 0;
  LightClusters clusters_;
  std::vector<std::vector<LightView>> clusterViews_;
  ShadowMapArray maps_;
};

}  // namespace

std::unique_ptr<ShadowPass> makeShadowMapShadows(RendererResources& resources, bool clustered) {
  return std::make_unique<ShadowMapShadows>(resources, clustered);
}

}  // namespace cpvs
