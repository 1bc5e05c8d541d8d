#pragma once
// A tool's command line from Python keywords: cpvs.bake and cpvs.preview take their tool's options as keywords
// (voxel_size=0.5 is --voxel-size 0.5) and parse them with the tool's own CLI11 definitions.
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace cpvs::python {

// A value as its flag takes it: a list or tuple joined with commas, anything else as str() gives it.
std::string optionText(pybind11::handle value);

// Appends each keyword as its flag: underscores become dashes; True gives a bare flag, False and None nothing;
// a list repeats the flag per item (exclude_mesh=["a", "b"]). A keyword in `refused` (flags the function sets
// itself or that make no sense there) raises cpvs.ArgumentError naming `function`.
void appendOptionFlags(std::vector<std::string>& args, const pybind11::kwargs& options,
                       const std::vector<std::string>& refused, const std::string& function);

// Parses `args` (args[0] the program name) into `app`; CLI11's message as cpvs.ArgumentError naming `function`.
void parseOptionFlags(CLI::App& app, const std::vector<std::string>& args, const std::string& function);

}  // namespace cpvs::python
