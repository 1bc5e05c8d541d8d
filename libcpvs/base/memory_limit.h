#pragma once
// How much memory this process may really use, and the bake's default memory budgets drawn from it: the tightest
// of the cgroup limits over the process (a container, a Slurm job), the CPVS_MEMORY_LIMIT environment variable
// (what a job script was granted) and the physical memory, which bound resident memory; and the resource limits on
// the address space (`ulimit -v`) and the data size (`ulimit -d`), which bound what the process maps. Each less a
// margin for what the budget does not see.
#include <cstdint>
#include <string>

namespace cpvs {

// What a limit bounds: resident memory, or mapped memory as the kernel counts it for RLIMIT_AS (all of the
// address space) or RLIMIT_DATA (private writable mappings: the heap, anonymous maps, thread stacks).
enum class MemoryMeasure { Resident, AddressSpace, Data };

struct MemoryLimit {
  uint64_t bytes = 0;  // 0: nothing known (no /proc, no sysconf), or no such limit
  std::string source;  // what it is, for messages and reports: "physical memory", "cgroup limit", ...
  std::string file;    // the file it was read from, if any
  MemoryMeasure measure = MemoryMeasure::Resident;
};

// The tightest limit on this process's memory. The cgroup limits are read for the process's own cgroup and
// every ancestor up to the hierarchy's mount (v2 memory.max, v1 memory.limit_in_bytes); "max" and v1's
// page-rounded 2^63 mean none. Throws Error(InvalidArgument) when CPVS_MEMORY_LIMIT is set but not a size.
MemoryLimit processMemoryLimit();

// The tighter of the soft RLIMIT_AS and RLIMIT_DATA limits (measure AddressSpace or Data); bytes 0 when neither
// is set. Allocations past it fail however much memory is free, so a budget on resident memory cannot see it.
MemoryLimit mappedMemoryLimit();

// What the budget leaves to everything it does not count (page cache charged to the cgroup, other processes,
// resident growth between two checks): an eighth of the limit, at least 64 MiB and at most 4 GiB.
uint64_t memoryMargin(uint64_t limitBytes);

// The budget a bake gets when none is given: processMemoryLimit() less memoryMargin(); bytes 0 when no limit
// is known. Its source says both, e.g. "physical memory 23.4 GiB less 2.9 GiB".
MemoryLimit defaultMemoryBudget();

// The budget on mapped memory a bake gets by default: mappedMemoryLimit() less memoryMargin(); bytes 0 when no
// such limit is set. Its source says which, e.g. "address-space limit (ulimit -v) 293 MiB less 64 MiB".
MemoryLimit defaultMappedBudget();

// Parses CPVS_MEMORY_LIMIT-style sizes: a number with an optional K, M, G or T suffix (powers of 1024).
// Returns 0 for anything else.
uint64_t parseMemorySize(const std::string& text);

// "23.4 GiB", "512 MiB".
std::string formatMemorySize(uint64_t bytes);

}  // namespace cpvs
