#pragma once
// The letter parameters of a word command with the bytes they occupy in the line, for tools
// that rewrite some numbers of a line and copy every other byte unchanged (shrinkage
// compensation rewrites X/Y/Z/E/I/J/K/R of moves). The rules are parse_params()'s: the words
// are only split after parse_params() accepted the line, with the same number parser.
#include <cstdint>
#include <string_view>
#include <vector>

#include "amctl/gcode/command.hpp"
#include "amctl/gcode/parser.hpp"

namespace amctl::gcode {

struct WordSpan {
  char letter = 0;                  ///< upper case
  std::uint32_t letter_offset = 0;  ///< 0-based byte offset of the letter in the line
  std::uint32_t number_offset = 0;  ///< 0-based byte offset of the number
  std::uint32_t number_size = 0;    ///< bytes of the number; 0 for a bare letter ("G28 X")
  double value = 0.0;               ///< 0 for a bare letter

  [[nodiscard]] bool bare() const { return number_size == 0; }
};

/// Splits the parameters of `cmd`, which parse_line() produced from `line`, into words in
/// the order written, with offsets into `line`. Returns false and fills `issue` (column in
/// `line`) when parse_params() rejects them. `params` receives parse_params()'s result.
bool split_words(std::string_view line, const Command& cmd, std::vector<WordSpan>& out,
                 Params& params, ParseIssue& issue);

}  // namespace amctl::gcode
