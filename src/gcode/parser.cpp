#include "amctl/gcode/parser.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

namespace amctl::gcode {
namespace {

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
inline bool is_digit(char c) { return c >= '0' && c <= '9'; }
inline bool is_alpha(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
inline char upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c; }

std::string printable(std::string_view s) {
  std::string out;
  for (char c : s.substr(0, 40)) {
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) {
      out += fmt::format("\\x{:02x}", static_cast<unsigned char>(c));
    } else {
      out += c;
    }
  }
  if (s.size() > 40) out += "...";
  return out;
}

bool set_issue(ParseIssue& issue, std::size_t index, std::string message) {
  issue.column = static_cast<std::uint32_t>(index + 1);
  issue.message = std::move(message);
  return false;
}

}  // namespace

std::size_t parse_number(std::string_view text, double& value) {
  std::size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) {
    negative = text[i] == '-';
    ++i;
  }
  // Only plain decimal forms: from_chars alone would also accept "inf" and "nan".
  if (i >= text.size() || !(is_digit(text[i]) || (text[i] == '.' && i + 1 < text.size() && is_digit(text[i + 1])))) {
    return 0;
  }
  // G-code numbers have no exponent: Klipper splits a line at every letter and Marlin's
  // value_float() stops at 'E', so "X1E5" is X=1 and E=5 and "Y40E1.5" is Y=40 and E=1.5
  // (docs/gcode.md, "Numbers"). A number is [sign] digits [. digits].
  // Fast path (Clinger): the decimal digits form an integer mantissa below 2^53 and the
  // fraction has at most 22 digits, so the mantissa and 10^k are exact doubles and one IEEE
  // division gives the correctly rounded value, the same as from_chars. At most 19 digits
  // are accumulated, so the uint64 never overflows.
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                      1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
                                      1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const char* p = text.data() + i;
  const char* const end = text.data() + text.size();
  const char* const digits_begin = p;
  std::uint64_t mant = 0;
  while (p < end && is_digit(*p)) mant = mant * 10 + static_cast<std::uint64_t>(*p++ - '0');
  std::ptrdiff_t ndigits = p - digits_begin;
  std::ptrdiff_t frac = 0;
  if (p < end && *p == '.') {
    const char* const frac_begin = ++p;
    while (p < end && is_digit(*p)) mant = mant * 10 + static_cast<std::uint64_t>(*p++ - '0');
    frac = p - frac_begin;
    ndigits += frac;
  }
  double v = 0.0;
  if (ndigits <= 19 && frac <= 22 && mant <= (std::uint64_t{1} << 53)) {
    v = static_cast<double>(mant) / kPow10[frac];
  } else {
    // Long digit strings: the correctly rounded value of exactly these characters (fixed
    // format: from_chars reads no exponent).
    auto [ptr, ec] = std::from_chars(text.data() + i, p, v, std::chars_format::fixed);
    if (ec == std::errc::result_out_of_range) {
      v = HUGE_VAL;  // reported as "not finite" by the caller
    } else if (ec != std::errc() || ptr != p) {
      return 0;
    }
  }
  value = negative ? -v : v;
  return static_cast<std::size_t>(p - text.data());
}

std::size_t parse_float_value(std::string_view text, double& value) {
  const std::size_t mantissa = parse_number(text, value);
  if (mantissa == 0) return 0;
  std::size_t j = mantissa;
  if (j < text.size() && (text[j] == 'e' || text[j] == 'E')) {
    std::size_t k = j + 1;
    if (k < text.size() && (text[k] == '+' || text[k] == '-')) ++k;
    if (k < text.size() && is_digit(text[k])) {
      while (k < text.size() && is_digit(text[k])) ++k;
      // The whole text with its exponent, correctly rounded (sign handled here: from_chars
      // takes no '+').
      const bool negative = text[0] == '-';
      const std::size_t start = (text[0] == '+' || text[0] == '-') ? 1 : 0;
      double v = 0.0;
      auto [ptr, ec] = std::from_chars(text.data() + start, text.data() + k, v,
                                       std::chars_format::scientific);
      if (ec == std::errc::result_out_of_range) {
        // Overflow is reported as "not finite" by the caller; underflow is 0.
        const bool tiny = text[j + 1] == '-';
        v = tiny ? 0.0 : HUGE_VAL;
      } else if (ec != std::errc() || ptr != text.data() + k) {
        return 0;
      }
      value = negative ? -v : v;
      return k;
    }
  }
  return mantissa;
}

bool parse_line(std::string_view line, Command& out, ParseIssue& issue) {
  out = Command{};
  issue = ParseIssue{};
  // Comment after ';' (anywhere, including inside what looks like parameters).
  std::size_t semi = line.find(';');
  std::string_view code = line;
  if (semi != std::string_view::npos) {
    out.comment = line.substr(semi + 1);
    code = line.substr(0, semi);
  }
  // Checksum: "*<digits>" at the end of the code part. Verified against the XOR of the bytes
  // before '*' when present.
  // Almost no line has one: a forward memchr finds that out much faster than rfind's
  // byte-by-byte backward loop, which then only runs on lines that do contain a '*'.
  std::size_t star = code.find('*');
  if (star != std::string_view::npos) star = code.rfind('*');
  if (star != std::string_view::npos) {
    std::size_t k = star + 1;
    while (k < code.size() && is_space(code[k])) ++k;
    std::size_t digits_begin = k;
    // A checksum is one byte; saturate instead of overflowing on a long run of digits (any
    // value above 255 is a mismatch anyway).
    int expected = 0;
    while (k < code.size() && is_digit(code[k])) {
      expected = std::min(expected * 10 + (code[k++] - '0'), 100000);
    }
    std::size_t rest = k;
    while (rest < code.size() && is_space(code[rest])) ++rest;
    if (k == digits_begin || rest != code.size()) {
      return set_issue(issue, star, "expected a checksum (digits) after '*'");
    }
    unsigned char x = 0;
    for (std::size_t j = 0; j < star; ++j) x ^= static_cast<unsigned char>(code[j]);
    if (x != expected) {
      return set_issue(issue, star,
                       fmt::format("checksum mismatch: found *{}, expected *{}", expected, int{x}));
    }
    code = code.substr(0, star);
  }

  std::size_t i = 0;
  const std::size_t n = code.size();
  auto skip_ws = [&] {
    while (i < n) {
      if (is_space(code[i])) {
        ++i;
      } else if (code[i] == '(') {
        std::size_t close = code.find(')', i);
        if (close == std::string_view::npos) return false;
        i = close + 1;
      } else {
        break;
      }
    }
    return true;
  };
  if (!skip_ws()) return set_issue(issue, i, "unterminated '(' comment: expected ')'");
  if (i >= n) return true;  // blank or comment-only line

  // Optional N line number.
  if (upper(code[i]) == 'N' && i + 1 < n && is_digit(code[i + 1])) {
    ++i;
    std::int64_t ln = 0;
    const std::size_t ln_begin = i;
    while (i < n && is_digit(code[i])) {
      if (ln > 100000000000000000) {  // 18 digits: more would overflow std::int64_t
        return set_issue(issue, ln_begin, "line number N is too large");
      }
      ln = ln * 10 + (code[i++] - '0');
    }
    out.line_number = ln;
    if (!skip_ws()) return set_issue(issue, i, "unterminated '(' comment: expected ')'");
    if (i >= n) return true;
  }

  const std::size_t word_begin = i;
  // Klipper's command words may start with '_' (its args_r split takes [A-Z_]+), the usual
  // name of helper macros such as _PURGE_LINE.
  if (!is_alpha(code[i]) && code[i] != '_') {
    return set_issue(issue, i, fmt::format("expected a command (such as G1 or M104), found '{}'",
                                           printable(code.substr(i))));
  }
  // Letter + number (G1, M204, G29.1, T0) or a Klipper extended command word.
  std::size_t j = i + 1;
  while (j < n && is_space(code[j])) ++j;  // "G 1" is tolerated by Marlin
  if (code[i] != '_' && j < n && is_digit(code[j])) {
    char letter = upper(code[i]);
    std::int32_t num = 0;
    std::size_t k = j;
    while (k < n && is_digit(code[k])) {
      if (num > 100000000) return set_issue(issue, j, "command number is too large");
      num = num * 10 + (code[k++] - '0');
    }
    std::int32_t sub = -1;
    if (k < n && code[k] == '.' && k + 1 < n && is_digit(code[k + 1])) {
      ++k;
      sub = 0;
      while (k < n && is_digit(code[k]) && sub < 100000000) sub = sub * 10 + (code[k++] - '0');
    }
    // A word like "G1X" is fine; "G1abc" with a letter directly after is parameters too.
    out.kind = CommandKind::word;
    out.letter = letter;
    out.code = num;
    out.subcode = sub;
    out.name = code.substr(word_begin, k - word_begin);
    i = k;
  } else {
    std::size_t k = i;
    while (k < n && (is_alpha(code[k]) || is_digit(code[k]) || code[k] == '_')) ++k;
    if (k - i < 2) {
      return set_issue(issue, i, fmt::format("expected a command (such as G1 or M104), found '{}'",
                                             printable(code.substr(i))));
    }
    out.kind = CommandKind::extended;
    out.name = code.substr(i, k - i);
    i = k;
  }
  while (i < n && is_space(code[i])) ++i;
  std::size_t end = n;
  while (end > i && is_space(code[end - 1])) --end;
  out.args = code.substr(i, end - i);
  out.args_column = static_cast<std::uint32_t>(i + 1);
  return true;
}

bool parse_params(const Command& cmd, Params& out, ParseIssue& issue) {
  out.present = 0;
  out.bare = 0;
  issue = ParseIssue{};
  std::string_view a = cmd.args;
  const std::size_t base = cmd.args_column - 1;
  std::size_t i = 0;
  const std::size_t n = a.size();
  while (i < n) {
    char c = a[i];
    if (is_space(c)) {
      ++i;
      continue;
    }
    if (c == '(') {
      std::size_t close = a.find(')', i);
      if (close == std::string_view::npos) {
        return set_issue(issue, base + i, "unterminated '(' comment: expected ')'");
      }
      i = close + 1;
      continue;
    }
    if (!is_alpha(c)) {
      return set_issue(issue, base + i,
                       fmt::format("expected a parameter letter (such as X or F), found '{}'",
                                   printable(a.substr(i))));
    }
    const char l = upper(c);
    const std::size_t letter_pos = i;
    ++i;
    const std::size_t after_letter = i;
    while (i < n && (a[i] == ' ' || a[i] == '\t')) ++i;
    double v = 0.0;
    std::size_t used = parse_number(a.substr(i), v);
    if (used == 0) {
      // A bare letter ("G28 X Y") means "flag present" with value 0, as firmware treats it;
      // a letter glued to a non-number ("Xnan") is an error.
      if (i >= n || a[i] == '(' || (i > after_letter && is_alpha(a[i]))) {
        v = 0.0;
        out.bare |= 1u << static_cast<unsigned>(l - 'A');
      } else {
        return set_issue(issue, base + i,
                         fmt::format("expected a number after '{}', found '{}'", l,
                                     printable(a.substr(i))));
      }
    } else {
      if (!std::isfinite(v)) {
        return set_issue(issue, base + i,
                         fmt::format("value of '{}' is out of range: '{}'", l,
                                     printable(a.substr(i, used))));
      }
      i += used;
      if (i < n && !(is_space(a[i]) || is_alpha(a[i]) || a[i] == '(')) {
        return set_issue(issue, base + i,
                         fmt::format("malformed number after '{}': unexpected '{}'", l,
                                     printable(a.substr(i))));
      }
    }
    const auto idx = static_cast<std::size_t>(l - 'A');
    out.value[idx] = v;
    out.column[idx] = static_cast<std::uint32_t>(base + letter_pos + 1);
    out.present |= (1u << idx);
  }
  return true;
}

bool find_extended_arg(const Command& cmd, std::string_view key, std::string_view& value_text,
                       std::uint32_t& column) {
  // A key given twice takes its last value, as Klipper's dict of the parameters does
  // (gcode.py: {k.upper(): v for k, v in eparams}).
  bool found = false;
  std::string_view a = cmd.args;
  std::size_t i = 0;
  while (i < a.size()) {
    while (i < a.size() && is_space(a[i])) ++i;
    std::size_t k = i;
    while (k < a.size() && a[k] != '=' && !is_space(a[k])) ++k;
    std::string_view name = a.substr(i, k - i);
    std::size_t v = k;
    if (k < a.size() && a[k] == '=') {
      v = k + 1;
      std::size_t e = v;
      if (e < a.size() && a[e] == '"') {
        std::size_t close = a.find('"', e + 1);
        e = close == std::string_view::npos ? a.size() : close + 1;
      } else {
        while (e < a.size() && !is_space(a[e])) ++e;
      }
      bool match = name.size() == key.size();
      for (std::size_t q = 0; match && q < key.size(); ++q) match = upper(name[q]) == upper(key[q]);
      if (match) {
        value_text = a.substr(v, e - v);
        column = static_cast<std::uint32_t>(cmd.args_column + v);
        found = true;
      }
      i = e;
    } else {
      i = k;
    }
  }
  return found;
}

}  // namespace amctl::gcode
