#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/gcode/parser.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

bool is_m73(std::string_view line) {
  gcode::Command c;
  gcode::ParseIssue issue;
  return gcode::parse_line(line, c, issue) && c.is('M', 73);
}

}  // namespace

std::size_t write_m73(const GcodeInput& input, const std::string& output_path,
                      const EstimateReport& report) {
  for (const char* binary : {".bgcode", ".3mf", ".gz"}) {
    if (output_path.ends_with(binary)) {
      throw Error(SourceLocation{output_path, 0, 0},
                  fmt::format("found an output name ending in {}, expected one for G-code text "
                              "(.gcode): the M73 lines are written into text, whatever the input",
                              binary));
    }
  }
  OutputOptions oo{"--write-m73", {input.path()}, {}};
  if (input.file() != nullptr && input.file()->identity()) oo.input_ids.push_back(*input.file()->identity());
  OutputFile out(output_path, oo);
  std::size_t written = 0;
  const double total = report.total_time_s;
  std::unique_ptr<gcode::LineReader> own;
  if (input.file() != nullptr) {
    if (input.file()->position() != 0) input.file()->rewind();
    own = formats::open_gcode_reader(*input.file());
  } else {
    own = formats::open_gcode_reader(input.path());
  }
  gcode::LineReader& reader = *own;
  std::string eol = "\n";
  std::string_view line;
  std::size_t next = 0;
  const auto& cps = report.checkpoints;
  while (reader.next(line)) {
    const std::uint64_t n = reader.line_number();
    while (next < cps.size() && cps[next].line <= n) {
      if (cps[next].line == n) {
        const double t = cps[next].time_s;
        const double pct = total > 0 ? std::floor(100.0 * t / total) : 100.0;
        const double rem_min = std::ceil(std::max(0.0, total - t) / 60.0);
        out.write(fmt::format("M73 P{:.0f} R{:.0f}{}", pct, rem_min, eol));
        ++written;
      }
      ++next;
    }
    if (!reader.terminator().empty()) eol = reader.terminator();  // the file's own line ends
    if (is_m73(line)) continue;
    out.write(line);
    out.write(eol);
  }
  out.write(fmt::format("M73 P100 R0{}", eol));
  ++written;
  out.commit();
  return written;
}

}  // namespace amctl::plan
