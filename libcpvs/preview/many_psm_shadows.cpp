// --shadows manypsm: ManyPSMs ("Many Perfect Shadow Maps", docs/references.md), the fourth per-frame technique
// of the culling demo (docs/culling-demo.md). Every frame: plan the listed lights' views, each at a resolution
// by its light's distance to the camera, packed into an atlas (CPU, "plan"); traverse the scene tree for all
// views at once, one level per compute dispatch over a list of (node, view) items ("traversal"); splat every
// emitted triangle in one draw and every emitted point in a second ("shadow_maps"); look the atlas up with the
// rule every map mode uses ("shadows"). Point splats make it approximate; where no node is splatted its maps
// are the per-light maps texel for texel (tests/culling_test.cpp).
#include <algorithm>
#include <bit>

#include "libcpvs/base/error.h"
#include "libcpvs/base/stopwatch.h"
#include "libcpvs/eval/shadow_map.h"
#include "libcpvs/gl/gl_program.h"
#include "libcpvs/preview/glsl_sources.h"
#include "libcpvs/preview/many_psm_plan.h"
#include "libcpvs/preview/scene_bvh.h"
#include "libcpvs/preview/shadow_map_array.h"
#include "libcpvs/preview/shadow_pass.h"
#include "libcpvs/raster/gpu_masks.h"

namespace cpvs {

namespace {

// many_psm_views.glsl's PsmView.
struct GpuPsmView {
  glm::mat4 viewFromWorld;
  glm::vec4 lateral, depth;
  glm::uvec4 cell;
};
static_assert(sizeof(GpuPsmView) == 112);

// The GPU lists' room, grown (and the frame redone) when a traversal overflows one.
struct Capacities {
  uint32_t items = 1u << 16, triangles = 1u << 16, points = 1u << 14;
};

class ManyPsmShadows final : public ShadowPass {
public:
  explicit ManyPsmShadows(RendererResources& r) {
    const gl::Context& c = *r.context;
    const std::string version = "#version 450\n";
    const std::string views = glsl::many_psm_views_glsl;
    traverseProgram_ = gl::linkProgram(c, {{GL_COMPUTE_SHADER, version + views + glsl::many_psm_traverse_comp}},
                                       "ManyPSMs traversal");
    dispatchArgsProgram_ = gl::linkProgram(
        c, {{GL_COMPUTE_SHADER, version + "#define DISPATCH\n" + views + glsl::many_psm_prepare_comp}}, "ManyPSMs dispatch sizes");
    drawArgsProgram_ = gl::linkProgram(c, {{GL_COMPUTE_SHADER, version + views + glsl::many_psm_prepare_comp}},
                                       "ManyPSMs draw sizes");
    const std::string fragment = version + kMaskTexelGlsl + glsl::coverage_mask_glsl + glsl::shadow_map_depth_frag;
    for (bool points : {false, true}) {
      const std::string vertex = version + "#extension GL_ARB_shader_viewport_layer_array : require\n" +
                                 (points ? "#define POINTS\n" : "") + views + glsl::shadow_map_clip_glsl +
                                 glsl::many_psm_splat_vert;
      try {
        (points ? pointProgram_ : triangleProgram_) = gl::linkProgram(
            c, {{GL_VERTEX_SHADER, vertex}, {GL_FRAGMENT_SHADER, fragment}}, points ? "ManyPSMs points" : "ManyPSMs triangles");
      } catch (const Error& e) {
        throw Error(ErrorCategory::NotSupported, std::string("--shadows manypsm needs GL_ARB_shader_viewport_layer_array "
                                                             "(a layer per vertex): ") + e.what());
      }
    }
    lookupProgram_ = linkMapLookupProgram(c);
    bvh_ = buildSceneBvh(r.casterTriangles, r.castingTrianglesOfInstance);
    nodes_ = gl::createStorageBuffer(c, bvh_.nodes.data(), bvh_.nodes.size() * sizeof(SceneBvhNode));
    leafTriangles_ = gl::createStorageBuffer(c, bvh_.triangles.data(), bvh_.triangles.size() * 4);
    r.requireStorage(size_t(r.vertexCount) * kVertexFloats * 4, "the scene's vertices for ManyPSMs' splats");
  }

  bool run(ShadowPassFrame& p) override {
    const ShadowMapSettings& settings = p.settings.shadowMaps;
    if (settings.size < 8 || settings.size > 8192 || !std::has_single_bit(settings.size))
      throw Error(ErrorCategory::InvalidArgument, "manypsm: the largest map size " + std::to_string(settings.size) +
                                                      " is not a power of two in 8..8192");
    if (settings.minSize < 1 || settings.minSize > settings.size || !std::has_single_bit(settings.minSize))
      throw Error(ErrorCategory::InvalidArgument, "manypsm: the smallest map size " + std::to_string(settings.minSize) +
                                                      " is not a power of two in 1.." + std::to_string(settings.size));
    Stopwatch clock;
    const ManyPsmPlan plan = planManyPsms(p.resources.lights, p.frame, p.frame.eye, settings);
    p.frame.passes.push_back({"plan", clock.ms(), false});
    const gl::Context& c = *p.resources.context;
    FrameBuffers frameBuffers(c);
    const MapRecordBuffers records = uploadMapRecords(c, plan.records, frameBuffers);
    maps_.ensure(c, plan.layerSize, plan.layers);
    // A traversal that overflows a list is redone with room for what it counted (at most a few times: the
    // counts of a level are exact once the levels above it fit).
    for (int attempt = 0;; ++attempt) {
      const size_t passesBefore = p.frame.passes.size();
      if (drawAtlas(p, plan)) break;
      if (attempt == 8) throw Error(ErrorCategory::RuntimeFailure, "manypsm: the traversal's lists kept overflowing");
      p.frame.passes.resize(passesBefore);
    }
    if (settings.keepMaps) {
      std::vector<MapPlace> places;
      for (const AtlasView& v : plan.views) places.push_back({v.layer, v.x, v.y, v.mapView.resolution});
      p.frame.shadowMaps.texels = maps_.read(c, places);
    }
    lookUpMaps(p, lookupProgram_, maps_, records);
    p.frame.uploadedBytes += plan.records.bytes();
    return true;
  }

private:
  // One traversal and the splats; false (and capacities grown) when a list overflowed.
  bool drawAtlas(ShadowPassFrame& p, const ManyPsmPlan& plan) {
    RendererResources& r = p.resources;
    const gl::Context& c = *r.context;
    const gl::Functions& g = c.gl();
    const uint32_t views = uint32_t(plan.views.size()), levels = std::max(1u, bvh_.levels);
    std::vector<GpuPsmView> gpuViews;
    std::vector<glm::uvec2> roots;
    for (uint32_t v = 0; v < views; ++v) {
      const AtlasView& av = plan.views[v];
      const ViewMapping vm(av.mapView);
      gpuViews.push_back({glm::mat4(av.mapView.viewFromWorld),
                          {float(av.mapView.xMin), float(av.mapView.yMin), float(av.mapView.xMax - av.mapView.xMin),
                           float(av.mapView.yMax - av.mapView.yMin)},
                          {vm.orthographic ? 1.0f : 0.0f, vm.linear ? 1.0f : 0.0f, float(vm.near), float(vm.sScale)},
                          {av.layer, av.x, av.y, av.mapView.resolution}});
      if (!av.mapView.empty && !bvh_.nodes.empty()) roots.push_back({0u, v});
    }
    const uint32_t itemCapacity = std::max<uint32_t>(capacity_.items, uint32_t(roots.size()));
    FrameBuffers buffers(c);
    std::vector<uint32_t> counters(2 + levels + 1, 0);
    counters[2] = uint32_t(roots.size());
    const GLuint viewBuffer = buffers.add(gl::createStorageBuffer(c, gpuViews.data(), gpuViews.size() * sizeof(GpuPsmView)));
    const GLuint counterBuffer = buffers.add(gl::createStorageBuffer(c, counters.data(), counters.size() * 4));
    const GLuint viewCounters = buffers.add(gl::createStorageBuffer(c, nullptr, size_t(views) * 3 * 4));
    GLuint items[2] = {buffers.add(gl::createStorageBuffer(c, nullptr, size_t(itemCapacity) * 8)),
                       buffers.add(gl::createStorageBuffer(c, nullptr, size_t(itemCapacity) * 8))};
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, items[0]);
    g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(roots.size() * 8), roots.data());
    const GLuint triangleItems = buffers.add(gl::createStorageBuffer(c, nullptr, size_t(capacity_.triangles) * 8));
    const GLuint pointItems = buffers.add(gl::createStorageBuffer(c, nullptr, size_t(capacity_.points) * 8));
    const uint32_t drawsAt = 3 * levels;
    const GLuint indirect = buffers.add(gl::createStorageBuffer(c, nullptr, (size_t(drawsAt) + 8) * 4));
    for (auto [index, buffer] : {std::pair{binding::kPsmNodes, nodes_}, {binding::kPsmViews, viewBuffer},
                                 {binding::kPsmCounters, counterBuffer}, {binding::kPsmTriangles, triangleItems},
                                 {binding::kPsmPoints, pointItems}, {binding::kPsmLeafTriangles, leafTriangles_},
                                 {binding::kPsmViewCounters, viewCounters}, {binding::kPsmIndirect, indirect},
                                 {binding::kPsmVertices, r.vertexBuffer}})
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, index, buffer);
    const auto capacities = [&](GLuint program) {
      g.Uniform1ui(g.GetUniformLocation(program, "itemCapacity"), itemCapacity);
      g.Uniform1ui(g.GetUniformLocation(program, "triangleCapacity"), capacity_.triangles);
      g.Uniform1ui(g.GetUniformLocation(program, "pointCapacity"), capacity_.points);
    };
    uint32_t dispatches = 0;
    p.timed("traversal", [&] {
      g.BindBuffer(GL_DISPATCH_INDIRECT_BUFFER, indirect);
      for (uint32_t level = 0; level < levels; ++level) {
        g.UseProgram(dispatchArgsProgram_);
        capacities(dispatchArgsProgram_);
        g.Uniform1ui(g.GetUniformLocation(dispatchArgsProgram_, "level"), level);
        g.DispatchCompute(1, 1, 1);
        g.MemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
        g.UseProgram(traverseProgram_);
        capacities(traverseProgram_);
        g.Uniform1ui(g.GetUniformLocation(traverseProgram_, "level"), level);
        g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kPsmItemsIn, items[level % 2]);
        g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kPsmItemsOut, items[(level + 1) % 2]);
        g.DispatchComputeIndirect(GLintptr(3 * level * 4));
        g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        dispatches += 2;
      }
      g.UseProgram(drawArgsProgram_);
      capacities(drawArgsProgram_);
      g.Uniform1ui(g.GetUniformLocation(drawArgsProgram_, "drawsAt"), drawsAt);
      g.DispatchCompute(1, 1, 1);
      g.MemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
      ++dispatches;
    });
    gl::checkError(c, "traversing the scene tree for " + std::to_string(views) + " views");
    uint64_t fragments[2] = {0, 0};
    splat(p, plan, indirect, drawsAt, fragments);
    // The counts, and whether every list had room.
    gl::readStorageBuffer(c, counterBuffer, counters.data(), counters.size() * 4);
    uint32_t mostItems = 0;
    for (uint32_t level = 0; level < levels; ++level) mostItems = std::max(mostItems, counters[2 + level + 1]);
    const bool fits = mostItems <= itemCapacity && counters[0] <= capacity_.triangles && counters[1] <= capacity_.points;
    if (!fits) {
      capacity_.items = std::max(capacity_.items, std::bit_ceil(mostItems + 1) * 2);
      capacity_.triangles = std::max(capacity_.triangles, std::bit_ceil(counters[0] + 1) * 2);
      capacity_.points = std::max(capacity_.points, std::bit_ceil(counters[1] + 1) * 2);
      const size_t most = std::max({size_t(capacity_.items), size_t(capacity_.triangles), size_t(capacity_.points)}) * 8;
      r.requireStorage(most, "ManyPSMs' item lists");
      return false;
    }
    std::vector<uint32_t> perView(size_t(views) * 3);
    gl::readStorageBuffer(c, viewCounters, perView.data(), perView.size() * 4);
    ShadowMapFrame& out = p.frame.shadowMaps;
    out = ShadowMapFrame{};
    out.size = plan.layerSize;
    out.atlasLayers = plan.layers;
    out.trianglesPerLight.assign(r.lights.size(), 0);
    for (uint32_t v = 0; v < views; ++v) {
      const AtlasView& av = plan.views[v];
      out.shadowLight.push_back(av.light);
      out.views.push_back(av.mapView);
      out.atlasPlaces.push_back({av.layer, av.x, av.y});
      out.nodesPerMap.push_back(perView[3 * v]);
      out.triangles.push_back(perView[3 * v + 1]);
      out.pointsPerMap.push_back(perView[3 * v + 2]);
      out.trianglesPerLight[av.light] += perView[3 * v + 1];
      out.nodesVisited += perView[3 * v];
    }
    out.points = counters[1];
    out.fragments = {fragments[0], fragments[1]};
    out.texelsCleared = uint64_t(plan.layers) * plan.layerSize * plan.layerSize;
    out.drawCalls = 2;
    out.dispatches = dispatches;
    out.bytes = uint64_t(plan.layers) * plan.layerSize * plan.layerSize * 4 + bvh_.bytes() +
                (uint64_t(itemCapacity) * 2 + capacity_.triangles + capacity_.points) * 8;
    if (p.settings.shadowMaps.keepMaps && counters[1] > 0) {
      std::vector<glm::uvec2> splatted(counters[1]);
      gl::readStorageBuffer(c, pointItems, splatted.data(), splatted.size() * 8);
      for (const glm::uvec2& item : splatted) {
        out.pointBoxes.emplace_back(bvh_.nodes[item.x].lo, bvh_.nodes[item.x].hi);
        out.pointMaps.push_back(item.y);
      }
    }
    return true;
  }

  // The atlas: every layer cleared, then one draw of every emitted triangle and one of every point.
  void splat(ShadowPassFrame& p, const ManyPsmPlan& plan, GLuint indirect, uint32_t drawsAt, uint64_t fragments[2]) {
    RendererResources& r = p.resources;
    const gl::Functions& g = r.gl();
    GLuint queries[2];
    g.GenQueries(2, queries);
    p.timed("shadow_maps", [&] {
      g.BindFramebuffer(GL_FRAMEBUFFER, maps_.framebuffer());
      g.FramebufferTexture(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, maps_.texture(), 0);
      const GLenum none = GL_NONE;
      g.DrawBuffers(1, &none);
      g.ReadBuffer(GL_NONE);
      g.Viewport(0, 0, GLsizei(plan.layerSize), GLsizei(plan.layerSize));
      g.Enable(GL_DEPTH_TEST);
      g.DepthFunc(GL_LESS);
      g.DepthMask(GL_TRUE);
      g.Disable(GL_CULL_FACE);
      const GLfloat far = float(ShadowMap16::kFar) / 65536.0f;
      g.ClearBufferfv(GL_DEPTH, 0, &far);
      for (GLenum plane = GL_CLIP_DISTANCE0; plane <= GL_CLIP_DISTANCE3; ++plane) g.Enable(plane);
      g.BindVertexArray(r.vertexArray);  // no attributes read: the splats pull their vertices
      g.BindBuffer(GL_DRAW_INDIRECT_BUFFER, indirect);
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kMaskHeaders, r.maskHeaders);
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kMaskBytes, r.maskBytes);
      for (int points = 0; points < 2; ++points) {
        const GLuint program = points ? pointProgram_ : triangleProgram_;
        g.UseProgram(program);
        g.Uniform1ui(g.GetUniformLocation(program, "layerSize"), plan.layerSize);
        g.Uniform1ui(g.GetUniformLocation(program, "vertexFloats"), kVertexFloats);
        g.BeginQuery(GL_SAMPLES_PASSED, queries[points]);
        g.DrawArraysIndirect(points ? GL_POINTS : GL_TRIANGLES, reinterpret_cast<const void*>(size_t(drawsAt + 4 * points) * 4));
        g.EndQuery(GL_SAMPLES_PASSED);
      }
      for (GLenum plane = GL_CLIP_DISTANCE0; plane <= GL_CLIP_DISTANCE3; ++plane) g.Disable(plane);
    });
    g.BindVertexArray(0);
    for (int i = 0; i < 2; ++i) {
      GLuint samples = 0;
      g.GetQueryObjectuiv(queries[i], GL_QUERY_RESULT, &samples);
      fragments[i] = samples;
    }
    g.DeleteQueries(2, queries);
    gl::checkError(*r.context, "splatting ManyPSMs' atlas");
  }

  GLuint traverseProgram_ = 0, dispatchArgsProgram_ = 0, drawArgsProgram_ = 0, triangleProgram_ = 0, pointProgram_ = 0,
         lookupProgram_ = 0;
  SceneBvh bvh_;
  GLuint nodes_ = 0, leafTriangles_ = 0;
  Capacities capacity_;
  ShadowMapArray maps_;
};

}  // namespace

std::unique_ptr<ShadowPass> makeManyPsmShadows(RendererResources& resources) {
  return std::make_unique<ManyPsmShadows>(resources);
}

}  // namespace cpvs
