#pragma once
// The lockstep peel of closed solids replayed per texel from the crossings one pass keeps (docs/depth-maps.md,
// "The CPU rasteriser").
#include <cstdint>
#include <cstring>
#include <limits>

namespace cpvs {

// Peel states of a texel (the GL renderer's counts).
enum State : uint8_t { kInactive = 0, kActive = 1, kExitFound = 2, kCapped = 3, kStuck = 4 };

constexpr float kInfinity = std::numeric_limits<float>::infinity();

// The largest float below x (x finite or +infinity).
inline float floatBefore(float x) {
  if (x == 0.0f) return -std::numeric_limits<float>::denorm_min();
  uint32_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  bits = x > 0.0f ? bits - 1 : bits + 1;
  std::memcpy(&x, &bits, sizeof bits);
  return x;
}

// The closed crossings a texel's lockstep peel consumes, kept from the one pass that finds its enter surface: the
// P + 1 nearest distinct closed front keys (the first is the enter surface when it is a closed front; the peel
// consumes F2 .. F(P+1)), the P nearest distinct closed back keys, and per back key whether several closed back
// faces lie exactly there (a repeated back layer is an exit). P = the peel cap.
template <int P>
struct KeptCrossings {
  float front[P + 1];
  float back[P];
  uint8_t backRepeated;  // bit k: back[k] was met more than once

  void clear() {
    for (float& f : front) f = kInfinity;
    for (float& b : back) b = kInfinity;
    backRepeated = 0;
  }
  void addFront(float key) {
    if (!(key < front[P])) return;
    for (int k = 0; k < P; ++k)
      if (key == front[k]) return;  // coincident front faces count once, as the peel's strict "beyond" test
    int at = P;
    for (; at > 0 && key < front[at - 1]; --at) front[at] = front[at - 1];
    front[at] = key;
  }
  void addBack(float key) {
    if (!(key <= back[P - 1])) return;
    for (int k = 0; k < P; ++k)
      if (key == back[k]) {
        backRepeated |= uint8_t(1u << k);
        return;
      }
    int at = P - 1;
    for (; at > 0 && key < back[at - 1]; --at) back[at] = back[at - 1];
    back[at] = key;
    // Flags follow their keys: those from `at` on move up one place, the last one drops out with its key.
    const unsigned below = backRepeated & ((1u << at) - 1u), above = (backRepeated >> at) << (at + 1);
    backRepeated = uint8_t((below | above) & ((1u << P) - 1u));
  }
};

// One texel's lockstep peel over its kept crossings, `iterations` iterations of a peel capped at `cap`: the
// passes' per-texel rule (below) applied to the layers each iteration would find.
struct ReplayedTexel {
  uint8_t state;
  uint8_t finishedAt;  // the iteration (1-based) that found the exit or no back face; cap + 1 when none did
  float frontCursor, backCursor;
};

template <int P>
ReplayedTexel replayTexel(const KeptCrossings<P>& kept, float enterKey, uint32_t iterations, uint32_t cap) {
  ReplayedTexel r{kActive, uint8_t(cap + 1), enterKey, floatBefore(enterKey)};
  for (uint32_t it = 0; it < iterations; ++it) {
    const float f = kept.front[it + 1], b = kept.back[it];
    if (b == kInfinity) {
      r.state = kStuck;
      r.finishedAt = uint8_t(it + 1);
      return r;
    }
    if (f == kInfinity || b <= f || ((kept.backRepeated >> it) & 1u)) {
      r.backCursor = b;
      r.state = kExitFound;
      r.finishedAt = uint8_t(it + 1);
      return r;
    }
    r.frontCursor = f;
    r.backCursor = b;
    if (it + 1 == cap) r.state = kCapped;
  }
  return r;
}

// The peel caps the replay handles; deeper caps (tests resolve nesting completely with 16) peel in passes.
constexpr uint32_t kMaxReplayedPeels = 3;

}  // namespace cpvs
