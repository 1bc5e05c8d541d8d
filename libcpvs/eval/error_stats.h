#pragma once
// A shadow method's error against the ray-traced reference, per light or pooled over lights: what cpvs-query's
// report ("reference") and the speed-vs-error sweep give. A value >= 0.5 counts as lit.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace cpvs {

struct ErrorStats {
  uint64_t samples = 0;               // valid points (x lights when pooled)
  uint64_t misclassified = 0;         // binary answer (value >= 0.5 is lit) != reference
  uint64_t uniform = 0;               // points whose reference is the same at every offset within two voxels
  uint64_t misclassifiedUniform = 0;
  // Pairs where the point faces the light and lies in its influence: the others are 0 for both sides by rule
  // (a back face, outside the cone or range), so errors can only happen here.
  uint64_t facing = 0;
  uint64_t misclassifiedFacing = 0;
  double absDiffSum = 0;              // sum |value - reference| (PCF values are fractions)
  double absDiffSumUniform = 0;       // the same over the uniform points
  uint64_t referenceLit = 0;
  uint64_t cpvsLit = 0;               // the method said lit (value >= 0.5)
  // Input indices (0-based rows) of the first misclassified uniform points: where to look first when that
  // rate is not ~0 (a uniform point is far from any shadow boundary, so its error is not resolution).
  std::vector<uint64_t> firstMisclassifiedUniform;
  std::vector<uint64_t> firstMisclassified;  // the same over all points (shadow edges included)
  static constexpr size_t kExamples = 20;

  // One point: the method's value, the reference (0 or 1), whether the point is uniform, and its input row
  // (kept among the first examples when misclassified).
  void record(float value, uint8_t reference, bool isUniform, uint64_t row, bool facesLight = true);
  void add(const ErrorStats& o);
  double meanAbsDiff() const { return samples ? absDiffSum / double(samples) : 0.0; }
  double rate(uint64_t count, uint64_t of) const { return of ? double(count) / double(of) : 0.0; }
};

}  // namespace cpvs
