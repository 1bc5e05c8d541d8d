#include "libcpvs/bake/light_subsets.h"

#include <algorithm>
#include <charconv>
#include <numeric>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

bool parseIndex(const std::string& text, uint64_t& value) {
  if (text.empty() || text.size() > 12) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size();
}

}  // namespace

std::vector<uint32_t> parseLightList(const std::string& text, const std::vector<Light>& lights) {
  std::vector<uint32_t> out;
  const auto fail = [&](const std::string& item, const std::string& why) {
    throw Error(ErrorCategory::InvalidArgument, "light list '" + text + "': '" + item + "' " + why);
  };
  const auto checkIndex = [&](const std::string& item, uint64_t i) {
    if (i >= lights.size())
      fail(item, "is out of range: the scene has " + std::to_string(lights.size()) + " light(s), indices 0-" +
                     std::to_string(lights.empty() ? 0 : lights.size() - 1));
  };
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    start = comma + 1;
    if (item.empty()) fail(item, "is empty (two commas in a row, or a comma at an end)");
    uint64_t a = 0, b = 0;
    const size_t dash = item.find('-');
    if (parseIndex(item, a)) {
      checkIndex(item, a);
      out.push_back(uint32_t(a));
    } else if (dash != std::string::npos && parseIndex(item.substr(0, dash), a) &&
               parseIndex(item.substr(dash + 1), b)) {
      if (b < a) fail(item, "is a range that ends before it starts");
      checkIndex(item, b);
      for (uint64_t i = a; i <= b; ++i) out.push_back(uint32_t(i));
    } else {
      bool found = false;
      for (size_t i = 0; i < lights.size(); ++i)
        if (lights[i].name == item) {
          out.push_back(uint32_t(i));
          found = true;
        }
      if (!found) fail(item, "is not an index, a range or the name of a light of the scene");
    }
    if (comma == text.size()) break;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

ShardSpec parseShard(const std::string& text) {
  const size_t slash = text.find('/');
  uint64_t i = 0, n = 0;
  if (slash == std::string::npos || !parseIndex(text.substr(0, slash), i) || !parseIndex(text.substr(slash + 1), n))
    throw Error(ErrorCategory::InvalidArgument, "shard '" + text + "': expected I/N, e.g. 0/4");
  if (n < 1 || n > 100000 || i >= n)
    throw Error(ErrorCategory::InvalidArgument,
                "shard '" + text + "': N must be in 1..100000 and I in 0..N-1 (shards are numbered from 0)");
  return {uint32_t(i), uint32_t(n)};
}

std::vector<uint32_t> shardLights(const std::vector<uint32_t>& lights, const std::vector<double>& costs,
                                  ShardSpec shard) {
  std::vector<uint32_t> order = lights;
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return costs.at(a) > costs.at(b) || (costs.at(a) == costs.at(b) && a < b);
  });
  std::vector<double> load(shard.count, 0.0);
  std::vector<uint32_t> mine;
  for (const uint32_t light : order) {
    const size_t least = size_t(std::min_element(load.begin(), load.end()) - load.begin());
    load[least] += costs.at(light);
    if (least == shard.index) mine.push_back(light);
  }
  std::sort(mine.begin(), mine.end());
  return mine;
}

std::string formatLightList(const std::vector<uint32_t>& lights) {
  std::string out;
  for (size_t i = 0; i < lights.size();) {
    size_t j = i;
    while (j + 1 < lights.size() && lights[j + 1] == lights[j] + 1) ++j;
    if (!out.empty()) out += ',';
    out += std::to_string(lights[i]);
    if (j > i) out += '-' + std::to_string(lights[j]);
    i = j + 1;
  }
  return out;
}

}  // namespace cpvs
