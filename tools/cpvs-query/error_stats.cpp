#include "tools/cpvs-query/error_stats.h"

namespace cpvs::query {

void ErrorStats::add(const ErrorStats& o) {
  samples += o.samples;
  misclassified += o.misclassified;
  uniform += o.uniform;
  misclassifiedUniform += o.misclassifiedUniform;
  absDiffSum += o.absDiffSum;
  absDiffSumUniform += o.absDiffSumUniform;
  referenceLit += o.referenceLit;
  cpvsLit += o.cpvsLit;
  for (uint64_t i : o.firstMisclassifiedUniform)
    if (firstMisclassifiedUniform.size() < kExamples) firstMisclassifiedUniform.push_back(i);
}

}  // namespace cpvs::query
