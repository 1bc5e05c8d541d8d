#pragma once
// Alpha-tested shadow casters (docs/alpha.md): where a material's alpha lets light through, as one bit per
// texel of its base-colour texture. Every consumer of the scene — the CPU and GL depth rasterisers, the Embree
// reference, the surface sampler and cpvs-view — cuts a triangle with the same mask and the same lookup rule.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace cpvs {

// glTF sampler wrap modes (the values are glTF's).
enum class TextureWrap : uint16_t { Repeat = 10497, ClampToEdge = 33071, MirroredRepeat = 33648 };

// Which texels of a material block light. Built once at import from the texture's alpha channel, the
// material's baseColorFactor alpha and its cutoff: a texel blocks light when factor * alpha >= cutoff.
struct CoverageMask {
  uint32_t width = 1, height = 1;
  TextureWrap wrapS = TextureWrap::Repeat, wrapT = TextureWrap::Repeat;
  std::vector<uint8_t> blocks;  // width * height, row 0 = the image's first row (v = 0): 1 blocks light

  // The rule: the texel that contains (u, v) (nearest, no filtering), wrapped by the sampler's modes.
  // Coordinates that are not finite block light (the conservative answer).
  bool blocksAt(double u, double v) const {
    if (!std::isfinite(u) || !std::isfinite(v)) return true;
    return blocks[size_t(texel(v, height, wrapT)) * width + texel(u, width, wrapS)];
  }
  // 64-bit hash of the size, wraps and bits: what a bake's input hash and cache keys take for the mask.
  uint64_t hash() const;

  static uint32_t texel(double coordinate, uint32_t size, TextureWrap wrap);
};

// How a material's alphaMode "BLEND" casts: cut at 0.5 like MASK (leaf cards stay dappled, clear glass and
// light-shaft meshes cast nothing), as if opaque, or not at all.
enum class TransparentPolicy : uint8_t { Clip = 0, Opaque = 1, None = 2 };
// "clip" / "opaque" / "none"; throws Error(InvalidArgument) for anything else.
TransparentPolicy parseTransparentPolicy(const std::string& name);

// What a mesh's material does to its shadow.
enum class AlphaMode : uint8_t { Opaque = 0, Mask = 1, Blend = 2 };
struct CasterAlpha {
  bool casts = true;  // false: the mesh casts no shadow at all
  float cutoff = 0.5f;  // when casts and the mesh has a texture or factor to cut with
  bool tested = false;  // the alpha test applies (MASK, or BLEND clipped)
};
// The rule for a material: OPAQUE ignores alpha; MASK cuts at its cutoff; BLEND follows the policy (clip at
// 0.5, opaque, or none). With alphaTest false every material casts as OPAQUE.
CasterAlpha casterAlpha(AlphaMode mode, float cutoff, TransparentPolicy policy, bool alphaTest);

// The mask of a texture's alpha channel (`alpha`: width * height bytes) under a factor and cutoff.
CoverageMask makeCoverageMask(uint32_t width, uint32_t height, const std::vector<uint8_t>& alpha, float factorAlpha,
                              float cutoff, TextureWrap wrapS, TextureWrap wrapT);

}  // namespace cpvs
