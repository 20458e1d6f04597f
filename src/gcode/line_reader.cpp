#include "amctl/gcode/line_reader.hpp"

namespace amctl::gcode {

InputOptions gcode_input_options(bool rewindable) {
  InputOptions o;
  o.what = "G-code file";
  o.rewindable = rewindable;
  return o;
}

}  // namespace amctl::gcode
