#include "libcpvs/eval/error_stats.h"

#include <algorithm>
#include <cmath>

namespace cpvs {

void ErrorStats::record(float value, uint8_t reference, bool isUniform, uint64_t row, bool facesLight) {
  const bool lit = value >= 0.5f;
  const bool wrong = lit != (reference != 0);
  const double diff = std::abs(double(value) - double(reference));
  ++samples;
  facing += facesLight;
  misclassifiedFacing += facesLight && wrong;
  misclassified += wrong;
  if (wrong && firstMisclassified.size() < kExamples) firstMisclassified.push_back(row);
  absDiffSum += diff;
  referenceLit += reference != 0;
  cpvsLit += lit;
  if (!isUniform) return;
  ++uniform;
  misclassifiedUniform += wrong;
  if (wrong && firstMisclassifiedUniform.size() < kExamples) firstMisclassifiedUniform.push_back(row);
  absDiffSumUniform += diff;
}

void ErrorStats::add(const ErrorStats& o) {
  samples += o.samples;
  misclassified += o.misclassified;
  uniform += o.uniform;
  misclassifiedUniform += o.misclassifiedUniform;
  facing += o.facing;
  misclassifiedFacing += o.misclassifiedFacing;
  absDiffSum += o.absDiffSum;
  absDiffSumUniform += o.absDiffSumUniform;
  referenceLit += o.referenceLit;
  cpvsLit += o.cpvsLit;
  // Pooled over lights: the first rows misclassified for any light, each once.
  for (auto [rows, more] : {std::pair{&firstMisclassifiedUniform, &o.firstMisclassifiedUniform},
                            std::pair{&firstMisclassified, &o.firstMisclassified}}) {
    rows->insert(rows->end(), more->begin(), more->end());
    std::sort(rows->begin(), rows->end());
    rows->erase(std::unique(rows->begin(), rows->end()), rows->end());
    if (rows->size() > kExamples) rows->resize(kExamples);
  }
}

}  // namespace cpvs
