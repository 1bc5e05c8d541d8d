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
#include "support/test_dags.h"
#include "support/test_support.h"

namespace cpvs {
namespace {

// DagView's 8x8 tile mask at slice z: the leaf, or all ones / zeros where a homogeneous node covers the tile.
uint64_t tileMaskOf(const DagView& dag, uint32_t x, uint32_t y, uint32_t z) {
  uint32_t code = uint32_t(dag.rootCode), offset = 0;
  for (uint32_t half = dag.resolution >> 1; half >= 8 && code == uint32_t(ChildCode::Ref); half >>= 1) {
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = dag.nodes[offset];
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) offset = dag.child(offset, header, c, half * 2);
  }
  if (code != uint32_t(ChildCode::Ref)) return 0 - uint64_t(code == uint32_t(ChildCode::Shadowed));
  const uint32_t header = dag.nodes[offset];
  code = childCodeOf(header, z & 7u);
  return code == uint32_t(ChildCode::Ref) ? dag.leaves[dag.child(offset, header, z & 7u, 8)] : 0 - uint64_t(code);
}

struct Golden {
  std::vector<std::shared_ptr<const CpvsFile>> files;
  std::vector<DagView> dags;
  ShadowDag wide = test::wideReferenceDag();  // two-unit references
};
Golden golden() {
  Golden g;
  for (const char* name : {"tiny_v2.cpvs", "tiny_scene_bake64_v2.cpvs", "alpha_test_bake128_v2.cpvs", "tiny_v1.cpvs"}) {
    g.files.push_back(orThrow(CpvsFile::open(test::sourcePath(std::string("tests/golden/") + name))));
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
