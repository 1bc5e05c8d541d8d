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
    lookupProgram_ = linkMapLookupProgram(c, r.lights.size());
    bvh_ = buildSceneBvh(r.casterTriangles, r.castingTrianglesOfInstance);
    nodes_ = gl::createStorageBuffer(c, bvh_.nodes.data(), bvh_.nodes.size() * sizeof(SceneBvhNode));
    leafTriangles_ = gl::createStorageBuffer(c, bvh_.triangles.data(), bvh_.triangles.size() * 4);
    r.requireStorage(size_t(r.vertexCount) * kVertexFloats * 4, "the scene's vertices for ManyPSMs' splats");
    c.gl().GenVertexArrays(1, &noAttributes_);
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
  // A frame's GPU lists: the views, the level-0 items (root, view), the counters, two item lists used in turn
  // by the levels, the emitted triangles and points, and the indirect arguments.
  struct TraversalBuffers {
    explicit TraversalBuffers(const gl::Context& c) : owned(c) {}
    FrameBuffers owned;
    GLuint views = 0, counters = 0, viewCounters = 0, items[2] = {0, 0}, triangles = 0, points = 0, indirect = 0;
    uint32_t levels = 0, itemCapacity = 0, drawsAt = 0;  // drawsAt: the draws' arguments, in words
    std::vector<uint32_t> counts;  // as uploaded: [0] triangles, [1] points, [2 + level] items
  };

  // One traversal and the splats; false (and capacities grown) when a list overflowed.
  bool drawAtlas(ShadowPassFrame& p, const ManyPsmPlan& plan) {
    TraversalBuffers b(*p.resources.context);
    upload(p.resources, plan, b);
    const uint32_t dispatches = traverse(p, b);
    uint64_t fragments[2] = {0, 0};
    splat(p, plan, b.indirect, b.drawsAt, fragments);
    const gl::Context& c = *p.resources.context;
    gl::readStorageBuffer(c, b.counters, b.counts.data(), b.counts.size() * 4);
    if (grewForOverflow(p.resources, b)) return false;
    report(p, plan, b, dispatches, fragments);
    return true;
  }

  void upload(RendererResources& r, const ManyPsmPlan& plan, TraversalBuffers& b) {
    const gl::Context& c = *r.context;
    const gl::Functions& g = c.gl();
    std::vector<GpuPsmView> gpuViews;
    std::vector<glm::uvec2> roots;
    for (uint32_t v = 0; v < plan.views.size(); ++v) {
      const AtlasView& av = plan.views[v];
      const ViewMapping vm(av.mapView);
      gpuViews.push_back({glm::mat4(av.mapView.viewFromWorld),
                          {float(av.mapView.xMin), float(av.mapView.yMin), float(av.mapView.xMax - av.mapView.xMin),
                           float(av.mapView.yMax - av.mapView.yMin)},
                          {vm.orthographic ? 1.0f : 0.0f, vm.linear ? 1.0f : 0.0f, float(vm.near), float(vm.sScale)},
                          {av.layer, av.x, av.y, av.mapView.resolution}});
      if (!av.mapView.empty && !bvh_.nodes.empty()) roots.push_back({0u, v});
    }
    b.levels = std::max(1u, bvh_.levels);
    b.itemCapacity = std::max<uint32_t>(capacity_.items, uint32_t(roots.size()));
    b.counts.assign(2 + b.levels + 1, 0);
    b.counts[2] = uint32_t(roots.size());
    b.drawsAt = 3 * b.levels;
    const auto buffer = [&](const void* data, size_t bytes) { return b.owned.add(gl::createStorageBuffer(c, data, bytes)); };
    b.views = buffer(gpuViews.data(), gpuViews.size() * sizeof(GpuPsmView));
    b.counters = buffer(b.counts.data(), b.counts.size() * 4);
    b.viewCounters = buffer(nullptr, plan.views.size() * 2 * 4);
    b.items[0] = buffer(nullptr, size_t(b.itemCapacity) * 8);
    b.items[1] = buffer(nullptr, size_t(b.itemCapacity) * 8);
    g.BindBuffer(GL_SHADER_STORAGE_BUFFER, b.items[0]);
    g.BufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(roots.size() * 8), roots.data());
    b.triangles = buffer(nullptr, size_t(capacity_.triangles) * 8);
    b.points = buffer(nullptr, size_t(capacity_.points) * 8);
    b.indirect = buffer(nullptr, (size_t(b.drawsAt) + 8) * 4);
    for (auto [index, name] : {std::pair{binding::kPsmNodes, nodes_}, {binding::kPsmViews, b.views},
                               {binding::kPsmCounters, b.counters}, {binding::kPsmTriangles, b.triangles},
                               {binding::kPsmPoints, b.points}, {binding::kPsmLeafTriangles, leafTriangles_},
                               {binding::kPsmViewCounters, b.viewCounters}, {binding::kPsmIndirect, b.indirect},
                               {binding::kPsmVertices, r.vertexBuffer}})
      g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, index, name);
  }

  // The levels, each sized on the GPU by the one before; then the draws' sizes. Returns the dispatches.
  uint32_t traverse(ShadowPassFrame& p, const TraversalBuffers& b) {
    const gl::Functions& g = p.resources.gl();
    const auto capacities = [&](GLuint program) {
      g.Uniform1ui(g.GetUniformLocation(program, "itemCapacity"), b.itemCapacity);
      g.Uniform1ui(g.GetUniformLocation(program, "triangleCapacity"), capacity_.triangles);
      g.Uniform1ui(g.GetUniformLocation(program, "pointCapacity"), capacity_.points);
    };
    uint32_t dispatches = 0;
    p.timed("traversal", [&] {
      g.BindBuffer(GL_DISPATCH_INDIRECT_BUFFER, b.indirect);
      for (uint32_t level = 0; level < b.levels; ++level) {
        g.UseProgram(dispatchArgsProgram_);
        capacities(dispatchArgsProgram_);
        g.Uniform1ui(g.GetUniformLocation(dispatchArgsProgram_, "level"), level);
        g.DispatchCompute(1, 1, 1);
        g.MemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
        g.UseProgram(traverseProgram_);
        capacities(traverseProgram_);
        g.Uniform1ui(g.GetUniformLocation(traverseProgram_, "level"), level);
        g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kPsmItemsIn, b.items[level % 2]);
        g.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding::kPsmItemsOut, b.items[(level + 1) % 2]);
        g.DispatchComputeIndirect(GLintptr(3 * level * 4));
        g.MemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
        dispatches += 2;
      }
      g.UseProgram(drawArgsProgram_);
      capacities(drawArgsProgram_);
      g.Uniform1ui(g.GetUniformLocation(drawArgsProgram_, "drawsAt"), b.drawsAt);
      g.DispatchCompute(1, 1, 1);
      g.MemoryBarrier(GL_COMMAND_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
      ++dispatches;
    });
    gl::checkError(*p.resources.context, "traversing the scene tree");
    return dispatches;
  }

  // Whether a list overflowed; if so, room for twice what it counted.
  bool grewForOverflow(RendererResources& r, const TraversalBuffers& b) {
    const std::vector<uint32_t>& n = b.counts;
    uint32_t mostItems = 0;
    for (uint32_t level = 0; level < b.levels; ++level) mostItems = std::max(mostItems, n[2 + level + 1]);
    if (mostItems <= b.itemCapacity && n[0] <= capacity_.triangles && n[1] <= capacity_.points) return false;
    capacity_.items = std::max(capacity_.items, std::bit_ceil(mostItems + 1) * 2);
    capacity_.triangles = std::max(capacity_.triangles, std::bit_ceil(n[0] + 1) * 2);
    capacity_.points = std::max(capacity_.points, std::bit_ceil(n[1] + 1) * 2);
    r.requireStorage(std::max({size_t(capacity_.items), size_t(capacity_.triangles), size_t(capacity_.points)}) * 8,
                     "ManyPSMs' item lists");
    return true;
  }

  // The frame's maps and work counters (and, for tests, every splatted node's box).
  void report(ShadowPassFrame& p, const ManyPsmPlan& plan, const TraversalBuffers& b, uint32_t dispatches,
              const uint64_t fragments[2]) {
    RendererResources& r = p.resources;
    const gl::Context& c = *r.context;
    const size_t views = plan.views.size();
    std::vector<uint32_t> perView(views * 2);
    gl::readStorageBuffer(c, b.viewCounters, perView.data(), perView.size() * 4);
    ShadowMapFrame& out = p.frame.shadowMaps;
    out = ShadowMapFrame{};
    out.size = plan.layerSize;
    out.atlasLayers = plan.layers;
    out.trianglesPerLight.assign(r.lights.size(), 0);
    for (size_t v = 0; v < views; ++v) {
      const AtlasView& av = plan.views[v];
      out.shadowLight.push_back(av.light);
      out.views.push_back(av.mapView);
      out.atlasPlaces.push_back({av.layer, av.x, av.y});
      out.triangles.push_back(perView[2 * v]);
      out.pointsPerMap.push_back(perView[2 * v + 1]);
      out.trianglesPerLight[av.light] += perView[2 * v];
    }
    for (uint32_t level = 0; level < b.levels; ++level) out.nodesVisited += b.counts[2 + level];  // items processed
    out.points = b.counts[1];
    out.fragments = {fragments[0], fragments[1]};
    out.texelsCleared = uint64_t(plan.layers) * plan.layerSize * plan.layerSize;
    out.drawCalls = 2;
    out.dispatches = dispatches;
    out.bytes = out.texelsCleared * 4 + bvh_.bytes() + (uint64_t(b.itemCapacity) * 2 + capacity_.triangles + capacity_.points) * 8;
    if (p.settings.shadowMaps.keepMaps && b.counts[1] > 0) {
      std::vector<glm::uvec2> splatted(b.counts[1]);
      gl::readStorageBuffer(c, b.points, splatted.data(), splatted.size() * 8);
      for (const glm::uvec2& item : splatted) {
        out.pointBoxes.emplace_back(bvh_.nodes[item.x].lo, bvh_.nodes[item.x].hi);
        out.pointMaps.push_back(item.y);
      }
    }
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
      g.BindVertexArray(noAttributes_);  // the splats pull their vertices (more than the vertex array holds)
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

  GLuint traverseProgram_ = 0, dispatchArgsProgram_ = 0, drawArgsProgram_ = 0, triangleProgram_ = 0, pointProgram_ = 0;
  MapLookupProgram lookupProgram_;
  SceneBvh bvh_;
  GLuint nodes_ = 0, leafTriangles_ = 0, noAttributes_ = 0;
  Capacities capacity_;
  ShadowMapArray maps_;
};

}  // namespace

std::unique_ptr<ShadowPass> makeManyPsmShadows(RendererResources& resources) {
  return std::make_unique<ManyPsmShadows>(resources);
}

}  // namespace cpvs
