#include "amctl/gcode/words.hpp"

#include "amctl/core/error.hpp"

namespace amctl::gcode {
namespace {
inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
inline bool is_alpha(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
inline char upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c; }
}  // namespace

bool split_words(std::string_view line, const Command& cmd, std::vector<WordSpan>& out,
                 Params& params, ParseIssue& issue) {
  out.clear();
  if (!parse_params(cmd, params, issue)) return false;
  const std::string_view a = cmd.args;
  if (a.empty()) return true;
  AMCTL_CHECK(a.data() >= line.data() && a.data() + a.size() <= line.data() + line.size(),
              "split_words: the command was not parsed from this line");
  const auto base = static_cast<std::size_t>(a.data() - line.data());
  // parse_params() accepted the text, so only its accepted forms remain: blanks, '(...)'
  // comments, and letters followed by blanks and a number, or bare letters.
  std::size_t i = 0;
  while (i < a.size()) {
    const char c = a[i];
    if (is_blank(c)) {
      ++i;
      continue;
    }
    if (c == '(') {
      const std::size_t close = a.find(')', i);
      AMCTL_CHECK(close != std::string_view::npos, "split_words: parse_params accepted '('");
      i = close + 1;
      continue;
    }
    AMCTL_CHECK(is_alpha(c), "split_words: parse_params accepted a non-letter");
    WordSpan w;
    w.letter = upper(c);
    w.letter_offset = static_cast<std::uint32_t>(base + i);
    ++i;
    const std::size_t after_letter = i;
    while (i < a.size() && (a[i] == ' ' || a[i] == '\t')) ++i;
    const std::size_t used = parse_number(a.substr(i), w.value);
    if (used == 0) {
      w.value = 0.0;
      w.number_offset = static_cast<std::uint32_t>(base + after_letter);
      i = after_letter;
    } else {
      w.number_offset = static_cast<std::uint32_t>(base + i);
      w.number_size = static_cast<std::uint32_t>(used);
      i += used;
    }
    out.push_back(w);
  }
  return true;
}

}  // namespace amctl::gcode
