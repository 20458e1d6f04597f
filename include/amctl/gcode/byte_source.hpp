#pragma once
// A stream of bytes that G-code text is read from: the project's one byte source
// (core/input.hpp), named here for the G-code readers and the decoders of formats/.
#include "amctl/core/input.hpp"

namespace amctl::gcode {

using ByteSource = amctl::ByteSource;

}  // namespace amctl::gcode
