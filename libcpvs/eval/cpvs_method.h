#pragma once
// The CPVS as a ShadowMethod: a LightShadow over a bake's views (in memory, or in an open .cpvs file).
#include <memory>

#include "libcpvs/runtime/cpvs_file.h"
#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/eval/shadow_method.h"

namespace cpvs {

class CpvsMethod : public ShadowMethod {
public:
  explicit CpvsMethod(LightShadow shadow) : shadow_(std::move(shadow)) {}
  // The views of a bake (referenced: `baked` must outlive the method).
  static CpvsMethod fromBake(const BakedLight& baked, int topGridLevels = kAutomaticTopGrid);
  // A light of an open file (referenced: the file must outlive the method).
  static CpvsMethod fromFile(const CpvsFile::LightEntry& entry, int topGridLevels = kAutomaticTopGrid);

  std::string name() const override { return "cpvs"; }
  const Light& light() const override { return shadow_.light(); }
  uint64_t bytes() const override;
  void visibility(std::span<const SurfacePoint> points, const LookupOptions& options,
                  std::span<float> out) const override;
  const LightShadow& shadow() const { return shadow_; }

private:
  LightShadow shadow_;
};

}  // namespace cpvs
