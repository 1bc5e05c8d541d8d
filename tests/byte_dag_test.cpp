// The byte-form walk (libcpvs/runtime/byte_dag.h): a 2.x view read in place through it, and the views of a pool
// laid out by NodePool (both leaf shapes, with and without hot tables), answer every voxel and every 8x8 tile
// mask as DagView does.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "libcpvs/base/error.h"
#include "libcpvs/dag/node_pool.h"
#include "libcpvs/runtime/byte_dag.h"
#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/runtime/dag_walk.glsl.h"
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

// DagView's 8x8 tile mask at slice z, from the runtime's own tile walk (the GPU walk's C++ twin).
uint64_t tileMaskOf(const DagView& dag, uint32_t x, uint32_t y, uint32_t z) {
  const gpu::uvec2 m = gpu::DagWalk{dag}.cpvsTileMask(x, y, z);
  return uint64_t(m.x) | uint64_t(m.y) << 32;
}

struct Golden {
  std::vector<std::shared_ptr<const CpvsFile>> files;
  std::vector<DagView> dags;
  ShadowDag wide = test::wideReferenceDag();  // two-unit references
};
Golden golden() {
  Golden g;
  for (const char* path : {"formats/cpvs/golden/tiny_v2.cpvs", "tests/golden/tiny_scene_bake64_v2.cpvs",
                           "tests/golden/alpha_test_bake128_v2.cpvs", "formats/cpvs/golden/tiny_v1.cpvs"}) {
    g.files.push_back(orThrow(CpvsFile::open(test::sourcePath(path))));
    for (const auto& light : g.files.back()->lights())
      for (const auto& view : light.views) g.dags.push_back(view.dag);
  }
  g.dags.push_back(g.wide.view());
  return g;
}

size_t mismatches(const ByteDagView& bytes, const DagView& dag) {
  size_t wrong = 0;
  for (uint32_t z = 0; z < dag.resolution; ++z)
    for (uint32_t y = 0; y < dag.resolution; ++y)
      for (uint32_t x = 0; x < dag.resolution; ++x) {
        wrong += bytes.shadowed(x, y, z) != dag.shadowed(x, y, z);
        if ((x & 7u) == 0 && (y & 7u) == 0) wrong += bytes.tileMask(x, y, z) != tileMaskOf(dag, x, y, z);
      }
  return wrong;
}

TEST(ByteDag, A2xViewReadInPlaceAnswersAsDagView) {
  const Golden g = golden();
  for (size_t v = 0; v < g.dags.size(); ++v) {
    const ByteDagView bytes = ByteDagView::inPlace(g.dags[v]);
    EXPECT_EQ(static_cast<const void*>(bytes.bytes.data()), static_cast<const void*>(g.dags[v].nodes.data()));
    EXPECT_EQ(mismatches(bytes, g.dags[v]), 0u) << "view " << v;
  }
}

TEST(ByteDag, PooledViewsAnswerAsTheirDagViews) {
  const Golden g = golden();
  for (const LeafShape shape : {LeafShape::Slices, LeafShape::Octants}) {
    NodePool pool(shape);
    for (const DagView& dag : g.dags) pool.add(dag);
    for (const bool hot : {false, true}) {
      const PooledDags pooled = concatenate(pool.layOut(hot), shape);
      ASSERT_EQ(pooled.views.size(), g.dags.size());
      for (size_t v = 0; v < g.dags.size(); ++v)
        EXPECT_EQ(mismatches(pooled.views[v], g.dags[v]), 0u)
            << "view " << v << (shape == LeafShape::Octants ? ", octants" : ", slices") << (hot ? ", hot tables" : "");
    }
  }
}

}  // namespace
}  // namespace cpvs
