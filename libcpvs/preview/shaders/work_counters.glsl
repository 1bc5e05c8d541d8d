// Work counters a pass adds to (cpvs-view's report: what a GPU's time follows, apart from llvmpipe's): 64-bit
// sums kept as (low, high) word pairs in one storage buffer. A workgroup first sums into shared memory, then
// adds each non-zero sum with one global atomic (not one per pair). CPVS_WORK_COUNTERS is fixed when the
// program is linked (e.g. 1 + the lights, for per-light sums).
layout(std430, binding = 30) buffer WorkCounters { uint workCounters[]; };
shared uint gGroupWork[CPVS_WORK_COUNTERS];
uint groupInvocations() { return gl_WorkGroupSize.x * gl_WorkGroupSize.y * gl_WorkGroupSize.z; }
// Called by every invocation, in uniform control flow.
void beginGroupWork() {
  for (uint i = gl_LocalInvocationIndex; i < uint(CPVS_WORK_COUNTERS); i += groupInvocations()) gGroupWork[i] = 0u;
  barrier();
}
void countWork(uint counter, uint amount) {
  if (amount != 0u) atomicAdd(gGroupWork[counter], amount);
}
// Called by every invocation, in uniform control flow.
void endGroupWork() {
  barrier();
  for (uint i = gl_LocalInvocationIndex; i < uint(CPVS_WORK_COUNTERS); i += groupInvocations()) {
    uint amount = gGroupWork[i];
    if (amount == 0u) continue;
    uint old = atomicAdd(workCounters[2u * i], amount);
    if (old + amount < old) atomicAdd(workCounters[2u * i + 1u], 1u);  // the low word wrapped
  }
}
