#include "amctl/dynamics/sample_csv.hpp"

#include <cmath>
#include <cstdio>
#include <iterator>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::dynamics {

std::size_t csv_decimation(double sample_rate_hz, std::optional<double> csv_rate_hz) {
  const double cr = csv_rate_hz.value_or(sample_rate_hz);
  require_positive("csv_rate_hz", cr);
  const double ratio = sample_rate_hz / cr;
  const auto decim = static_cast<std::size_t>(std::llround(ratio));
  if (decim < 1 || std::abs(ratio - static_cast<double>(decim)) > 1e-9 * ratio) {
    throw Error(fmt::format("--csv-rate-hz: must divide --sample-rate-hz {1} evenly, got {0}", cr, sample_rate_hz));
  }
  return decim;
}

SampleCsvFile::SampleCsvFile(const std::string& path, std::size_t decimation, OutputOptions options)
    : out_(path, std::move(options)), decimation_(decimation) {
  out_.write("t_s,cmd_x_mm,cmd_y_mm,cmd_z_mm,sim_x_mm,sim_y_mm,contour_error_mm,vibration_mm,line\n");
}

void SampleCsvFile::set_first_step(long long first_step) {
  const auto d = static_cast<long long>(decimation_);
  k_ = static_cast<std::size_t>(((first_step % d) + d) % d);
}

void SampleCsvFile::row(const SimSample& s, double e) {
  if (k_++ % decimation_ != 0 || std::isnan(e)) return;
  fmt::memory_buffer b;
  fmt::format_to(std::back_inserter(b), "{:.6f},{:.6f},{:.6f},{:.4f},{:.6f},{:.6f},{:.6g},{:.6g},{}\n", s.t_s,
                 s.cmd_mm[0], s.cmd_mm[1], s.cmd_mm[2], s.sim_mm[0], s.sim_mm[1], e,
                 std::hypot(s.vibration_mm[0], s.vibration_mm[1]), s.line);
  out_.write(std::string_view(b.data(), b.size()));
}

void SampleCsvFile::commit() { out_.commit(); }

}  // namespace amctl::dynamics
