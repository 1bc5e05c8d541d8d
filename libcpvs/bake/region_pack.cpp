#include "libcpvs/bake/region_pack.h"

#include <cstring>

#include <xxhash.h>

#include "libcpvs/base/error.h"
#include "libcpvs/runtime/outcome.h"

namespace cpvs {
namespace {

constexpr char kMagic[8] = {'C', 'P', 'V', 'S', 'R', 'G', 'N', '1'};

void putWord(std::string& out, uint64_t value) {
  for (unsigned b = 0; b < 8; ++b) out.push_back(char(uint8_t(value >> (8 * b))));
}

uint64_t wordAt(std::string_view bytes, size_t at) {
  uint64_t value = 0;
  for (unsigned b = 0; b < 8; ++b) value |= uint64_t(uint8_t(bytes[at + b])) << (8 * b);
  return value;
}

}  // namespace

std::string encodeRegionPack(uint64_t frameKey, const RegionPack& pack) {
  std::string out(kMagic, sizeof kMagic);
  putWord(out, frameKey);
  putWord(out, pack.lightKey);
  putWord(out, pack.regions.size());
  for (const CachedRegion& r : pack.regions) {
    putWord(out, r.key);
    putWord(out, r.record.size());
    out += r.record;
  }
  putWord(out, XXH3_64bits(out.data(), out.size()));
  return out;
}

RegionPack decodeRegionPack(std::string_view bytes, uint64_t frameKey, const std::string& name) {
  const auto fail = [&](const std::string& why) -> RegionPack {
    throw Error(ErrorCategory::InvalidInput, name + ": " + why);
  };
  if (bytes.size() < 40 || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    return fail("not a region pack of this version");
  const size_t body = bytes.size() - 8;
  if (wordAt(bytes, body) != XXH3_64bits(bytes.data(), body)) return fail("checksum mismatch (damaged)");
  if (wordAt(bytes, 8) != frameKey) return fail("a region pack of another view");
  RegionPack pack;
  pack.lightKey = wordAt(bytes, 16);
  const uint64_t count = wordAt(bytes, 24);
  if (count > body / 16) return fail("counts more regions than it has bytes");
  pack.regions.resize(count);
  size_t at = 32;
  for (CachedRegion& r : pack.regions) {
    if (body - at < 16) return fail("ends inside a region");
    r.key = wordAt(bytes, at);
    const uint64_t length = wordAt(bytes, at + 8);
    at += 16;
    if (length > body - at) return fail("ends inside a region's record");
    r.record.assign(bytes.substr(at, length));
    at += length;
  }
  if (at != body) return fail("has bytes after its last region");
  return pack;
}

}  // namespace cpvs
