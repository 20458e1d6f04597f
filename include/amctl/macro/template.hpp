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

/// A template that exceeds one of amctl's bounds (RenderLimits, the nesting and size limits
/// below): not a construct to skip but an error of the run, at the template line.
class LimitError : public TemplateError {
 public:
  using TemplateError::TemplateError;
};

/// Bounds of compiling a template (docs/macros.md, "Limits").
inline constexpr std::size_t kMaxTemplateBytes = 1u << 20;  ///< the text of one template
inline constexpr std::uint32_t kMaxNesting = 200;  ///< expressions and statements inside each other,
                                                   ///< chains (a|f|f, a.b.c, 1+1+1) counted per link

/// Bounds of one render (and of one expansion, with the macros it calls): a template that
/// would exceed them fails with a LimitError naming the bound. Every one is far above what a
/// printer macro does; each stops a template that would hang or take the memory instead.
struct RenderLimits {
  std::uint64_t max_loop_iterations = 1'000'000;  ///< all `for` iterations of one render
  std::size_t max_output_bytes = 16u << 20;       ///< the text one render produces
  std::size_t max_range_length = 1'000'000;       ///< longest range() list
  std::size_t max_string_bytes = 16u << 20;       ///< longest string
  std::size_t max_list_length = 1'000'000;        ///< most items of one list or dict
  /// Largest value, counted as it would print: every string byte and 16 bytes per item, a
  /// list shared by several others counted each time (so [a, a] doubling in a loop stops).
  std::uint64_t max_value_bytes = 64ull << 20;
  /// Memory: the strings and lists one render builds, in total (a bound on what it can hold).
  std::uint64_t max_allocated_bytes = 256ull << 20;
  /// Work: expression nodes evaluated, items and bytes compared, scanned or copied.
  std::uint64_t max_work = 200'000'000;
  /// One macro call with the macros it calls, and theirs: renders in all ...
  std::uint64_t max_calls_per_expansion = 100'000;
  /// ... and the G-code text they produce in all.
  std::uint64_t max_expansion_bytes = 64ull << 20;
};

namespace detail {
struct Body;
}

class Template {
 public:
  /// Parses `text`. Throws TemplateError at the first construct outside the subset, LimitError
  /// when the text is longer than kMaxTemplateBytes or nests deeper than kMaxNesting.
  static Template compile(std::string_view text);

  /// Renders with `globals` as the names the template sees (Klipper: the macro's variables,
  /// params, rawparams, printer, action_*). `range` is always there. Throws TemplateError on an
  /// evaluation error (an undefined value in arithmetic, action_raise_error), LimitError on a
  /// bound of `limits`.
  [[nodiscard]] std::string render(const Dict& globals, const RenderLimits& limits = {}) const;

 private:
  std::shared_ptr<const detail::Body> body_;
};

/// Python's ast.literal_eval of a `variable_*` option or a SET_GCODE_VARIABLE VALUE: numbers,
/// strings, True/False/None, lists, tuples and dicts of them. Throws TemplateError otherwise.
Value parse_literal(std::string_view text);

}  // namespace amctl::macro
