#include "amctl/core/error.hpp"

#include <cmath>

#include <fmt/format.h>

namespace amctl {

std::string SourceLocation::to_string() const {
  if (line == 0) return file;
  if (column == 0) return fmt::format("{}:{}", file, line);
  return fmt::format("{}:{}:{}", file, line, column);
}

namespace {

/// A message is printed through what() (a C string) and read on a terminal: a NUL byte from
/// the input would cut it there, other control bytes would garble the terminal. They are
/// written as \0, \x01, ... (tab and line feed stay).
std::string printable(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u == 0) {
      out += "\\0";
    } else if ((u < 0x20 && c != '\t' && c != '\n') || u == 0x7f) {
      out += fmt::format("\\x{:02x}", u);
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

Error::Error(const std::string& message) : std::runtime_error(printable(message)), detail_(printable(message)) {}

Error::Error(const SourceLocation& where, const std::string& message)
    : std::runtime_error(printable(where.file.empty() && where.line == 0
                                       ? message
                                       : where.to_string() + ": " + message)),
      where_(where),
      detail_(printable(message)) {}

void fail_check(const char* expr, const char* file, int line, std::string_view msg) {
  throw InternalError(fmt::format("internal error at {}:{}: check '{}' failed: {}", file, line,
                                  expr, msg));
}

namespace {

/// "--flag: must" for a command-line flag (the place, as every flag message names it first),
/// "name must" otherwise.
std::string subject(std::string_view what) {
  return what.substr(0, 2) == "--" ? fmt::format("{}:", what) : std::string(what);
}

}  // namespace

void require_finite(std::string_view what, double value) {
  if (!std::isfinite(value)) {
    throw Error(fmt::format("{} must be a finite number, got {}", subject(what), value));
  }
}

void require_positive(std::string_view what, double value) {
  if (!std::isfinite(value) || value <= 0.0) {
    throw Error(fmt::format("{} must be a finite number > 0, got {}", subject(what), value));
  }
}

void require_non_negative(std::string_view what, double value) {
  if (!std::isfinite(value) || value < 0.0) {
    throw Error(fmt::format("{} must be a finite number >= 0, got {}", subject(what), value));
  }
}

}  // namespace amctl
