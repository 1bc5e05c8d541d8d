#pragma once
// cpvs-query's error figures per light (or pooled over the lights): what the report's "reference" object holds.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace cpvs {

struct ErrorStats {
  uint64_t samples = 0;               // valid points (x lights when pooled)
  uint64_t misclassified = 0;         // binary CPVS answer (value >= 0.5 is lit) != reference
  uint64_t uniform = 0;               // points whose reference is the same at every offset within two voxels
  uint64_t misclassifiedUniform = 0;
  double absDiffSum = 0;              // sum |CPVS value - reference| (PCF values are fractions)
  double absDiffSumUniform = 0;       // the same over the uniform points
  uint64_t referenceLit = 0;
  uint64_t cpvsLit = 0;               // value >= 0.5
  // Input indices (0-based rows) of the first misclassified uniform points: where to look first when that
  // rate is not ~0 (a uniform point is far from any shadow boundary, so its error is not resolution).
  std::vector<uint64_t> firstMisclassifiedUniform;
  std::vector<uint64_t> firstMisclassified;  // the same over all points (shadow edges included)
  static constexpr size_t kExamples = 20;

  void add(const ErrorStats& o);
  double rate(uint64_t count, uint64_t of) const { return of ? double(count) / double(of) : 0.0; }
};

}  // namespace cpvs
