#pragma once
// The inputs of one run of a command (docs/architecture.md, "Inputs and outputs"): when the
// program asks for it (the amctl executable does, at its start), every file the one input reader
// (core/input.hpp) opens is noted, and the one output writer (core/output.hpp) refuses to
// write over any of them, whichever flag named it: a machine file, an [include] of a
// printer.cfg, an accelerometer record, a parameters file are protected as the G-code input is.
// Off by default, so that a long-lived library user (Python) may write a file it read earlier.
#include <vector>

#include "amctl/core/output.hpp"

namespace amctl {

/// From now on, every file opened by InputFile is an input no OutputFile may replace.
void protect_inputs_of_this_run();
/// Called by InputFile for each file it opens (does nothing unless protection is on).
void note_input_of_this_run(const FileIdentity& id);
/// The files noted so far.
[[nodiscard]] std::vector<FileIdentity> inputs_of_this_run();

}  // namespace amctl
