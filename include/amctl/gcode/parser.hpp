#pragma once
#include <string>
#include <string_view>

#include "amctl/gcode/command.hpp"

namespace amctl::gcode {

/// Why a line could not be parsed: column (1-based) and a message saying what was found
/// and what was expected.
struct ParseIssue {
  std::uint32_t column = 0;
  std::string message;
  [[nodiscard]] bool ok() const { return column == 0 && message.empty(); }
};

/// Splits one line (without its '\n'; a trailing '\r' is tolerated) into command word,
/// arguments and comment. Returns false and fills `issue` on malformed syntax (bad command
/// word, unterminated '(' comment, checksum mismatch).
bool parse_line(std::string_view line, Command& out, ParseIssue& issue);

/// Parses the letter parameters of a word command ("X10 Y-2.5 E.4", "X10Y5"). Every letter
/// must be followed by a finite number. Returns false and fills `issue` otherwise.
bool parse_params(const Command& cmd, Params& out, ParseIssue& issue);

/// Looks up KEY=VALUE (case-insensitive key) in an extended command's args. Returns true and
/// sets `value_text` (raw text, maybe quoted) if present.
bool find_extended_arg(const Command& cmd, std::string_view key, std::string_view& value_text,
                       std::uint32_t& column);

/// A G-code word's number: [+-]digits[.digits], also ".5" and "5.". No exponent: as in
/// Klipper and Marlin a letter ends the number, so "1E5" is 1 (then the word E5). Fast and
/// locale-independent, correctly rounded. Returns the number of characters consumed, 0 if
/// none form a number.
std::size_t parse_number(std::string_view text, double& value);

/// The value of an extended command's KEY=VALUE (Klipper reads it with Python's float()):
/// parse_number's forms plus an exponent, [+-]digits[.digits][(e|E)[+-]digits]. No "inf",
/// "nan" or hexadecimal. Returns the number of characters consumed, 0 if none form a number.
std::size_t parse_float_value(std::string_view text, double& value);

}  // namespace amctl::gcode
