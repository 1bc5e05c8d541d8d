#include "libcpvs/scene/coverage_mask.h"

#include <algorithm>
#include <cmath>

#include <xxhash.h>

#include "libcpvs/base/error.h"
#include "libcpvs/base/named_values.h"

namespace cpvs {

uint32_t CoverageMask::texel(double coordinate, uint32_t size, TextureWrap wrap) {
  // Far outside [0, 1] every wrap is periodic or clamped long before; the clamp keeps the texel index in an
  // int32, as the GL renderer's shader computes it.
  const double scaled = std::clamp(coordinate * double(size), -1073741824.0, 1073741824.0);
  const int64_t i = int64_t(std::floor(scaled));
  const int64_t n = int64_t(size);
  switch (wrap) {
    case TextureWrap::ClampToEdge: return uint32_t(std::clamp<int64_t>(i, 0, n - 1));
    case TextureWrap::MirroredRepeat: {
      const int64_t m = ((i % (2 * n)) + 2 * n) % (2 * n);
      return uint32_t(m < n ? m : 2 * n - 1 - m);
    }
    case TextureWrap::Repeat:
    default: return uint32_t(((i % n) + n) % n);
  }
}

uint64_t CoverageMask::hash() const {
  XXH3_state_t* state = XXH3_createState();
  XXH3_64bits_reset(state);
  const uint32_t header[] = {width, height, uint32_t(wrapS), uint32_t(wrapT)};
  XXH3_64bits_update(state, header, sizeof header);
  XXH3_64bits_update(state, blocks.data(), blocks.size());
  const uint64_t digest = XXH3_64bits_digest(state);
  XXH3_freeState(state);
  return digest;
}

namespace {
constexpr Named<TransparentPolicy> kTransparentPolicies[] = {
    {TransparentPolicy::Clip, "clip"}, {TransparentPolicy::Opaque, "opaque"}, {TransparentPolicy::None, "none"}};
}  // namespace

TransparentPolicy parseTransparentPolicy(const std::string& name) {
  return parseNamed(kTransparentPolicies, name, "transparent policy");
}

CasterAlpha casterAlpha(AlphaMode mode, float cutoff, TransparentPolicy policy, bool alphaTest) {
  CasterAlpha result;
  if (!alphaTest || mode == AlphaMode::Opaque) return result;
  if (mode == AlphaMode::Mask) {
    result.tested = true;
    result.cutoff = cutoff;
    return result;
  }
  switch (policy) {
    case TransparentPolicy::Opaque: break;
    case TransparentPolicy::None: result.casts = false; break;
    case TransparentPolicy::Clip:
      result.tested = true;
      result.cutoff = 0.5f;
      break;
  }
  return result;
}

CoverageMask makeCoverageMask(uint32_t width, uint32_t height, const std::vector<uint8_t>& alpha, float factorAlpha,
                              float cutoff, TextureWrap wrapS, TextureWrap wrapT) {
  CoverageMask mask;
  mask.width = width;
  mask.height = height;
  mask.wrapS = wrapS;
  mask.wrapT = wrapT;
  // The alpha test per 8-bit value, once: value v blocks when factor * v / 255 >= cutoff (in float, as a
  // shader computes it).
  uint8_t blocksValue[256];
  for (int v = 0; v < 256; ++v) blocksValue[v] = factorAlpha * (float(v) / 255.0f) >= cutoff ? 1 : 0;
  mask.blocks.resize(size_t(width) * height);
  for (size_t i = 0; i < mask.blocks.size(); ++i) mask.blocks[i] = blocksValue[alpha[i]];
  return mask;
}

}  // namespace cpvs
