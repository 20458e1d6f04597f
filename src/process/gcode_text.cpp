#include "amctl/process/gcode_text.hpp"

#include <cctype>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::process {

const GcodeWord* GcodeLine::find(char letter) const {
  for (const auto& w : words) {
    if (w.letter == letter) return &w;
  }
  return nullptr;
}

std::string GcodeLine::command() const {
  for (const auto& w : words) {
    if (w.letter == 'G' || w.letter == 'M' || w.letter == 'T') return w.letter + w.text;
  }
  return {};
}

GcodeLine parse_gcode_line(std::string_view s, const std::string& file, std::uint64_t line_no) {
  GcodeLine out;
  std::size_t i = 0;
  while (i < s.size()) {
    const char c = s[i];
    if (c == ';') {
      out.comment = std::string(s.substr(i + 1));
      out.has_comment = true;
      break;
    }
    if (c == '(') {
      const std::size_t e = s.find(')', i);
      out.comment = std::string(s.substr(i + 1, (e == std::string_view::npos ? s.size() : e) - i - 1));
      out.has_comment = true;
      i = e == std::string_view::npos ? s.size() : e + 1;
      continue;
    }
    if (c == '*') break;  // checksum ends the command
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
      continue;
    }
    if (!std::isalpha(static_cast<unsigned char>(c))) {
      throw Error(SourceLocation{file, line_no, static_cast<std::uint32_t>(i + 1)},
                  fmt::format("unexpected character '{}' in G-code", c));
    }
    const char letter = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    std::size_t j = i + 1;
    // G-code numbers have no exponent ("X1E5" is X1 then E5).
    while (j < s.size() && (std::isdigit(static_cast<unsigned char>(s[j])) || s[j] == '.' ||
                            s[j] == '-' || s[j] == '+'))
      ++j;
    GcodeWord w;
    w.letter = letter;
    w.text = std::string(s.substr(i + 1, j - i - 1));
    const char* b = w.text.data();
    if (!w.text.empty() && *b == '+') ++b;
    auto [p, ec] = std::from_chars(b, w.text.data() + w.text.size(), w.value);
    if (w.text.empty() || ec != std::errc() || p != w.text.data() + w.text.size() ||
        !std::isfinite(w.value)) {
      throw Error(SourceLocation{file, line_no, static_cast<std::uint32_t>(i + 1)},
                  fmt::format("word '{}' needs a number, got '{}'", letter, w.text));
    }
    if (letter != 'N') out.words.push_back(std::move(w));
    i = j;
  }
  return out;
}

std::string format_coord(double v, int decimals) {
  std::string s = fmt::format("{:.{}f}", v, decimals);
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  return s;
}

}  // namespace amctl::process
