#pragma once
// A small, self-contained G-code line reader for the process module (scaling and the
// empirical time estimator). It understands words (letter + number), ';' and '(...)'
// comments, line numbers (N) and checksums (*). A full reader lives in module gcode.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace amctl::process {

struct GcodeWord {
  char letter = 0;       ///< upper case
  double value = 0.0;
  std::string text;      ///< the number as written
};

struct GcodeLine {
  std::vector<GcodeWord> words;
  std::string comment;   ///< text after ';' (without it), or inside '(...)'
  bool has_comment = false;
  [[nodiscard]] const GcodeWord* find(char letter) const;
  /// The command word, e.g. "G1", "M83", or "" when the line has none.
  [[nodiscard]] std::string command() const;
};

/// Parses one line (without its newline). `file` and `line_no` are used in errors, which
/// name file:line:col for a malformed number.
[[nodiscard]] GcodeLine parse_gcode_line(std::string_view line, const std::string& file,
                                         std::uint64_t line_no);

/// Formats a coordinate with at most `decimals` decimals, trailing zeros removed.
[[nodiscard]] std::string format_coord(double v, int decimals);

}  // namespace amctl::process
