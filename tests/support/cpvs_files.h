#pragma once
// .cpvs files for the format's tests (format_test, format3_test): the content of the golden files and baked
// content from synthetic depth maps, and the raw container, unpacked into sections and packed again with valid
// checksums, so that a test can damage a record or a DAG behind checksums that still match.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "libcpvs/bake/cpvs_writer.h"

namespace cpvs::test::cpvsfiles {

using Bytes = std::vector<uint8_t>;
inline constexpr double kPi = 3.14159265358979323846;

ShadowDag bakedDag(uint32_t n, uint32_t seed);        // from test::syntheticDepth
ShadowDag uniformDag(uint32_t n, ChildCode code);     // no nodes: every voxel lit (or shadowed)
LightView makeView(Projection projection, DepthMapping mapping, uint32_t n, int face, double k);
Light makeLight(LightType type, const std::string& name);
CpvsContent bakedContent();  // a sun (1 view), a spot (1 view) and a point light (6 views), baked DAGs
CpvsContent tinyContent();   // hand-made DAGs, small and fixed: the content of the golden files

Bytes toBytes(const std::string& s);
Bytes readFile(const std::string& path);
void writeFile(const std::string& path, const Bytes& bytes);
// Opens bytes and returns the Error's message; fails the test when it opens or throws anything else.
std::string openError(const Bytes& bytes, const std::string& name = "t.cpvs");

struct RawSection {
  uint32_t type = 0, elementSize = 0;
  Bytes bytes;
};
struct RawFile {
  uint16_t major = 1, minor = 0;
  std::vector<RawSection> sections;
};
uint64_t getLE(const Bytes& b, size_t at, int n);
void putLE(Bytes& b, size_t at, uint64_t v, int n);
void putF64(Bytes& b, size_t at, double v);
RawFile unpack(const Bytes& b);
// Sections first (64-byte aligned), the table last: a layout the writer does not use but the spec allows.
Bytes pack(const RawFile& f);
RawSection& sectionOf(RawFile& f, uint32_t type);
// `original` with 1 to 3 random bytes of its sections [firstSection, end) changed (a byte replaced, or one bit
// flipped), drawn from `rng`: pack() makes the checksums valid again, so only the structure checks can catch it.
RawFile randomlyDamaged(const RawFile& original, size_t firstSection, std::mt19937& rng);

}  // namespace cpvs::test::cpvsfiles
