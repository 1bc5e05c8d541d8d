#include "tools/common/input_kind.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "libcpvs/base/error.h"

namespace cpvs::tools {
namespace {

std::string whatItIs(InputKind kind) {
  return kind == InputKind::Cpvs ? "a baked .cpvs file" : "a glTF scene";
}

[[noreturn]] void refuse(const std::string& path, InputKind kind, const std::string& expected, const std::string& usage) {
  throw Error(ErrorCategory::InvalidArgument,
              path + " is " + whatItIs(kind) + ", where " + expected + " was expected; usage: " + usage);
}

}  // namespace

InputKind sniffInput(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return InputKind::Unknown;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error(ErrorCategory::InvalidInput, path + ": not a regular file (a directory, FIFO or device)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorCategory::InvalidInput, path + ": cannot open: " + std::strerror(errno));
  char head[64] = {};
  in.read(head, sizeof head);
  const size_t n = size_t(in.gcount());
  const std::string bytes(head, n);
  // The .cpvs magic is 0x89 "CPVS" CR LF ^Z; its name alone still tells where a text-mode transfer damaged
  // the bytes around it.
  if (bytes.substr(0, 8).find("CPVS") != std::string::npos) return InputKind::Cpvs;
  if (bytes.compare(0, 4, "glTF") == 0) return InputKind::Scene;
  size_t i = bytes.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  while (i < n && (bytes[i] == ' ' || bytes[i] == '\t' || bytes[i] == '\r' || bytes[i] == '\n')) ++i;
  if (i < n && bytes[i] == '{') return InputKind::Scene;
  return InputKind::Unknown;
}

void expectScene(const std::string& path, const std::string& usage) {
  if (const InputKind kind = sniffInput(path); kind == InputKind::Cpvs) refuse(path, kind, "a scene (.gltf, .glb)", usage);
}

void expectCpvs(const std::string& path, const std::string& usage) {
  if (const InputKind kind = sniffInput(path); kind == InputKind::Scene) refuse(path, kind, "a baked .cpvs file", usage);
}

void expectPoints(const std::string& option, const std::string& path, const std::string& usage) {
  const InputKind kind = sniffInput(path);
  if (kind == InputKind::Unknown) return;
  throw Error(ErrorCategory::InvalidArgument,
              option + " " + path + " is " + whatItIs(kind) + ", where points (CSV, PLY or EXR) were expected; " +
                  (kind == InputKind::Scene ? "'cpvs-sample SCENE -o points.csv' makes points on a scene's surfaces; "
                                            : "") +
                  "usage: " + usage);
}

}  // namespace cpvs::tools
