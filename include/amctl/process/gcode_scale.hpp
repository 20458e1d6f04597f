#pragma once
// Compensating a sliced part: rewrite the coordinates of G0/G1/G2/G3 moves through a
// ScaleMap. Because the Z map is a continuous increasing function, every move of one layer
// gets the same new Z and the layer order is kept. Extrusion is rescaled with the path:
// E per move is multiplied by (new XY length / old XY length) * dZ'/dZ (the layer height
// grows with the local Z factor), so the bead cross-section stays what the slicer planned.
//
// Lines are read and split by the gcode module (LineReader, parse_line, split_words), with
// the interpreter's rules for the modal state: G20/G21 units, G90/G91, M82/M83 (E is
// relative under G91 or M83), G92 and G28 positions, SET_KINEMATIC_POSITION. Only the numbers
// of the X/Y/Z/E/I/J/K/R words of moves are replaced; every other byte of a line, and every
// line that is not a move, is copied unchanged (PrusaSlicer's ";Z:" layer annotations are
// the one exception: they are mapped like the moves' Z so that they stay in step).
#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/input.hpp"
#include "amctl/gcode/command.hpp"
#include "amctl/gcode/parser.hpp"
#include "amctl/gcode/words.hpp"
#include "amctl/process/scale_map.hpp"

namespace amctl::process {

struct GcodeScaleOptions {
  bool scale_extrusion = true;
  /// Decimals written for the X/Y/Z/I/J/K/R and the E numbers that change (trailing zeros
  /// removed).
  int xyz_decimals = 4;
  int e_decimals = 5;
};

struct GcodeScaleReport {
  std::uint64_t lines = 0;
  std::uint64_t moves_rewritten = 0;       ///< move lines whose text changed
  std::uint64_t arcs = 0;
  std::uint64_t layers = 0;                ///< distinct Z values of extruding moves
  double max_arc_radius_mismatch_mm = 0;   ///< |r_start - r_end| after an anisotropic map
  std::array<double, 3> extrusion_min_mm{}, extrusion_max_mm{};    ///< before
  std::array<double, 3> scaled_min_mm{}, scaled_max_mm{};          ///< after
  double extruded_mm = 0, scaled_extruded_mm = 0;                  ///< total filament
};

/// Rewrites a G-code stream one line at a time (bounded memory). Positions are tracked in
/// mm like gcode::Interpreter: for the input file and, separately, for the file written, so
/// that G92 offsets, homing and relative moves stay right in the output.
class GcodeScaler {
 public:
  GcodeScaler(ScaleMap map, GcodeScaleOptions options, std::string file);

  /// Rewrites one line (without its terminator), appending the result to `out`. Throws
  /// amctl::Error "file:line:col: ..." for what the interpreter rejects (malformed words,
  /// bare letters in a move) and for R-form arcs the map cannot keep circular.
  void feed(std::string_view line, std::uint64_t line_no, std::string& out);

  /// The report so far (empty extents are zeros when nothing extruded).
  [[nodiscard]] GcodeScaleReport report() const;
  /// True once an extruding XY move was seen.
  [[nodiscard]] bool extruded() const { return !layer_z_.empty(); }

 private:
  void move(const gcode::Command& cmd, std::string_view line, std::uint64_t line_no,
            std::string& out);
  [[nodiscard]] double map_axis(int axis, double v_mm) const {
    return map_.origin_mm[axis] + map_.axes[axis].map(v_mm - map_.origin_mm[axis]);
  }
  /// Formats `v` (in the file's units) and returns the value the text stands for.
  double format(double v, int decimals, std::string& text) const;
  [[nodiscard]] std::vector<gcode::WordSpan>& words(const gcode::Command& cmd,
                                                    std::string_view line,
                                                    std::uint64_t line_no);

  ScaleMap map_;
  GcodeScaleOptions opt_;
  std::string file_;
  // Modal state, as gcode::Interpreter keeps it.
  double unit_mm_ = 1.0;  // 25.4 after G20
  bool absolute_xyz_ = true;
  bool absolute_e_ = true;
  int arc_plane_ = 17;
  // Machine and file ("gcode") positions X Y Z E in mm, of the input and of the output.
  std::array<double, 4> in_pos_{}, in_gcode_{}, out_pos_{}, out_gcode_{};
  std::set<double> layer_z_;
  GcodeScaleReport rep_;
  // Scratch buffers reused for every line.
  gcode::Command cmd_;
  gcode::ParseIssue issue_;
  gcode::Params params_;
  std::vector<gcode::WordSpan> words_;
  std::string line_out_;
};

/// Extent of the extruding moves of a file (used to pick a default origin); throws
/// amctl::Error when nothing extrudes.
struct GcodeExtent {
  std::array<double, 3> min_mm{}, max_mm{};
};
[[nodiscard]] GcodeExtent gcode_extrusion_extent(const std::string& path);
/// Same over an input already open (rewound first when read before).
[[nodiscard]] GcodeExtent gcode_extrusion_extent(InputFile& input);

/// Streams `input` through a GcodeScaler into `output` (amctl::OutputFile: a regular file
/// appears only when everything was written; never over the input). Line terminators (LF,
/// CR LF, a lone CR, none at the end) are kept as they were.
GcodeScaleReport scale_gcode_file(const std::string& input, const std::string& output,
                                  const ScaleMap& map, const GcodeScaleOptions& options);
/// Same over an input already open (rewound first when read before: the extent pass).
GcodeScaleReport scale_gcode_file(InputFile& input, const std::string& output, const ScaleMap& map,
                                  const GcodeScaleOptions& options);

/// Formats a coordinate with at most `decimals` decimals, trailing zeros removed ("-0" -> "0").
[[nodiscard]] std::string format_coord(double v, int decimals);

}  // namespace amctl::process
