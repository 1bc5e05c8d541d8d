#include "libcpvs/dag/shadow_dag.h"

#include <bit>

namespace cpvs {

uint32_t DagView::levels() const { return resolution >= 8 ? uint32_t(std::countr_zero(resolution)) - 2 : 0; }

bool DagView::shadowed(uint32_t x, uint32_t y, uint32_t z) const {
  uint32_t code = uint32_t(rootCode);
  uint32_t offset = 0;
  for (uint32_t half = resolution >> 1; half >= 8; half >>= 1) {
    if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
    const unsigned c = ((z & half) ? 4u : 0u) | ((y & half) ? 2u : 0u) | ((x & half) ? 1u : 0u);
    const uint32_t header = nodes[offset];
    code = childCodeOf(header, c);
    if (code == uint32_t(ChildCode::Ref)) offset = nodes[offset + 1 + refSlot(header, c)];
  }
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const unsigned c = z & 7u;
  const uint32_t header = nodes[offset];
  code = childCodeOf(header, c);
  if (code != uint32_t(ChildCode::Ref)) return code == uint32_t(ChildCode::Shadowed);
  const uint64_t mask = leaves[nodes[offset + 1 + refSlot(header, c)]];
  return (mask >> ((y & 7u) * 8u + (x & 7u))) & 1u;
}

}  // namespace cpvs
