// Work counters a pass adds to (cpvs-view's report: what a GPU's time follows, apart from llvmpipe's): 64-bit
// sums kept as (low, high) word pairs in one storage buffer. A workgroup first sums into shared memory, then
// one invocation adds the group's sum (one global atomic per group, not per pair).
layout(std430, binding = 30) buffer WorkCounters { uint workCounters[]; };
shared uint gGroupWork[CPVS_WORK_COUNTERS];
void beginGroupWork() {
  if (gl_LocalInvocationIndex == 0u)
    for (uint i = 0u; i < uint(CPVS_WORK_COUNTERS); ++i) gGroupWork[i] = 0u;
  barrier();
}
void countWork(uint counter, uint amount) { atomicAdd(gGroupWork[counter], amount); }
// Called by every invocation, in uniform control flow.
void endGroupWork() {
  barrier();
  if (gl_LocalInvocationIndex == 0u)
    for (uint i = 0u; i < uint(CPVS_WORK_COUNTERS); ++i) {
      uint amount = gGroupWork[i];
      uint old = atomicAdd(workCounters[2u * i], amount);
      if (old + amount < old) atomicAdd(workCounters[2u * i + 1u], 1u);  // the low word wrapped
    }
}
