#pragma once
// The former process-local atomic writer is now amctl's one output writer (core/output.hpp):
// a regular file appears whole or not at all; "-", a device or a FIFO is streamed. The alias
// keeps the callers that name it compiling; new code uses amctl::OutputFile.
#include "amctl/core/output.hpp"

namespace amctl::process {

using AtomicFileWriter = amctl::OutputFile;

}  // namespace amctl::process
