// The passes of the vector DAG walks (dag_walks.h), written once over a lane type: dag_walks_avx2.cpp (eight
// lanes) and dag_walks_avx512.cpp (sixteen) include this inside their own anonymous namespace and target region,
// after defining what it uses, so each compiles its own copy for its instruction set:
//
//   V, M                          a vector of 32-bit lanes and a lane mask; kLanes, how many lanes
//   splat, &, |, +, -, <<, shr, shl, equal, blend, andNot (M a and not b), laneMask(lanes), lanesSet(M),
//   load(const uint32_t*, M), compress(uint32_t*, M, V) (the lanes of M packed to the front, a whole vector
//   stored: up to kLanes - 1 slots past the last kept lane written)
//   Units                         pair(M, V unit): the unit at each index and the next, in one 32-bit read
//   isReference(M, V raw)         the lanes of M whose 2-bit child code `raw` is a reference (2 or 3)
//   Results<kKind>                homogeneous(M ending, size_t lanes, V out, V code) and
//                                 leaf(leaves, M, size_t lanes, V out, V leaf, V x, V y): the walks' results
//
// No include guard on purpose: it is meant to be included once per file, inside that file's namespace.

// Bits set in each lane's low 16 bits (the scalar popcount32 of a 16-bit value).
inline V popcount16(V v) {
  v = v - (shr(v, 1) & splat(0x5555u));
  v = (v & splat(0x3333u)) + (shr(v, 2) & splat(0x3333u));
  v = (v + shr(v, 4)) & splat(0x0F0Fu);
  return (v + shr(v, 8)) & splat(0x1Fu);
}

// One step of kLanes walks at their nodes: child c's code (0 lit, 1 shadowed, 2 reference: childCodeOf) and,
// for the references, readRef's value.
struct Step {
  V code, ref;
  M isRef;
};
inline Step step(const Units& units, M m, V offset, V c) {
  const V header = units.pair(m, offset) & splat(0xFFFFu);
  const V twoC = c + c;
  const V raw = shr(header, twoC) & splat(3);
  Step s;
  s.code = raw - (raw & shr(raw, 1));
  s.isRef = isReference(m, raw);
  // The reference's unit follows the header and the units of the references before it (readRef).
  const V refBits = (header & splat(0xAAAAu)) | (header & shr(header, 1) & splat(0x5555u));
  const V before = shl(splat(1), twoC) - splat(1);
  const V pair = units.pair(s.isRef, offset + splat(1) + popcount16(refBits & before));
  s.ref = blend(equal(raw, splat(3)), pair & splat(0xFFFFu), pair);  // a wide reference takes both units
  return s;
}

// The K <= 9 filters' footprints (filterFootprintsAvx512, filterFootprintsAvx2): the footprints of a batch, one array per field (x0, x1, y0, y1: inclusive texel bounds; z: the slice; out: the
// answer's slot), each with kWalkPadding spare slots for the packing stores.
struct FootprintArrays {
  uint32_t *x0, *x1, *y0, *y1, *z, *out;
};
struct FootprintStorage {
  std::vector<uint32_t> fields[6];
  FootprintArrays reserve(size_t count) {
    if (fields[0].size() < count + kWalkPadding)
      for (std::vector<uint32_t>& f : fields) f.resize(count + kWalkPadding);
    return {fields[0].data(), fields[1].data(), fields[2].data(), fields[3].data(), fields[4].data(),
            fields[5].data()};
  }
};
struct FootprintLanes {
  V x0, x1, y0, y1, z, out;
};
inline FootprintLanes loadFootprints(const FootprintArrays& f, size_t i, M m) {
  return {load(f.x0 + i, m), load(f.x1 + i, m), load(f.y0 + i, m), load(f.y1 + i, m), load(f.z + i, m),
          load(f.out + i, m)};
}

// kLanes walks' fields (WalkSet's arrays) in lanes.
struct WalkLanes {
  V x, y, z, offset, out;
};
inline WalkLanes loadWalks(const WalkSet& w, size_t i, M m) {
  return {load(w.x + i, m), load(w.y + i, m), load(w.z + i, m), load(w.offset + i, m), load(w.out + i, m)};
}
// Appends the walks of the lanes `keep` at w[at, ...) and returns the new count. The stores may write over the
// walks being read (at <= their index, and kLanes slots from `at` end at most where those lanes end): those
// lanes are already in registers.
inline size_t storeWalks(const WalkSet& w, size_t at, M keep, const WalkLanes& l) {
  compress(w.x + at, keep, l.x);
  compress(w.y + at, keep, l.y);
  compress(w.z + at, keep, l.z);
  compress(w.offset + at, keep, l.offset);
  compress(w.out + at, keep, l.out);
  return at + lanesSet(keep);
}

template <WalkResult kKind>
void descend(const WalkDag& dag, const WalkSet& w, size_t active, uint32_t startSize, const Results<kKind>& results) {
  const Units units{dag.nodes, splat(uint32_t(dag.nodeUnits - 1))};
  // Octree levels: child c = (z, y, x bits at the child's edge) in Z-order.
  for (uint32_t size = startSize; size > 8 && active > 0; size >>= 1) {
    const unsigned bit = unsigned(std::countr_zero(size)) - 1u;  // log2 of the child's edge
    const V base = splat(dag.childBase[bit + 1]);
    size_t kept = 0;
    for (size_t i = 0; i < active; i += kLanes) {
      const size_t lanes = std::min(kLanes, active - i);
      const M m = laneMask(lanes);
      WalkLanes l = loadWalks(w, i, m);
      const V c = (shr(l.z, bit) & splat(1)) << 2 | (shr(l.y, bit) & splat(1)) << 1 | (shr(l.x, bit) & splat(1));
      const Step s = step(units, m, l.offset, c);
      results.homogeneous(andNot(m, s.isRef), lanes, l.out, s.code);
      l.offset = base + s.ref;
      const size_t next = storeWalks(w, kept, s.isRef, l);
      prefetchWalkNodes(dag.nodes, w.offset, kept, next);
      kept = next;
    }
    active = kept;
  }
  if (active == 0) return;
  // Leaf parents: the z-only split into 8 x 8 x 1 leaves.
  size_t kept = 0;
  for (size_t i = 0; i < active; i += kLanes) {
    const size_t lanes = std::min(kLanes, active - i);
    const M m = laneMask(lanes);
    WalkLanes l = loadWalks(w, i, m);
    const Step s = step(units, m, l.offset, l.z & splat(7));
    results.homogeneous(andNot(m, s.isRef), lanes, l.out, s.code);
    l.offset = s.ref;  // a leaf index from here on
    const size_t next = storeWalks(w, kept, s.isRef, l);
    for (size_t j = kept; j < next; ++j) portable::prefetchRead(dag.leaves + w.offset[j]);
    kept = next;
  }
  // Leaves.
  for (size_t i = 0; i < kept; i += kLanes) {
    const size_t lanes = std::min(kLanes, kept - i);
    const M m = laneMask(lanes);
    results.leaf(dag.leaves, m, lanes, load(w.out + i, m), load(w.offset + i, m), load(w.x + i, m), load(w.y + i, m));
  }
}

// Walks [0, started), each at its start entry's node (the top grid's cell or the root): their nodes prefetched,
// then descended in groups of kWalksInFlight (a group's prefetched lines are still in L1 one pass later).
template <WalkResult kKind>
void descendFromStart(const WalkStart& g, const WalkSet& w, size_t started, const Results<kKind>& results) {
  prefetchWalkNodes(g.dag.nodes, w.offset, 0, started);
  const uint32_t startSize = g.gridCells ? 1u << g.gridShift : g.dag.resolution;
  for (size_t begin = 0; begin < started; begin += kWalksInFlight)
    descend(g.dag, w.from(begin), std::min(kWalksInFlight, started - begin), startSize, results);
}
