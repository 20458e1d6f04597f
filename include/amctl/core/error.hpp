#pragma once
// amctl's three error channels (see docs/architecture.md):
//  - expected outcomes are status enums returned by the call;
//  - bad user input throws amctl::Error, whose message names where (file:line:col),
//    what was found and what was expected;
//  - our own broken invariants trip AMCTL_CHECK, which is always on and throws
//    amctl::InternalError.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

namespace amctl {

/// A place in an input file. line and column are 1-based; 0 means "unknown".
struct SourceLocation {
  std::string file;
  std::uint64_t line = 0;
  std::uint32_t column = 0;

  /// "file:line:col", "file:line" or "file" depending on what is known.
  [[nodiscard]] std::string to_string() const;
};

/// Bad user input: malformed files, out-of-range parameters, unknown keys.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message);
  Error(const SourceLocation& where, const std::string& message);

  [[nodiscard]] const SourceLocation& where() const noexcept { return where_; }
  /// The message without the location prefix.
  [[nodiscard]] const std::string& detail() const noexcept { return detail_; }

 private:
  SourceLocation where_;
  std::string detail_;
};

/// A broken internal invariant: a bug in amctl, never the user's fault.
class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

[[noreturn]] void fail_check(const char* expr, const char* file, int line, std::string_view msg);

/// Throws amctl::Error naming `what` unless `value` is finite and > 0.
void require_positive(std::string_view what, double value);
/// Throws amctl::Error naming `what` unless `value` is finite and >= 0.
void require_non_negative(std::string_view what, double value);
/// Throws amctl::Error naming `what` unless `value` is finite.
void require_finite(std::string_view what, double value);

}  // namespace amctl

#define AMCTL_CHECK(cond, msg)                                       \
  do {                                                               \
    if (!(cond)) ::amctl::fail_check(#cond, __FILE__, __LINE__, msg); \
  } while (false)
