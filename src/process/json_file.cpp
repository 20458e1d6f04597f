#include "amctl/process/json_file.hpp"

#include <cmath>
#include <iterator>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/text_input.hpp"
#include "amctl/process/csv.hpp"

namespace amctl::process {
namespace {

constexpr std::size_t kMaxJsonDepth = 64;

// A character iterator that counts the newlines it has passed, so that the parser callback
// knows on which line the token just read ends.
struct CountingIterator {
  using iterator_category = std::forward_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  const char* p = nullptr;
  std::uint64_t* newlines = nullptr;
  char* last = nullptr;  // the character read last

  reference operator*() const { return *p; }
  CountingIterator& operator++() {
    if (*p == '\n') ++*newlines;
    *last = *p;
    ++p;
    return *this;
  }
  CountingIterator operator++(int) {
    CountingIterator old = *this;
    ++*this;
    return old;
  }
  bool operator==(const CountingIterator& o) const { return p == o.p; }
  bool operator!=(const CountingIterator& o) const { return p != o.p; }
};

std::string escape_token(const std::string& key) {  // RFC 6901
  std::string out;
  for (char c : key) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

}  // namespace

JsonFile JsonFile::read(const std::string& path) {
  return parse(read_whole_text(path, InputOptions{"JSON file", false, 64ull << 20}), path);
}

JsonFile JsonFile::parse(std::string_view text, std::string name) {
  JsonFile f;
  f.name_ = std::move(name);
  struct Frame {
    std::string path;
    bool array = false;
    std::size_t index = 0;
    std::string key;
  };
  std::vector<Frame> stack;
  std::uint64_t newlines = 0;
  char last = 0;
  // The path of the value about to be completed in the innermost container.
  auto slot = [&]() -> std::string {
    if (stack.empty()) return "";
    const Frame& t = stack.back();
    return t.path + "/" + (t.array ? std::to_string(t.index) : escape_token(t.key));
  };
  auto done = [&] {
    if (!stack.empty() && stack.back().array) ++stack.back().index;
  };
  auto note = [&](const std::string& p, std::uint64_t line) { f.line_of_.emplace(p, line); };
  const Json::parser_callback_t cb = [&](int, Json::parse_event_t ev, Json& parsed) {
    switch (ev) {
      case Json::parse_event_t::key:
        stack.back().key = parsed.get<std::string>();
        note(slot(), newlines + 1);
        break;
      case Json::parse_event_t::object_start:
      case Json::parse_event_t::array_start: {
        // amctl's JSON files nest three levels; a bound keeps the memory of the paths (and the
        // parser's) linear in the file whatever it holds.
        if (stack.size() >= kMaxJsonDepth) {
          throw Error(SourceLocation{f.name_, newlines + 1, 0},
                      fmt::format("arrays and objects nested more than {} deep, expected the flat "
                                  "structure of an amctl JSON file",
                                  kMaxJsonDepth));
        }
        const std::string p = slot();
        note(p, newlines + 1);
        stack.push_back(Frame{p, ev == Json::parse_event_t::array_start, 0, {}});
        break;
      }
      case Json::parse_event_t::object_end:
      case Json::parse_event_t::array_end:
        stack.pop_back();
        done();
        break;
      case Json::parse_event_t::value:
        // A number is known only after the character that ends it was read: when that was
        // the newline, the number is on the line before. (For members the key's line, noted
        // first, is kept.)
        note(slot(), newlines + 1 - (parsed.is_number() && last == '\n' ? 1 : 0));
        done();
        break;
    }
    return true;
  };
  const CountingIterator begin{text.data(), &newlines, &last};
  const CountingIterator end{text.data() + text.size(), &newlines, &last};
  try {
    f.root_ = Json::parse(begin, end, cb);
  } catch (const Json::parse_error& e) {
    // e.byte is the 1-based offset of the character where the parser stopped.
    std::uint64_t line = 1;
    std::uint32_t col = 1;
    for (std::size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    std::string what = e.what();
    const std::size_t colon = what.find(": ", what.find("parse error"));
    if (colon != std::string::npos) what = what.substr(colon + 2);
    throw Error(SourceLocation{f.name_, line, col}, "not valid JSON: " + what);
  } catch (const Json::out_of_range& e) {
    // A number beyond the range of a double ("1e400"): thrown once the number was read, so
    // the line counted so far is the number's (or the next one when a newline ended it).
    std::string what = e.what();
    const std::size_t at = what.find("] ");
    if (at != std::string::npos) what = what.substr(at + 2);
    throw Error(SourceLocation{f.name_, newlines + 1 - (last == '\n' ? 1 : 0), 0},
                "not valid JSON: " + what + ", expected a number within the range of a double");
  }
  return f;
}

SourceLocation JsonFile::where(const std::string& pointer) const {
  // The value itself, else the nearest enclosing value that has a known line.
  std::string p = pointer;
  for (;;) {
    const auto it = line_of_.find(p);
    if (it != line_of_.end()) return SourceLocation{name_, it->second, 0};
    const std::size_t slash = p.rfind('/');
    if (slash == std::string::npos) return SourceLocation{name_, 0, 0};
    p.resize(slash);
  }
}

void JsonFile::fail(const std::string& pointer, const std::string& message) const {
  throw Error(where(pointer), message);
}

double JsonFile::number(const std::string& pointer) const {
  const Json::json_pointer jp(pointer);
  const std::string key = pointer.substr(pointer.rfind('/') + 1);
  if (!root_.contains(jp)) fail(pointer, fmt::format("expected a number '{}'", key));
  const Json& v = root_.at(jp);
  if (!v.is_number() || !std::isfinite(v.get<double>())) {
    fail(pointer, fmt::format("'{}' must be a finite number, got {}", key, v.dump()));
  }
  return v.get<double>();
}

}  // namespace amctl::process
