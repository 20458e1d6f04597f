#include "amctl/core/error.hpp"

#include <cmath>

#include <fmt/format.h>

namespace amctl {

std::string SourceLocation::to_string() const {
  if (line == 0) return file;
  if (column == 0) return fmt::format("{}:{}", file, line);
  return fmt::format("{}:{}:{}", file, line, column);
}

Error::Error(const std::string& message) : std::runtime_error(message), detail_(message) {}

Error::Error(const SourceLocation& where, const std::string& message)
    : std::runtime_error(where.file.empty() && where.line == 0
                             ? message
                             : where.to_string() + ": " + message),
      where_(where),
      detail_(message) {}

void fail_check(const char* expr, const char* file, int line, std::string_view msg) {
  throw InternalError(fmt::format("internal error at {}:{}: check '{}' failed: {}", file, line,
                                  expr, msg));
}

void require_finite(std::string_view what, double value) {
  if (!std::isfinite(value)) {
    throw Error(fmt::format("{} must be a finite number, got {}", what, value));
  }
}

void require_positive(std::string_view what, double value) {
  if (!std::isfinite(value) || value <= 0.0) {
    throw Error(fmt::format("{} must be a finite number > 0, got {}", what, value));
  }
}

void require_non_negative(std::string_view what, double value) {
  if (!std::isfinite(value) || value < 0.0) {
    throw Error(fmt::format("{} must be a finite number >= 0, got {}", what, value));
  }
}

}  // namespace amctl
