#pragma once
// G-buffers as query points: an EXR image whose pixels hold world positions (and normals), as a renderer
// writes them, read into the points cpvs-query answers (one per pixel, row-major).
#include <cstdint>
#include <string>
#include <vector>

#include "libcpvs/io/points.h"

namespace cpvs {

// Positions from the channels P.X/P.Y/P.Z (or position.X..., else R/G/B); normals from N.X/N.Y/N.Z of the same
// file or, when `normalsPath` is given, of that file (N.X/N.Y/N.Z, else R/G/B; it must have the same size).
// hasNormals says whether normals were found (the points' normals are zero otherwise). Throws Error
// (InvalidInput) naming the file and the channels it has.
std::vector<QueryPoint> readGBuffer(const std::string& path, const std::string& normalsPath, uint32_t& width,
                                    uint32_t& height, bool& hasNormals);

}  // namespace cpvs
