#pragma once
// MeatPack decoding, as binary G-code blocks with encoding 1 (MeatPack) and 2 (MeatPack
// keeping comment lines) carry it.
//
// MeatPack packs the 15 most frequent G-code characters into 4-bit codes, two per byte, low
// nibble first:
//   0-9 -> '0'..'9', 10 '.', 11 ' ' (or 'E' once "no spaces" is on), 12 '\n', 13 'G', 14 'X',
//   15: this character is not packed; it follows as a whole byte.
// When both nibbles are 15 two whole bytes follow; when only the low one is, the whole byte
// comes first and then the high nibble's character. A '\n' in the low nibble ends the line
// and the high nibble is padding. Control sequences are 0xFF 0xFF and a command byte:
// 251 packing on, 250 packing off (the bytes that follow are plain text, as comment lines are
// written), 249 reset (packing off), 248 query (ignored), 247 "no spaces" on, 246 off.
//
// The writer drops the spaces of G lines (G1X10Y5E.2); the decoder writes them back before
// each parameter letter (X Y Z E F I J R S G P W H C A) of a line that starts with G and a
// digit, and drops empty lines, so that the text is what Prusa's bgcode tool gives when it
// converts the file back to text (checked against its own test files, tests/formats/).
//
// Streaming: decode() takes any slice of a block and appends at most 3 characters per input
// byte; each block starts fresh (reset()).
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace amctl::formats {

class MeatPackDecoder {
 public:
  /// A new block: packing off, "no spaces" off, no pending byte.
  void reset();
  /// Decodes `in` and appends the text to `out`.
  void decode(std::span<const std::uint8_t> in, std::string& out);
  /// True if the block ended in the middle of a packed pair or a control sequence.
  [[nodiscard]] bool pending() const { return whole_bytes_due_ > 0 || held_ != 0 || signal_ > 0 || command_due_; }

 private:
  void byte(std::uint8_t b, std::string& out);
  void emit(char c, std::string& out);
  [[nodiscard]] char unpack(unsigned code) const;

  bool packing_ = false;
  bool no_spaces_ = false;
  int signal_ = 0;            // 0xFF bytes seen that may start a control sequence
  bool command_due_ = false;  // 0xFF 0xFF seen: the next byte is a command
  int whole_bytes_due_ = 0;   // unpacked characters that follow as whole bytes
  char held_ = 0;             // high-nibble character waiting for the whole byte before it
  char last_ = 0;             // last character written in this block (0: none yet)
  enum class Line : std::uint8_t { start, after_g, g_command, other };
  Line line_ = Line::start;   // what the line being written is so far
};

}  // namespace amctl::formats
