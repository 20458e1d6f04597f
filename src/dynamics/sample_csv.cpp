#include "amctl/dynamics/sample_csv.hpp"

#include <cmath>
#include <cstdint>
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
    : decimation_(decimation) {
  if (table_format_for(path) == TableFormat::npy) {
    std::vector<NpyColumn> cols;
    for (const char* n : {"t_s", "cmd_x_mm", "cmd_y_mm", "cmd_z_mm", "sim_x_mm", "sim_y_mm",
                          "contour_error_mm", "vibration_mm"}) {
      cols.push_back({n, NpyType::f8, 0});
    }
    cols.push_back({"line", NpyType::u8, 0});
    npy_.emplace(path, std::move(cols), std::move(options));
    return;
  }
  csv_.emplace(path, std::move(options));
  csv_->write("t_s,cmd_x_mm,cmd_y_mm,cmd_z_mm,sim_x_mm,sim_y_mm,contour_error_mm,vibration_mm,line\n");
}

void SampleCsvFile::set_first_step(long long first_step) {
  const auto d = static_cast<long long>(decimation_);
  k_ = static_cast<std::size_t>(((first_step % d) + d) % d);
}

void SampleCsvFile::row(const SimSample& s, double e) {
  if (k_++ % decimation_ != 0 || std::isnan(e)) return;
  const double vibration_mm = std::hypot(s.vibration_mm[0], s.vibration_mm[1]);
  if (npy_) {
    NpyRecord r(*npy_);
    r.set(0, s.t_s).set(1, s.cmd_mm[0]).set(2, s.cmd_mm[1]).set(3, s.cmd_mm[2]);
    r.set(4, s.sim_mm[0]).set(5, s.sim_mm[1]).set(6, e).set(7, vibration_mm);
    r.set_int(8, static_cast<std::int64_t>(s.line));
    npy_->append(r.bytes());
    return;
  }
  fmt::memory_buffer b;
  fmt::format_to(std::back_inserter(b), "{:.6f},{:.6f},{:.6f},{:.4f},{:.6f},{:.6f},{:.6g},{:.6g},{}\n", s.t_s,
                 s.cmd_mm[0], s.cmd_mm[1], s.cmd_mm[2], s.sim_mm[0], s.sim_mm[1], e,
                 vibration_mm, s.line);
  csv_->write(std::string_view(b.data(), b.size()));
}

void SampleCsvFile::commit() {
  if (npy_) {
    npy_->commit();
  } else {
    csv_->commit();
  }
}

}  // namespace amctl::dynamics
