#pragma once
// Which kind of file an input is, from its first bytes rather than its name: a baked .cpvs (its magic), a glTF
// scene (.glb's "glTF", or a JSON object), or something else. Every tool checks its inputs with it before
// reading them, so that a .cpvs given where a scene belongs (or the reverse) is named as such, with the
// tool's usage, instead of failing deep inside the wrong reader (docs/cli.md, "Errors").
#include <string>

namespace cpvs::tools {

enum class InputKind { Scene, Cpvs, Unknown };

// Unknown for anything else, an empty file included. Throws Error(InvalidInput) when `path` exists but is no
// regular file (a directory, FIFO or device) or cannot be opened; a path that does not exist is Unknown, left
// to the reader to report.
InputKind sniffInput(const std::string& path);

// Throw Error(InvalidArgument) naming the path, what it is and `usage` ("cpvs-view SCENE FILE.cpvs") when the
// input is of the other kind; anything else is left to the reader, whose message says what is wrong.
void expectScene(const std::string& path, const std::string& usage);
void expectCpvs(const std::string& path, const std::string& usage);
// Query points (CSV, PLY, EXR): a scene or a .cpvs given as points is refused; `option` is "--points".
void expectPoints(const std::string& option, const std::string& path, const std::string& usage);

}  // namespace cpvs::tools
