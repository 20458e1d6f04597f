// Rendering a PRINT_START-style macro (set, if, for, filters, printer fields): what one macro
// call costs before its lines run.
#include <benchmark/benchmark.h>

#include "amctl/macro/template.hpp"

namespace {

void BM_MacroRenderPrintStart(benchmark::State& state) {
  using amctl::macro::Dict;
  using amctl::macro::Value;
  const auto t = amctl::macro::Template::compile(
      "{% set bed = params.BED|default(60)|float %}\n"
      "{% set hotend = params.EXTRUDER|default(210)|float %}\n"
      "M140 S{bed}\n"
      "{% if 'xyz' not in printer.toolhead.homed_axes %}G28{% endif %}\n"
      "M190 S{bed}\n"
      "{% for i in range(10) %}G1 X{printer.toolhead.axis_minimum.x + i * 10} Y5 E{(i * 0.4)|round(3)} F3000\n{% endfor %}\n"
      "M109 S{hotend}\n");
  Dict th;
  th.set("homed_axes", Value::string(""));
  th.set("axis_minimum", Value::list({Value::number(0), Value::number(0), Value::number(0),
                                      Value::number(0)}, true));
  Dict printer;
  printer.set("toolhead", Value::dict(th));
  Dict params;
  params.set("BED", Value::string("100"));
  params.set("EXTRUDER", Value::string("245"));
  Dict g;
  g.set("printer", Value::dict(printer));
  g.set("params", Value::dict(params));
  std::size_t bytes = 0;
  for (auto _ : state) {
    const std::string out = t.render(g);
    bytes = out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["output_bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_MacroRenderPrintStart)->Unit(benchmark::kMicrosecond);

}  // namespace
