#pragma once
// A Jinja2 template as Klipper reads a macro's `gcode:` (klippy/extras/gcode_macro.py:
// jinja2.Environment('{%', '%}', '{', '}'), so an expression is `{ ... }`, a statement
// `{% ... %}`, a comment `{# ... #}`). Debian 12 has no C++ Jinja library (no inja package), so
// this is a small evaluator of its own: a lexer and parser to a syntax tree (compile) and an
// evaluator over Value (render). The subset it reads is listed in docs/macros.md; anything
// else is a TemplateError naming the template line, never a crash, and every loop and the
// output are bounded.
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

#include "amctl/macro/value.hpp"

namespace amctl::macro {

/// A construct amctl cannot read or evaluate, at `line` (1-based) of the template text.
class TemplateError : public std::runtime_error {
 public:
  TemplateError(std::uint32_t line, const std::string& message)
      : std::runtime_error(message), line_(line) {}
  [[nodiscard]] std::uint32_t line() const { return line_; }

 private:
  std::uint32_t line_;
};

/// Bounds of one render: a template that would exceed them fails with a TemplateError.
struct RenderLimits {
  std::uint64_t max_loop_iterations = 1'000'000;  ///< all `for` iterations of one render
  std::size_t max_output_bytes = 16u << 20;
  std::size_t max_range_length = 1'000'000;       ///< longest range() list
};

namespace detail {
struct Body;
}

class Template {
 public:
  /// Parses `text`. Throws TemplateError at the first construct outside the subset.
  static Template compile(std::string_view text);

  /// Renders with `globals` as the names the template sees (Klipper: the macro's variables,
  /// params, rawparams, printer, action_*). `range` is always there. Throws TemplateError on an
  /// evaluation error (an undefined value in arithmetic, action_raise_error, a limit).
  [[nodiscard]] std::string render(const Dict& globals, const RenderLimits& limits = {}) const;

 private:
  std::shared_ptr<const detail::Body> body_;
};

/// Python's ast.literal_eval of a `variable_*` option or a SET_GCODE_VARIABLE VALUE: numbers,
/// strings, True/False/None, lists, tuples and dicts of them. Throws TemplateError otherwise.
Value parse_literal(std::string_view text);

}  // namespace amctl::macro
