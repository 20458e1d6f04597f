#pragma once
// A whole text input (TOML, printer.cfg, M503 output, JSON, CSV): read_whole_input() of
// core/input.hpp, with a UTF-8 byte-order mark dropped and UTF-16 refused at 1:1 (naming the
// encoding and how to convert it). Binary formats (STL) use read_whole_input() itself.
#include <string>

#include "amctl/core/input.hpp"

namespace amctl {

[[nodiscard]] std::string read_whole_text(const std::string& path, InputOptions options = {});

}  // namespace amctl
