#pragma once
// One parsed G-code line. The parser is allocation-free: every string_view points into the
// line buffer given to parse_line(), valid until that buffer changes.
//
// Accepted syntax (RepRap wiki / NIST RS274): optional "N<int>" line number, a command word
// (letter + number such as G1, M204, T0, G29.1; or a Klipper extended command such as
// SET_VELOCITY_LIMIT), parameters as letter+number with or without spaces (G1X10Y5), Klipper
// KEY=VALUE parameters, ';' comments to end of line, '(...)' inline comments, an optional
// "*<checksum>" (XOR of the bytes before '*'), any letter case, CR LF line ends.
#include <array>
#include <cstdint>
#include <string_view>

namespace amctl::gcode {

enum class CommandKind : std::uint8_t {
  none,      ///< blank line or comment only
  word,      ///< letter + number: G1, M204, T0, G29.1
  extended,  ///< Klipper-style NAME [KEY=VALUE ...]
};

struct Command {
  CommandKind kind = CommandKind::none;
  char letter = 0;          ///< 'G', 'M', 'T' (upper case) for kind == word
  std::int32_t code = -1;   ///< number after the letter (1 for G1)
  std::int32_t subcode = -1;  ///< number after the dot (1 for G29.1), -1 if none
  std::string_view name;    ///< upper-cased is not guaranteed; the raw command word
  std::string_view args;    ///< everything after the command word, comments removed
  std::string_view comment; ///< text after ';' (without the ';'), empty if none
  std::uint32_t args_column = 0;  ///< 1-based column of args.front()
  std::int64_t line_number = -1;  ///< N word, -1 if absent

  [[nodiscard]] bool is(char l, int c) const { return kind == CommandKind::word && letter == l && code == c; }
};

/// Numeric letter parameters of a word command, parsed on demand (unknown commands are never
/// parsed, so M117 text or macros cannot raise spurious errors).
struct Params {
  std::array<double, 26> value{};
  std::array<std::uint32_t, 26> column{};  ///< 1-based column of the letter
  std::uint32_t present = 0;               ///< bit i set if letter 'A'+i was given
  std::uint32_t bare = 0;                  ///< bit i set if the letter had no number ("G28 X")

  [[nodiscard]] bool has(char l) const { return (present >> (l - 'A')) & 1u; }
  [[nodiscard]] double get(char l) const { return value[static_cast<std::size_t>(l - 'A')]; }
  [[nodiscard]] double get_or(char l, double fallback) const { return has(l) ? get(l) : fallback; }
  [[nodiscard]] bool empty() const { return present == 0; }
};

}  // namespace amctl::gcode
