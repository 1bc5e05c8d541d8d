#pragma once
// What a tool says when CLI11 refuses its command line: the tool's name first, an unknown option named before
// anything else with the nearest known one suggested, and a positional argument that no slot took named as
// such (docs/cli.md, "Errors"). CLI11 alone, so that cpvs-scenegen, which keeps apart from the library, can use
// it too.
#include <string>

#include <CLI/CLI.hpp>

namespace cpvs::tools {

// The known option nearest to `typed` ("--sunn" -> "--sun", "--res" -> "--resolution"), or "" when none is
// near enough to be a likely slip. Several equally near ones are joined by " or ".
std::string nearestOption(const CLI::App& app, const std::string& typed);

// "cpvs-view SCENE FILE.cpvs": the tool's name and its positional arguments, as --help names them.
std::string positionalUsage(const CLI::App& app);

// The message for a parse error that is no success (not --help or --version), without the tool's name; e.g.
// "unknown option --sunn (did you mean --sun?)".
std::string describeParseError(const CLI::App& app, const CLI::ParseError& error);

// Prints --help or --version (exit 0), or "TOOL: error: ..." and a pointer to --help (exit 1).
int reportParseError(CLI::App& app, const CLI::ParseError& error);

}  // namespace cpvs::tools
