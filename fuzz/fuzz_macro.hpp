#pragma once
// The macro engine under the fuzzer (fuzz_macro_expr.cpp, fuzz_macro_stmt.cpp): a template
// compiled and rendered with globals shaped like Klipper's (params, a printer object, a
// macro's variables) and tight limits, so that every bound is reached within -timeout. The
// only acceptable outcomes are rendered text within the output bound, or a TemplateError
// (LimitError included); anything else (a crash, another exception, a hang, an out-of-memory)
// is a bug.
#include <string>
#include <string_view>

#include "amctl/macro/template.hpp"
#include "amctl/macro/value.hpp"
#include "fuzz_support.hpp"

namespace amctl::fuzz {

inline macro::Dict macro_globals() {
  using macro::Dict;
  using macro::List;
  using macro::Value;
  Dict params;
  params.set("X", Value::string("10.5"));
  params.set("NAME", Value::string("pla"));
  params.set("EMPTY", Value::string(""));
  Dict toolhead;
  toolhead.set("position", Value::list({Value::number(1), Value::number(2), Value::number(3), Value::number(4)}, true));
  toolhead.set("homed_axes", Value::string("xyz"));
  toolhead.set("max_accel", Value::number(3000));
  Dict printer;
  printer.set("toolhead", Value::dict(std::move(toolhead)));
  Dict vars;
  vars.set("count", Value::integer(3));
  vars.set("list", Value::list({Value::integer(1), Value::string("a"), Value::none()}));
  printer.set("gcode_macro M", Value::dict(vars));
  Dict g = vars;
  g.set("params", Value::dict(std::move(params)));
  g.set("rawparams", Value::string("X=10.5 NAME=pla"));
  g.set("printer", Value::dict(std::move(printer)));
  g.set("action_respond_info", Value::function("action_respond_info"));
  g.set("action_raise_error", Value::function("action_raise_error"));
  return g;
}

inline macro::RenderLimits fuzz_limits() {
  macro::RenderLimits lim;
  lim.max_loop_iterations = 20000;
  lim.max_output_bytes = 1 << 16;
  lim.max_range_length = 20000;
  lim.max_string_bytes = 1 << 18;
  lim.max_list_length = 20000;
  lim.max_value_bytes = 1 << 20;
  lim.max_allocated_bytes = 8 << 20;
  lim.max_work = 2'000'000;
  return lim;
}

inline void fuzz_template(std::string_view text) {
  static const macro::Dict globals = macro_globals();
  const macro::RenderLimits lim = fuzz_limits();
  try {
    const macro::Template t = macro::Template::compile(text);
    const std::string out = t.render(globals, lim);
    require(out.size() <= lim.max_output_bytes);
  } catch (const macro::TemplateError& e) {
    require(e.line() >= 1);
  }
  try {  // the same text as a variable_* literal
    (void)macro::parse_literal(text);
  } catch (const macro::TemplateError&) {
  }
}

}  // namespace amctl::fuzz
