#include "libcpvs/eval/error_stats.h"

#include <algorithm>

namespace cpvs {

void ErrorStats::add(const ErrorStats& o) {
  samples += o.samples;
  misclassified += o.misclassified;
  uniform += o.uniform;
  misclassifiedUniform += o.misclassifiedUniform;
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
