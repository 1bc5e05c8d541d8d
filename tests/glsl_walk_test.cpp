// The GPU twin of the DAG walk (libcpvs/runtime/dag_walk.glsl.h): compiled as C++ it answers what
// DagView::shadowed and shadowedTexels answer; pasted into a GLSL 4.50 compute shader (OSMesa: llvmpipe here)
// it answers the same on every query. DAGs: baked (TorusKnot, sun and spot), synthetic depth maps (N = 8 puts
// a leaf parent at the root), two-unit references, and an all-shadowed root without nodes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "libcpvs/import/gltf_import.h"
#include "libcpvs/bake/bake.h"
#include "libcpvs/base/error.h"
#include "libcpvs/dag/dag_builder.h"
#include "libcpvs/gl/gl_context.h"
#include "libcpvs/runtime/dag_walk.glsl.h"
#include "libcpvs/runtime/shadow_lookup.h"
#include "libcpvs/tiles/tile_masks.h"
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

using test::wideReferenceDag;

// ---- DAGs -----------------------------------------------------------------------------------------------

struct NamedDag {
  std::string name;
  ShadowDag dag;
  bool everyVoxel = false;  // the GPU walks every voxel, not only random queries
};

// Random boxes of casters over empty texels, some thin (open), some thick (free voxels inside).
ShadowDag syntheticDag(uint32_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  auto below = [&](uint32_t m) { return uint32_t(rng() % m); };
  DepthRegion d;
  d.rect = {0, 0, n, n};
  d.resolution = n;
  d.enter.assign(size_t(n) * n, n);
  d.exit.assign(size_t(n) * n, n);
  for (int b = 0; b < 10; ++b) {
    const uint32_t x0 = below(n), y0 = below(n), w = 1 + below(n / 2), h = 1 + below(n / 2);
    const uint32_t e = below(n - 1), exit = std::min(n, e + 1 + (below(2) ? below(n - e) : 0));
    for (uint32_t y = y0; y < std::min(n, y0 + h); ++y)
      for (uint32_t x = x0; x < std::min(n, x0 + w); ++x)
        if (e < d.enter[size_t(y) * n + x]) d.enter[size_t(y) * n + x] = e, d.exit[size_t(y) * n + x] = exit;
  }
  return buildDag(buildTileChains(d, UndefinedMode::Kampe), true);
}

// The TorusKnot under a sun and a spot at N = 128 (every voxel on the GPU too; lossless and lossy) and 256 (one
// bake each per process); empty with the reason where no depth renderer is available.
const std::vector<NamedDag>& bakedDags(std::string& why) {
  static std::string failure;
  static const std::vector<NamedDag> dags = [] {
    std::vector<NamedDag> out;
    try {
      Scene scene = importGltf(test::sourcePath("data/scenes/TorusKnot/torusknot.gltf"));
      scene.lights = {test::sunLight("sun", {0.3, -1.0, 0.2}),
                      test::spotLight("spot", {5, 60, 0}, {0, -1, 0}, 0.6, 150)};
      // A lossy bake (docs/lossy.md) is an ordinary DAG: the walk reads it unchanged.
      for (const auto& [n, lossy] : {std::pair{128u, false}, std::pair{256u, false}, std::pair{128u, true}}) {
        BakeSettings settings;
        settings.resolution = n;
        settings.threads = 1;
        if (lossy) {
          settings.maxVoxelError = 4;
          settings.maxEdgeError = 2;
        }
        const CpvsContent content = bakeScene(scene, settings);
        for (const BakedLight& light : content.lights)
          for (size_t v = 0; v < light.views.size(); ++v)
            out.push_back({"TorusKnot " + light.light.name + (lossy ? " lossy" : "") + " view " + std::to_string(v),
                           light.views[v].dag, n <= 128});
      }
    } catch (const Error& e) {
      if (e.category() != ErrorCategory::NotSupported) throw;
      failure = e.what();
    }
    return out;
  }();
  why = failure;
  return dags;
}

std::vector<NamedDag> allDags(std::string& bakeFailure) {
  std::vector<NamedDag> dags;
  dags.push_back({"two-unit references", wideReferenceDag(), true});
  dags.push_back({"all shadowed, no nodes", orThrow(encodeDag(16, ChildCode::Shadowed, {}, {}, {})), true});
  dags.push_back({"synthetic N=8", syntheticDag(8, 3), true});
  dags.push_back({"synthetic N=32", syntheticDag(32, 5), true});
  dags.push_back({"synthetic N=64", syntheticDag(64, 7), true});
  for (const NamedDag& d : bakedDags(bakeFailure)) dags.push_back(d);
  // An empty baked view has resolution 0: nothing to walk.
  std::erase_if(dags, [](const NamedDag& d) { return d.dag.resolution < 8; });
  return dags;
}

// ---- queries --------------------------------------------------------------------------------------------

// (x, y, z, K): K = 0 asks cpvsShadowed, K >= 1 cpvsShadowedTexels. As the shader reads them (ivec4).
struct Query {
  int32_t x, y, z, k;
};

std::vector<Query> queriesFor(const NamedDag& d, uint32_t seed) {
  const int32_t n = int32_t(d.dag.resolution);
  std::vector<Query> q;
  if (d.everyVoxel)
    for (int32_t z = 0; z < n; ++z)
      for (int32_t y = 0; y < n; ++y)
        for (int32_t x = 0; x < n; ++x) q.push_back({x, y, z, 0});
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int32_t> coord(-6, n + 5), inside(0, n - 1);
  // Footprints clipped by the grid's borders and crossing tile borders, whatever the resolution.
  const int32_t edges[] = {-5, -4, -1, 0, 1, 3, 4, 7, 8, 9, n / 2 - 1, n / 2, n - 9, n - 8, n - 5, n - 1, n, n + 4};
  for (int k : {0, 1, 3, 5, 7, 9, 15}) {
    for (int i = 0; i < 2000; ++i) {
      Query r{coord(rng), coord(rng), inside(rng), k};
      if (i % 4 == 1) r.x = edges[rng() % std::size(edges)];
      if (i % 4 == 2) r.y = edges[rng() % std::size(edges)];
      if (k == 0) r.x = std::clamp(r.x, 0, n - 1), r.y = std::clamp(r.y, 0, n - 1);  // voxels must be inside
      q.push_back(r);
    }
  }
  return q;
}

// The runtime's answer.
uint32_t expected(const DagView& view, const Query& q) {
  if (q.k == 0) return view.shadowed(uint32_t(q.x), uint32_t(q.y), uint32_t(q.z)) ? 1 : 0;
  return shadowedTexels(view, q.x, q.y, uint32_t(q.z), q.k);
}

std::string describe(const NamedDag& d, const Query& q) {
  return d.name + " (N=" + std::to_string(d.dag.resolution) + ") at " + std::to_string(q.x) + "," +
         std::to_string(q.y) + "," + std::to_string(q.z) + " K=" + std::to_string(q.k);
}

// ---- the C++ twin ---------------------------------------------------------------------------------------

TEST(GlslWalk, CppTwinEqualsTheRuntimeWalk) {
  std::string bakeFailure;
  const std::vector<NamedDag> dags = allDags(bakeFailure);
  size_t checked = 0;
  for (const NamedDag& d : dags) {
    const DagView view = d.dag.view();
    const gpu::DagWalk walk{view};
    const uint32_t n = view.resolution;
    size_t shadowed = 0;
    for (uint32_t z = 0; z < n; ++z)  // every voxel of every DAG
      for (uint32_t y = 0; y < n; ++y)
        for (uint32_t x = 0; x < n; ++x, ++checked) {
          const bool s = view.shadowed(x, y, z);
          ASSERT_EQ(walk.cpvsShadowed(x, y, z), s) << describe(d, {int(x), int(y), int(z), 0});
          shadowed += s;
        }
    std::printf("[ dag      ] %s: N=%u, %zu units, %zu leaves, %.1f%% shadowed\n", d.name.c_str(), n,
                d.dag.nodes.size(), d.dag.leaves.size(), 100.0 * double(shadowed) / (double(n) * n * n));
    for (const Query& q : queriesFor(d, 11)) {
      const uint32_t twin = q.k == 0 ? (walk.cpvsShadowed(uint32_t(q.x), uint32_t(q.y), uint32_t(q.z)) ? 1u : 0u)
                                     : walk.cpvsShadowedTexels(q.x, q.y, uint32_t(q.z), q.k);
      ASSERT_EQ(twin, expected(view, q)) << describe(d, q);
      ++checked;
    }
  }
  std::printf("[ checked  ] %zu C++ walks over %zu DAGs\n", checked, dags.size());
  if (!bakeFailure.empty()) std::printf("[ no bake  ] baked DAGs left out: %s\n", bakeFailure.c_str());
}

// ---- the GLSL twin --------------------------------------------------------------------------------------

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// What the header's GLSL text needs before it (the accessors over SSBOs), and the shader's main after it.
// #line gives the header's own line numbers in the compiler's log (source string 1).
const char* const kPrelude = R"(#version 450
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Nodes { uint nodes[]; };      // u16 units, two per uint
layout(std430, binding = 1) readonly buffer Leaves { uvec2 leaves[]; };   // (low, high) 32 bits
layout(std430, binding = 2) readonly buffer Params { uint resolution; uint rootCode; uint childBase[32]; };
layout(std430, binding = 3) readonly buffer Queries { ivec4 queries[]; }; // (x, y, z, K), K = 0: voxel
layout(std430, binding = 4) writeonly buffer Answers { uint answers[]; };
uint cpvsNodeUnit(uint i) { return (nodes[i >> 1u] >> ((i & 1u) * 16u)) & 0xFFFFu; }
uvec2 cpvsLeaf(uint i) { return leaves[i]; }
uint cpvsResolution() { return resolution; }
uint cpvsRootCode() { return rootCode; }
uint cpvsChildBase(uint log2Edge) { return childBase[log2Edge]; }
#line 1 1
)";
const char* const kMain = R"(
#line 1 2
void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= uint(queries.length())) return;
  ivec4 q = queries[i];
  answers[i] = q.w == 0 ? (cpvsShadowed(uint(q.x), uint(q.y), uint(q.z)) ? 1u : 0u)
                        : cpvsShadowedTexels(q.x, q.y, uint(q.z), q.w);
}
)";
constexpr uint32_t kLocalSize = 64;

// One context and program per process, never destroyed (Mesa tears its state down in its own exit handlers).
struct Gpu {
  std::unique_ptr<gl::Context> context;
  GLuint program = 0;
  std::string unavailable;  // why there is no context: the test is skipped
  std::string failure;      // why the shader did not build: the test fails
};

Gpu& gpu() {
  static Gpu& g = *[] {
    auto* g = new Gpu;
    try {
      g->context = gl::createOSMesaContext();
    } catch (const Error& e) {
      if (e.category() != ErrorCategory::NotSupported) throw;
      g->unavailable = e.what();
      return g;
    }
    const gl::Functions& f = g->context->gl();
    if (g->context->majorVersion() * 10 + g->context->minorVersion() < 43 || !f.DispatchCompute || !f.MemoryBarrier) {
      g->unavailable = "no compute shaders in " + g->context->description();
      return g;
    }
    std::printf("[ context  ] %s\n", g->context->description().c_str());
    const std::string source =
        kPrelude + readText(std::string(CPVS_SOURCE_DIR) + "/libcpvs/runtime/dag_walk.glsl.h") + kMain;
    gl::CurrentContext current(*g->context);
    const GLuint shader = f.CreateShader(GL_COMPUTE_SHADER);
    const char* text = source.c_str();
    f.ShaderSource(shader, 1, &text, nullptr);
    f.CompileShader(shader);
    GLint ok = 0;
    char log[8192] = {};
    f.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    f.GetShaderInfoLog(shader, sizeof log, nullptr, log);
    if (!ok) {
      g->failure = std::string("compute shader does not compile (1:line = the header's line):\n") + log;
      f.DeleteShader(shader);
      return g;
    }
    if (log[0]) std::printf("[ compiler ] %s\n", log);
    g->program = f.CreateProgram();
    f.AttachShader(g->program, shader);
    f.LinkProgram(g->program);
    f.DeleteShader(shader);
    f.GetProgramiv(g->program, GL_LINK_STATUS, &ok);
    if (!ok) {
      f.GetProgramInfoLog(g->program, sizeof log, nullptr, log);
      g->failure = std::string("compute program does not link:\n") + log;
    }
    return g;
  }();
  return g;
}

// A shader storage buffer holding `bytes` at `binding`, zero-padded to whole 16-byte blocks (GL has no empty
// buffers, and an odd count of u16 units would leave the last uint partly outside the buffer).
GLuint storageBuffer(const gl::Functions& f, GLuint binding, const void* data, size_t bytes) {
  GLuint buffer = 0;
  f.GenBuffers(1, &buffer);
  f.BindBuffer(GL_SHADER_STORAGE_BUFFER, buffer);
  std::vector<unsigned char> padded(std::max<size_t>((bytes + 15) / 16 * 16, 16), 0);
  if (data && bytes) std::memcpy(padded.data(), data, bytes);
  f.BufferData(GL_SHADER_STORAGE_BUFFER, GLsizeiptr(padded.size()), padded.data(), GL_STATIC_DRAW);
  f.BindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, buffer);
  return buffer;
}

// The shader's answers to `queries` over one DAG.
std::vector<uint32_t> runOnGpu(Gpu& g, const DagView& view, const std::vector<Query>& queries) {
  const gl::Functions& f = g.context->gl();
  gl::CurrentContext current(*g.context);
  f.UseProgram(g.program);
  uint32_t params[2 + kMaxDagLevels] = {view.resolution, uint32_t(view.rootCode)};
  std::copy(std::begin(view.childBase), std::end(view.childBase), params + 2);
  // Little-endian: u16 unit 2i is the low half of uint i, a u64 leaf its (low, high) uvec2.
  const GLuint buffers[] = {
      storageBuffer(f, 0, view.nodes.data(), view.nodes.size_bytes()),
      storageBuffer(f, 1, view.leaves.data(), view.leaves.size_bytes()),
      storageBuffer(f, 2, params, sizeof params),
      storageBuffer(f, 3, queries.data(), queries.size() * sizeof(Query)),  // queries.length(): exact
      storageBuffer(f, 4, nullptr, queries.size() * sizeof(uint32_t)),
  };
  f.DispatchCompute(GLuint((queries.size() + kLocalSize - 1) / kLocalSize), 1, 1);
  f.MemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<uint32_t> answers(queries.size());
  f.BindBuffer(GL_SHADER_STORAGE_BUFFER, buffers[4]);
  f.GetBufferSubData(GL_SHADER_STORAGE_BUFFER, 0, GLsizeiptr(answers.size() * sizeof(uint32_t)), answers.data());
  const GLenum error = f.GetError();
  f.DeleteBuffers(GLsizei(std::size(buffers)), buffers);
  f.UseProgram(0);
  if (error != GL_NO_ERROR) throw std::runtime_error("GL error " + std::to_string(error) + " in the dispatch");
  return answers;
}

TEST(GlslWalk, ComputeShaderEqualsTheRuntimeWalk) {
  Gpu& g = gpu();
  if (!g.unavailable.empty()) GTEST_SKIP() << "no GL 4.3+ context here: " << g.unavailable;
  ASSERT_TRUE(g.failure.empty()) << g.failure;
  std::string bakeFailure;
  const std::vector<NamedDag> dags = allDags(bakeFailure);
  size_t checked = 0;
  for (const NamedDag& d : dags) {
    const DagView view = d.dag.view();
    const std::vector<Query> queries = queriesFor(d, 23);
    ASSERT_LE(queries.size(), size_t(65535) * kLocalSize);  // one dispatch's groups
    const std::vector<uint32_t> answers = runOnGpu(g, view, queries);
    size_t wrong = 0;
    for (size_t i = 0; i < queries.size(); ++i) {
      const uint32_t want = expected(view, queries[i]);
      if (answers[i] != want && ++wrong <= 5)
        ADD_FAILURE() << describe(d, queries[i]) << ": GPU " << answers[i] << ", runtime " << want;
    }
    ASSERT_EQ(wrong, 0u) << "of " << queries.size() << " queries on " << d.name;
    checked += queries.size();
  }
  std::printf("[ checked  ] %zu GPU queries over %zu DAGs\n", checked, dags.size());
  if (!bakeFailure.empty()) std::printf("[ no bake  ] baked DAGs left out: %s\n", bakeFailure.c_str());
}

}  // namespace
}  // namespace cpvs
