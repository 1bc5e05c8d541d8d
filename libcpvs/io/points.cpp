#include "libcpvs/io/points.h"

#include <algorithm>
#include <iterator>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string_view>

#include <sys/stat.h>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

[[noreturn]] void fail(const std::string& message) { throw Error(ErrorCategory::InvalidInput, message); }

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::string quoted(std::string_view s) {
  std::string t(s.substr(0, 40));
  if (s.size() > 40) t += "...";
  return "'" + t + "'";
}

// Parses a whole field as a double ("nan", "inf" accepted). Returns false when it is not a number.
bool parseDouble(std::string_view s, double& value) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (end != s.data() + s.size()) return false;
  if (ec == std::errc::result_out_of_range) {
    // Overflow reads as +-inf (a non-finite point, answered 0); underflow as 0.
    value = std::strtod(std::string(s).c_str(), nullptr);
    return true;
  }
  return ec == std::errc();
}

// Buffered reading of a FILE with line and byte bookkeeping.
class InputFile {
public:
  explicit InputFile(const std::string& path) : path_(path) {
    file_ = std::fopen(path.c_str(), "rb");
    if (!file_) fail(path + ": cannot open: " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fileno(file_), &st) == 0) {
      if (S_ISDIR(st.st_mode)) {
        std::fclose(file_);
        file_ = nullptr;
        fail(path + ": is a directory, not a points file");
      }
      if (S_ISREG(st.st_mode)) size_ = uint64_t(st.st_size);
    }
    buffer_.resize(1 << 20);
  }
  ~InputFile() {
    if (file_) std::fclose(file_);
  }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  // Next line without its terminator ('\n', with a trailing '\r' removed). False at the end of the file.
  bool line(std::string& out) {
    out.clear();
    for (;;) {
      if (pos_ == end_ && !refill()) {
        if (out.empty()) return false;
        break;
      }
      const char* start = buffer_.data() + pos_;
      const void* nl = std::memchr(start, '\n', end_ - pos_);
      if (nl) {
        const size_t n = size_t(static_cast<const char*>(nl) - start);
        out.append(start, n);
        pos_ += n + 1;
        consumed_ += n + 1;
        break;
      }
      out.append(start, end_ - pos_);
      consumed_ += end_ - pos_;
      pos_ = end_;
      if (out.size() > (64u << 20)) fail(path_ + ":" + std::to_string(lineNumber_ + 1) + ": line longer than 64 MiB");
    }
    ++lineNumber_;
    if (!out.empty() && out.back() == '\r') out.pop_back();
    return true;
  }
  // Reads exactly n bytes; false when the file ends first.
  bool bytes(void* dst, size_t n) {
    auto* out = static_cast<char*>(dst);
    while (n > 0) {
      if (pos_ == end_ && !refill()) return false;
      const size_t take = std::min(n, end_ - pos_);
      std::memcpy(out, buffer_.data() + pos_, take);
      pos_ += take;
      consumed_ += take;
      out += take;
      n -= take;
    }
    return true;
  }
  uint64_t lineNumber() const { return lineNumber_; }
  double progress() const { return size_ ? std::min(1.0, double(consumed_) / double(size_)) : 0.0; }
  const std::string& path() const { return path_; }

private:
  bool refill() {
    pos_ = 0;
    end_ = std::fread(buffer_.data(), 1, buffer_.size(), file_);
    if (end_ == 0 && std::ferror(file_)) fail(path_ + ": read error: " + std::strerror(errno));
    return end_ > 0;
  }

  std::string path_;
  FILE* file_ = nullptr;
  std::vector<char> buffer_;
  size_t pos_ = 0, end_ = 0;
  uint64_t consumed_ = 0, size_ = 0;
  uint64_t lineNumber_ = 0;
};

// ---- CSV ----------------------------------------------------------------------------------------------

class CsvReader final : public PointReader {
public:
  explicit CsvReader(const std::string& path) : in_(path) {
    std::string header;
    for (;;) {
      if (!in_.line(header)) fail(path + ": no header line (expected e.g. 'x,y,z' or 'x,y,z,nx,ny,nz')");
      if (in_.lineNumber() == 1 && header.rfind("\xEF\xBB\xBF", 0) == 0) header.erase(0, 3);
      const std::string_view t = trim(header);
      if (!t.empty() && t.front() != '#') break;
    }
    const std::string where = path + ":" + std::to_string(in_.lineNumber());
    std::vector<std::string> names;
    std::string_view rest(header);
    for (;;) {
      const size_t comma = rest.find(',');
      names.push_back(lower(trim(rest.substr(0, comma))));
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
    columns_ = names.size();
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i].empty()) fail(where + ": header column " + std::to_string(i + 1) + " has no name");
      for (size_t j = 0; j < i; ++j)
        if (names[j] == names[i]) fail(where + ": header names column '" + names[i] + "' twice");
    }
    static const char* const wanted[6] = {"x", "y", "z", "nx", "ny", "nz"};
    for (int k = 0; k < 6; ++k) {
      slot_[k] = -1;
      for (size_t i = 0; i < names.size(); ++i)
        if (names[i] == wanted[k]) slot_[k] = int(i);
    }
    if (slot_[0] < 0 || slot_[1] < 0 || slot_[2] < 0) {
      // A header that is all numbers is a file without one.
      double dummy;
      const bool numeric = parseDouble(trim(std::string_view(header).substr(0, header.find(','))), dummy);
      fail(where + ": header must name columns x, y and z (optionally nx, ny, nz)" +
           (numeric ? std::string("; the first line holds numbers: add a header line such as 'x,y,z'")
                    : ", got '" + header.substr(0, 80) + "'"));
    }
    const int normals = (slot_[3] >= 0) + (slot_[4] >= 0) + (slot_[5] >= 0);
    if (normals != 0 && normals != 3) fail(where + ": header names some of nx, ny, nz but not all three");
    hasNormals_ = normals == 3;
    for (size_t i = 0; i < names.size(); ++i) names_.push_back(names[i]);
    fields_.resize(columns_);
  }

  bool next(std::vector<QueryPoint>& out, size_t maxCount) override {
    out.clear();
    while (out.size() < maxCount && in_.line(line_)) {
      const std::string_view t = trim(line_);
      if (t.empty() || t.front() == '#') continue;
      out.push_back(parse(line_));
    }
    return !out.empty();
  }
  bool hasNormals() const override { return hasNormals_; }
  std::optional<uint64_t> count() const override { return std::nullopt; }
  double progress() const override { return in_.progress(); }
  PointFormat format() const override { return PointFormat::Csv; }

private:
  QueryPoint parse(const std::string& line) {
    std::string_view rest(line);
    size_t n = 0;
    for (;;) {
      const size_t comma = rest.find(',');
      if (n == columns_) {
        fail(where() + ": more than " + std::to_string(columns_) + " fields (the header has " +
             std::to_string(columns_) + " columns)");
      }
      fields_[n++] = trim(rest.substr(0, comma));
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
    if (n != columns_)
      fail(where() + ": " + std::to_string(n) + " fields, the header has " + std::to_string(columns_) + " columns");
    double v[6] = {0, 0, 0, 0, 0, 0};
    for (int k = 0; k < (hasNormals_ ? 6 : 3); ++k) {
      const size_t i = size_t(slot_[k]);
      if (!parseDouble(fields_[i], v[k]))
        fail(where() + ": field " + std::to_string(i + 1) + " ('" + names_[i] + "'): " +
             (fields_[i].empty() ? std::string("empty") : quoted(fields_[i]) + " is not a number"));
    }
    return {{v[0], v[1], v[2]}, {v[3], v[4], v[5]}};
  }
  std::string where() const { return in_.path() + ":" + std::to_string(in_.lineNumber()); }

  InputFile in_;
  size_t columns_ = 0;
  int slot_[6];
  bool hasNormals_ = false;
  std::vector<std::string> names_;
  std::vector<std::string_view> fields_;
  std::string line_;
};

// ---- PLY ----------------------------------------------------------------------------------------------

enum class Scalar : uint8_t { I8, U8, I16, U16, I32, U32, F32, F64 };

bool parseScalar(const std::string& name, Scalar& type) {
  static const struct {
    const char* name;
    Scalar type;
  } table[] = {{"char", Scalar::I8},     {"int8", Scalar::I8},     {"uchar", Scalar::U8},    {"uint8", Scalar::U8},
               {"short", Scalar::I16},   {"int16", Scalar::I16},   {"ushort", Scalar::U16},  {"uint16", Scalar::U16},
               {"int", Scalar::I32},     {"int32", Scalar::I32},   {"uint", Scalar::U32},    {"uint32", Scalar::U32},
               {"float", Scalar::F32},   {"float32", Scalar::F32}, {"double", Scalar::F64},  {"float64", Scalar::F64}};
  for (const auto& entry : table)
    if (name == entry.name) {
      type = entry.type;
      return true;
    }
  return false;
}

size_t scalarSize(Scalar t) {
  switch (t) {
    case Scalar::I8:
    case Scalar::U8: return 1;
    case Scalar::I16:
    case Scalar::U16: return 2;
    case Scalar::I32:
    case Scalar::U32:
    case Scalar::F32: return 4;
    case Scalar::F64: return 8;
  }
  return 0;
}

double decodeScalar(Scalar t, const unsigned char* p) {  // little-endian host (x86-64, aarch64)
  switch (t) {
    case Scalar::I8: return double(int8_t(p[0]));
    case Scalar::U8: return double(p[0]);
    case Scalar::I16: { int16_t v; std::memcpy(&v, p, 2); return v; }
    case Scalar::U16: { uint16_t v; std::memcpy(&v, p, 2); return v; }
    case Scalar::I32: { int32_t v; std::memcpy(&v, p, 4); return v; }
    case Scalar::U32: { uint32_t v; std::memcpy(&v, p, 4); return v; }
    case Scalar::F32: { float v; std::memcpy(&v, p, 4); return v; }
    case Scalar::F64: { double v; std::memcpy(&v, p, 8); return v; }
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  Scalar type = Scalar::F32;
  bool list = false;
  Scalar countType = Scalar::U8;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

class PlyReader final : public PointReader {
public:
  explicit PlyReader(const std::string& path) : in_(path), path_(path) {
    std::string line;
    if (!in_.line(line) || line != "ply") fail(path + ": not a PLY file (the first line is not 'ply')");
    bool haveFormat = false;
    for (;;) {
      if (!in_.line(line)) fail(path + ": the header has no 'end_header' line");
      const std::string where = path + ":" + std::to_string(in_.lineNumber());
      std::istringstream words(line);
      std::string keyword;
      words >> keyword;
      if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
      if (keyword == "end_header") break;
      if (keyword == "format") {
        std::string format, version;
        words >> format >> version;
        if (format == "ascii") {
          binary_ = false;
        } else if (format == "binary_little_endian") {
          binary_ = true;
        } else if (format == "binary_big_endian") {
          throw Error(ErrorCategory::InvalidInput, where + ": binary_big_endian PLY is not supported; convert it to "
                                                      "binary_little_endian or ascii");
        } else {
          fail(where + ": unknown PLY format '" + format + "'");
        }
        if (version != "1.0") fail(where + ": unsupported PLY version '" + version + "' (expected 1.0)");
        haveFormat = true;
      } else if (keyword == "element") {
        PlyElement element;
        std::string count;
        words >> element.name >> count;
        uint64_t value = 0;
        const auto [end, ec] = std::from_chars(count.data(), count.data() + count.size(), value);
        if (element.name.empty() || count.empty() || ec != std::errc() || end != count.data() + count.size())
          fail(where + ": malformed element line '" + line + "'");
        element.count = value;
        elements_.push_back(element);
      } else if (keyword == "property") {
        if (elements_.empty()) fail(where + ": property before any element");
        PlyProperty property;
        std::string type;
        words >> type;
        if (type == "list") {
          std::string countType, itemType;
          words >> countType >> itemType >> property.name;
          if (!parseScalar(countType, property.countType) || !parseScalar(itemType, property.type) ||
              property.countType == Scalar::F32 || property.countType == Scalar::F64)
            fail(where + ": malformed list property '" + line + "'");
          property.list = true;
        } else {
          if (!parseScalar(type, property.type)) fail(where + ": unknown property type '" + type + "'");
          words >> property.name;
        }
        if (property.name.empty()) fail(where + ": property without a name");
        elements_.back().properties.push_back(property);
      } else {
        fail(where + ": unexpected header line '" + line.substr(0, 80) + "'");
      }
    }
    if (!haveFormat) fail(path + ": the header has no 'format' line");
    size_t vertexElement = elements_.size();
    for (size_t i = 0; i < elements_.size(); ++i)
      if (elements_[i].name == "vertex") vertexElement = i;
    if (vertexElement == elements_.size()) fail(path + ": no 'element vertex' in the header");
    const PlyElement& vertex = elements_[vertexElement];
    static const char* const wanted[6] = {"x", "y", "z", "nx", "ny", "nz"};
    for (int k = 0; k < 6; ++k) {
      slot_[k] = -1;
      for (size_t i = 0; i < vertex.properties.size(); ++i)
        if (vertex.properties[i].name == wanted[k]) {
          if (vertex.properties[i].list) fail(path + ": vertex property '" + wanted[k] + "' is a list");
          slot_[k] = int(i);
        }
    }
    if (slot_[0] < 0 || slot_[1] < 0 || slot_[2] < 0) fail(path + ": the vertex element has no x, y and z properties");
    const int normals = (slot_[3] >= 0) + (slot_[4] >= 0) + (slot_[5] >= 0);
    if (normals != 0 && normals != 3) fail(path + ": the vertex element has some of nx, ny, nz but not all three");
    hasNormals_ = normals == 3;
    vertexCount_ = vertex.count;
    // Skip the elements stored before the vertices.
    for (size_t e = 0; e < vertexElement; ++e)
      for (uint64_t i = 0; i < elements_[e].count; ++i) {
        double ignored[6];
        readRecord(elements_[e], elements_[e].name, i, ignored, nullptr);
      }
    vertex_ = vertex;
    values_.resize(vertex.properties.size());
  }

  bool next(std::vector<QueryPoint>& out, size_t maxCount) override {
    out.clear();
    while (out.size() < maxCount && read_ < vertexCount_) {
      double v[6] = {0, 0, 0, 0, 0, 0};
      readRecord(vertex_, "vertex", read_, v, slot_);
      out.push_back({{v[0], v[1], v[2]}, {v[3], v[4], v[5]}});
      ++read_;
    }
    return !out.empty();
  }
  bool hasNormals() const override { return hasNormals_; }
  std::optional<uint64_t> count() const override { return vertexCount_; }
  double progress() const override { return vertexCount_ ? double(read_) / double(vertexCount_) : 1.0; }
  PointFormat format() const override { return PointFormat::Ply; }

private:
  // Reads one record of `element`; with `slots`, stores property slots[k] into out[k] (k < 6, slot >= 0).
  void readRecord(const PlyElement& element, const std::string& name, uint64_t index, double* out, const int* slots) {
    const auto where = [&] { return path_ + ": " + name + " " + std::to_string(index); };
    const size_t count = element.properties.size();
    if (values_.size() < count) values_.resize(count);
    if (binary_) {
      unsigned char bytes[8];
      for (size_t p = 0; p < count; ++p) {
        const PlyProperty& property = element.properties[p];
        if (property.list) {
          if (!in_.bytes(bytes, scalarSize(property.countType))) truncated(where());
          const double n = decodeScalar(property.countType, bytes);
          if (n < 0) fail(where() + ": negative list length");
          for (uint64_t i = 0; i < uint64_t(n); ++i)
            if (!in_.bytes(bytes, scalarSize(property.type))) truncated(where());
          values_[p] = 0;
        } else {
          if (!in_.bytes(bytes, scalarSize(property.type))) truncated(where());
          values_[p] = decodeScalar(property.type, bytes);
        }
      }
    } else {
      std::string line;
      for (;;) {
        if (!in_.line(line)) truncated(where());
        if (!trim(line).empty()) break;
      }
      const std::string at = where() + " (line " + std::to_string(in_.lineNumber()) + ")";
      std::string_view rest(line);
      auto token = [&](std::string_view& out) {
        while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
        size_t n = 0;
        while (n < rest.size() && rest[n] != ' ' && rest[n] != '\t') ++n;
        out = rest.substr(0, n);
        rest.remove_prefix(n);
        return n > 0;
      };
      std::string_view word;
      for (size_t p = 0; p < count; ++p) {
        const PlyProperty& property = element.properties[p];
        double value = 0;
        if (!token(word)) fail(at + ": too few values (" + std::to_string(count) + " properties expected)");
        if (!parseDouble(word, value)) fail(at + ": property '" + property.name + "': " + quoted(word) + " is not a number");
        if (property.list) {
          if (!(value >= 0) || value != std::floor(value)) fail(at + ": property '" + property.name + "': bad list length");
          for (uint64_t i = 0; i < uint64_t(value); ++i)
            if (!token(word)) fail(at + ": list '" + property.name + "' is shorter than its length");
          value = 0;
        }
        values_[p] = value;
      }
      if (token(word)) fail(at + ": more values than the " + std::to_string(count) + " properties of the header");
    }
    if (slots)
      for (int k = 0; k < 6; ++k)
        if (slots[k] >= 0) out[k] = values_[size_t(slots[k])];
  }
  [[noreturn]] void truncated(const std::string& where) {
    fail(where + ": the file ends early (the header promises " + std::to_string(vertexCount_) + " vertices)");
  }

  InputFile in_;
  std::string path_;
  bool binary_ = false;
  std::vector<PlyElement> elements_;
  PlyElement vertex_;
  int slot_[6];
  bool hasNormals_ = false;
  uint64_t vertexCount_ = 0, read_ = 0;
  std::vector<double> values_;
};

}  // namespace

PointFormat detectPointFormat(const std::string& path) {
  // A FIFO or device would block the read or never end.
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw Error(ErrorCategory::InvalidInput, path + ": not a regular file (a directory, FIFO or device)");
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw Error(ErrorCategory::InvalidInput, path + ": cannot open: " + std::strerror(errno));
  unsigned char magic[4] = {0, 0, 0, 0};
  const size_t n = std::fread(magic, 1, 4, f);
  std::fclose(f);
  if (n == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01) return PointFormat::Exr;
  if (n == 4 && std::memcmp(magic, "ply", 3) == 0 && (magic[3] == '\n' || magic[3] == '\r')) return PointFormat::Ply;
  return PointFormat::Csv;
}

const char* pointFormatName(PointFormat format) {
  // Indexed by the enum's value (0, 1, 2 in declaration order).
  static constexpr const char* kNames[] = {"csv", "ply", "exr"};
  const size_t i = size_t(format);
  return i < std::size(kNames) ? kNames[i] : "?";
}

std::unique_ptr<PointReader> PointReader::open(const std::string& path) {
  switch (detectPointFormat(path)) {
    case PointFormat::Ply: return std::make_unique<PlyReader>(path);
    case PointFormat::Csv: return std::make_unique<CsvReader>(path);
    case PointFormat::Exr: break;
  }
  throw Error(ErrorCategory::InvalidInput, path + ": an EXR image is not a point list (read it with readExr)");
}

}  // namespace cpvs
