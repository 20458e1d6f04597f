#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
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

std::size_t write_m73(const std::string& input_path, const std::string& output_path,
                      const EstimateReport& report) {
  if (input_path == output_path) {
    throw Error(SourceLocation{output_path, 0, 0},
                "the M73 output must be a different file from the input");
  }
  for (const char* binary : {".bgcode", ".3mf", ".gz"}) {
    if (output_path.ends_with(binary)) {
      throw Error(SourceLocation{output_path, 0, 0},
                  fmt::format("found an output name ending in {}, expected one for G-code text "
                              "(.gcode): the M73 lines are written into text, whatever the input",
                              binary));
    }
  }
  const std::string tmp = output_path + ".amctl-tmp";
  std::FILE* out = std::fopen(tmp.c_str(), "wb");
  if (out == nullptr) {
    throw Error(SourceLocation{output_path, 0, 0},
                fmt::format("cannot write: {}", std::strerror(errno)));
  }
  std::size_t written = 0;
  const double total = report.total_time_s;
  try {
    const auto reader_ptr = formats::open_gcode_reader(input_path);
    gcode::LineReader& reader = *reader_ptr;
    std::string_view line;
    std::size_t next = 0;
    const auto& cps = report.checkpoints;
    auto put = [&](std::string_view text) {
      if (std::fwrite(text.data(), 1, text.size(), out) != text.size()) {
        throw Error(SourceLocation{output_path, 0, 0},
                    fmt::format("write failed: {}", std::strerror(errno)));
      }
    };
    while (reader.next(line)) {
      const std::uint64_t n = reader.line_number();
      while (next < cps.size() && cps[next].line <= n) {
        if (cps[next].line == n) {
          const double t = cps[next].time_s;
          const double pct = total > 0 ? std::floor(100.0 * t / total) : 100.0;
          const double rem_min = std::ceil(std::max(0.0, total - t) / 60.0);
          put(fmt::format("M73 P{:.0f} R{:.0f}\n", pct, rem_min));
          ++written;
        }
        ++next;
      }
      if (is_m73(line)) continue;
      put(line);
      put("\n");
    }
    put("M73 P100 R0\n");
    ++written;
    if (std::fclose(out) != 0) {
      out = nullptr;
      throw Error(SourceLocation{output_path, 0, 0}, "closing the output failed");
    }
    out = nullptr;
    std::filesystem::rename(tmp, output_path);
  } catch (...) {
    if (out != nullptr) std::fclose(out);
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw;
  }
  return written;
}

}  // namespace amctl::plan
