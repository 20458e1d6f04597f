#include "amctl/dynamics/sample_csv.hpp"

#include <cmath>
#include <cstdio>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::dynamics {

std::size_t csv_decimation(double sample_rate_hz, std::optional<double> csv_rate_hz) {
  const double cr = csv_rate_hz.value_or(sample_rate_hz);
  require_positive("csv_rate_hz", cr);
  const double ratio = sample_rate_hz / cr;
  const auto decim = static_cast<std::size_t>(std::llround(ratio));
  if (decim < 1 || std::abs(ratio - static_cast<double>(decim)) > 1e-9 * ratio) {
    throw Error(fmt::format("--csv-rate-hz {} must divide --sample-rate-hz {} evenly", cr, sample_rate_hz));
  }
  return decim;
}

SampleCsvFile::SampleCsvFile(const std::string& path, std::size_t decimation)
    : path_(path), tmp_(path + ".part"), decimation_(decimation) {
  out_.open(tmp_);
  if (!out_) throw Error(fmt::format("cannot write CSV file '{}'", path));
  out_ << "t_s,cmd_x_mm,cmd_y_mm,cmd_z_mm,sim_x_mm,sim_y_mm,contour_error_mm,vibration_mm,line\n";
}

SampleCsvFile::~SampleCsvFile() {
  if (!committed_) {
    out_.close();
    std::remove(tmp_.c_str());
  }
}

void SampleCsvFile::set_first_step(long long first_step) {
  const auto d = static_cast<long long>(decimation_);
  k_ = static_cast<std::size_t>(((first_step % d) + d) % d);
}

void SampleCsvFile::row(const SimSample& s, double e) {
  if (k_++ % decimation_ != 0 || std::isnan(e)) return;
  out_ << fmt::format("{:.6f},{:.6f},{:.6f},{:.4f},{:.6f},{:.6f},{:.6g},{:.6g},{}\n", s.t_s, s.cmd_mm[0],
                      s.cmd_mm[1], s.cmd_mm[2], s.sim_mm[0], s.sim_mm[1], e,
                      std::hypot(s.vibration_mm[0], s.vibration_mm[1]), s.line);
}

void SampleCsvFile::commit() {
  out_.close();
  if (!out_ || std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    throw Error(fmt::format("cannot write CSV file '{}'", path_));
  }
  committed_ = true;
}

}  // namespace amctl::dynamics
