#pragma once
// Slicer annotations read from comments: layer changes, feature names, the slicer's own time
// estimate and its name (PrusaSlicer/SuperSlicer, Cura, OrcaSlicer/Bambu, ideaMaker).
// Internal to the gcode module; the result is the public amctl::gcode::Annotations.
#include <cstdint>
#include <optional>
#include <string_view>

#include "amctl/gcode/interpreter.hpp"

namespace amctl::gcode::detail {

/// Reads one comment (the text after ';') of line `line_no` into `notes`. Returns true when
/// the comment marks a new layer (notes.layer has then been advanced).
bool read_annotation(std::string_view comment, std::uint64_t line_no, Annotations& notes);

/// Makes `name` (trimmed) the current feature, adding it to notes.feature_names if new.
void set_feature(Annotations& notes, std::string_view name);

/// "1d 2h 47m 50s", "1h 47m 50s", "11m 18s", "50s" -> seconds; nullopt if not that form.
std::optional<double> parse_dhms(std::string_view s);

}  // namespace amctl::gcode::detail
