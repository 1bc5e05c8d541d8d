#pragma once
// Which lights one bake run bakes: a list the user names (--lights) and a cost-balanced shard of it (--shard),
// so that many processes or machines can share a level's lights and cpvs-merge can join their files.
#include <cstdint>
#include <string>
#include <vector>

#include "libcpvs/runtime/light.h"

namespace cpvs {

// Parses "0-11,20,Lantern": comma-separated light indices, inclusive index ranges and light names (exact,
// case-sensitive; a name that is all digits or contains a comma or '-' between digits is taken as an index or
// range). Returns the indices, ascending and without repeats. Throws Error(InvalidArgument) naming the item
// that is out of range, malformed or matches no light.
std::vector<uint32_t> parseLightList(const std::string& text, const std::vector<Light>& lights);

// "I/N" with 0 <= I < N <= 100000. Throws Error(InvalidArgument).
struct ShardSpec {
  uint32_t index = 0, count = 1;
};
ShardSpec parseShard(const std::string& text);

// Splits `lights` (indices) into `count` shards of about equal total cost and returns shard `index`'s lights,
// ascending. Deterministic: the longest-processing-time rule (costliest light first, ties by index, each to
// the shard with the least cost so far, ties to the lowest shard), so every process of a sharded bake computes
// the same partition. `costs[i]` is light i's estimated cost (indexed like the scene's lights).
std::vector<uint32_t> shardLights(const std::vector<uint32_t>& lights, const std::vector<double>& costs,
                                  ShardSpec shard);

// "0-3,7,9-10": the compact form of an ascending index list, for messages and reports.
std::string formatLightList(const std::vector<uint32_t>& lights);

}  // namespace cpvs
