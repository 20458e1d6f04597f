#pragma once
// The lexer of the interpreter's fast path (docs/gcode.md, "Fast path"). Internal to the
// gcode module: everything here is inline so that Interpreter::feed() keeps the whole plain
// G0/G1 path in one function, as before the split (issue 13): with external linkage GCC no
// longer inlines a function merely because it is called once, hence always_inline.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>

namespace amctl::gcode::detail {

/// The plain-move lexer of the fast path: "G0"/"G1", then only X Y Z E F words with plain
/// decimal numbers, spaces and an optional ';' comment. Anything else (N, '*', '(', other
/// letters, exponents, a repeated letter, a number not exactly representable by Clinger's
/// rule) returns false and the line goes through the general parser, which alone reports
/// errors. Values are computed exactly as parse_number() does, so both paths give the same
/// doubles.
struct PlainMove {
  std::array<double, 5> value{};  // X Y Z E F
  unsigned present = 0;           // bit i: value[i] given
  std::string_view comment;
  bool has_comment = false;
};

[[gnu::always_inline]] inline int plain_axis(char c) {
  switch (c) {
    case 'X': case 'x': return 0;
    case 'Y': case 'y': return 1;
    case 'Z': case 'z': return 2;
    case 'E': case 'e': return 3;
    case 'F': case 'f': return 4;
    default: return -1;
  }
}

/// Copies line[0, n) (3 <= n <= 64) into buf, whose bytes from n on are zero, with fixed-size
/// (overlapping) copies the compiler turns into a few vector moves.
[[gnu::always_inline]] inline void copy_short(char* buf, const char* s, std::size_t n) {
  if (n >= 32) {
    std::memcpy(buf, s, 32);
    std::memcpy(buf + n - 32, s + n - 32, 32);
  } else if (n >= 16) {
    std::memcpy(buf, s, 16);
    std::memcpy(buf + n - 16, s + n - 16, 16);
  } else if (n >= 8) {
    std::memcpy(buf, s, 8);
    std::memcpy(buf + n - 8, s + n - 8, 8);
  } else {
    for (std::size_t i = 0; i < n; ++i) buf[i] = s[i];
  }
}

[[gnu::always_inline]] inline bool lex_plain_move(std::string_view line, PlainMove& out) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                      1e16, 1e17, 1e18, 1e19};
  const std::size_t n = line.size();
  if (n < 3 || (line[0] != 'G' && line[0] != 'g') || (line[1] != '0' && line[1] != '1') ||
      (line[2] != ' ' && line[2] != '\t')) {
    return false;
  }
  // The lexer reads a zero-padded copy of the code part of the line (at most 64 bytes, up to
  // a ';' comment on longer lines), so its loops need no bounds checks. A NUL anywhere but at
  // the copy's end (a NUL byte in the file) hands the line to the general parser; a comment
  // is taken from the line itself.
  constexpr std::size_t kMaxCode = 64;
  std::size_t code = n;
  if (n > kMaxCode) {
    const void* semi = std::memchr(line.data(), ';', kMaxCode + 1);
    if (semi == nullptr) return false;
    code = static_cast<std::size_t>(static_cast<const char*>(semi) - line.data());
  }
  alignas(16) char buf[kMaxCode + 16] = {};  // zeros past the copy end every loop
  copy_short(buf, line.data(), code);
  const char* p = buf + 3;
  for (;;) {
    while (*p == ' ' || *p == '\t') ++p;
    if (*p == '\0') {
      const auto at = static_cast<std::size_t>(p - buf);
      if (at != code) return false;
      if (code < n) {
        out.comment = line.substr(code + 1);
        out.has_comment = true;
      }
      return true;
    }
    if (*p == ';') {
      out.comment = line.substr(static_cast<std::size_t>(p - buf) + 1);
      out.has_comment = true;
      return true;
    }
    const int axis = plain_axis(*p);
    if (axis < 0 || ((out.present >> axis) & 1u)) return false;
    ++p;
    bool negative = false;
    if (*p == '-' || *p == '+') negative = *p++ == '-';
    std::uint64_t mant = 0;
    const char* const int_begin = p;
    while (static_cast<unsigned>(*p - '0') < 10u) mant = mant * 10 + static_cast<unsigned>(*p++ - '0');
    std::ptrdiff_t ndigits = p - int_begin;
    std::ptrdiff_t frac = 0;
    if (*p == '.') {
      const char* const frac_begin = ++p;
      while (static_cast<unsigned>(*p - '0') < 10u) mant = mant * 10 + static_cast<unsigned>(*p++ - '0');
      frac = p - frac_begin;
      ndigits += frac;
    }
    if (ndigits == 0 || ndigits > 19 || mant > (std::uint64_t{1} << 53)) return false;
    if (*p != ' ' && *p != '\t' && *p != ';' && *p != '\0') return false;
    const double v = static_cast<double>(mant) / kPow10[frac];
    out.value[static_cast<std::size_t>(axis)] = negative ? -v : v;
    out.present |= 1u << axis;
  }
}

}  // namespace amctl::gcode::detail
