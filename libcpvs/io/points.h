#pragma once
// Streaming readers for query points (cpvs-query): CSV and PLY point clouds. Points are read in chunks, so
// inputs larger than memory work. EXR G-buffers are read whole with libcpvs/io/exr_image.h.
//
// CSV (text, UTF-8, optional BOM, LF or CRLF line ends):
//  * The first line that is not blank and does not start with '#' is the header: comma-separated column
//    names, case-insensitive, surrounding spaces ignored. It must name x, y and z; nx, ny, nz are optional
//    (all three or none). Any other named column (id, r, g, b, ...) is read past and ignored. A repeated or
//    empty column name is an error.
//  * Every further line is one point with exactly as many fields as the header. Fields are decimal or
//    scientific numbers (C locale); "nan" and "inf"/"-inf" are accepted and give a non-finite point that the
//    caller answers with 0. Blank lines and lines starting with '#' are skipped.
//  * Errors name the file and the line: "pts.csv:17: field 2 ('y'): 'abc' is not a number".
// PLY (format ascii 1.0 or binary_little_endian 1.0; big-endian is rejected):
//  * element "vertex" with properties x, y, z and optional nx, ny, nz of any scalar type (float/double
//    and the integer types, old and new names); other properties, list properties and other elements
//    (before or after the vertices, e.g. faces) are read past and ignored.
//  * Errors name the file and the header line or the vertex: "cloud.ply: vertex 12: ...".
// Points without normals get normal (0, 0, 0): no bias.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "libcpvs/runtime/shadow_lookup.h"

namespace cpvs {

// Position and normal (zero when the file has none), as the lookups take them.
using QueryPoint = SurfacePoint;

enum class PointFormat { Csv, Ply, Exr };
// Decides the format from the file's first bytes ("ply\n", the EXR magic 76 2f 31 01), else CSV.
// Throws Error(InputInvalid) when the file cannot be opened.
PointFormat detectPointFormat(const std::string& path);
const char* pointFormatName(PointFormat format);

class PointReader {
public:
  // Opens a CSV or PLY file and reads its header. Throws Error(InputInvalid) naming the file (and line).
  static std::unique_ptr<PointReader> open(const std::string& path);
  virtual ~PointReader() = default;

  // Replaces `out` with the next up to `maxCount` points (fewer only at the end). Returns false (and an
  // empty `out`) when no points are left. Throws Error(InputInvalid) naming the file and line / vertex.
  virtual bool next(std::vector<QueryPoint>& out, size_t maxCount) = 0;
  virtual bool hasNormals() const = 0;
  // Number of points when the header says (PLY), else nullopt.
  virtual std::optional<uint64_t> count() const = 0;
  // Fraction of the file consumed so far, for progress bars.
  virtual double progress() const = 0;
  virtual PointFormat format() const = 0;
};

}  // namespace cpvs
