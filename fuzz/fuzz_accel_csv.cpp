// libFuzzer target for the accelerometer CSV reader (Klipper raw, corpus and PSD formats,
// resonance/record.hpp) and the calibration behind `amctl resonance calibrate`.
// Acceptable outcomes: a record or table that keeps the reader's promises (equal column
// lengths, finite values, strictly increasing times or frequencies) and a calibration with
// finite figures, or amctl::Error.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/record.hpp"
#include "fuzz_support.hpp"

namespace rs = amctl::resonance;
using amctl::fuzz::require;

namespace {
bool all_finite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}
bool increasing(const std::vector<double>& v) {
  for (std::size_t i = 1; i < v.size(); ++i)
    if (!(v[i] > v[i - 1])) return false;
  return true;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  rs::AccelFile file;
  try {
    file = rs::parse_accel_text(text, "fuzz.csv");
  } catch (const amctl::Error&) {
    return 0;
  }
  if (file.format == rs::RecordFormat::klipper_psd) {
    const auto& p = file.psd;
    const std::size_t n = p.freq_hz.size();
    // A several-record PSD file (freq,NAME1,NAME2,...) holds psd_xyz only, per record.
    const bool sets = !p.name.empty();
    const std::size_t per_axis = sets ? 0 : n;
    require(p.psd_x.size() == per_axis && p.psd_y.size() == per_axis &&
            p.psd_z.size() == per_axis && p.psd_xyz.size() == n);
    require(all_finite(p.freq_hz) && all_finite(p.psd_x) && all_finite(p.psd_y) &&
            all_finite(p.psd_z) && all_finite(p.psd_xyz));
    require(sets || file.more_psd.empty());
    for (const auto& t : file.more_psd) {
      require(t.freq_hz == p.freq_hz && t.psd_xyz.size() == n && t.psd_x.empty());
      require(t.normalized == p.normalized && all_finite(t.psd_xyz));
    }
  } else {
    const auto& r = file.record;
    const std::size_t n = r.time_s.size();
    require(r.accel_x_mm_s2.size() == n && r.accel_y_mm_s2.size() == n &&
            r.accel_z_mm_s2.size() == n);
    require(all_finite(r.time_s) && all_finite(r.accel_x_mm_s2) && all_finite(r.accel_y_mm_s2) &&
            all_finite(r.accel_z_mm_s2));
    require(increasing(r.time_s));
    try {
      const rs::RecordQuality q = rs::assess_record(r);
      require(q.samples == n && std::isfinite(q.duration_s) && q.duration_s > 0.0 &&
              std::isfinite(q.jitter) && q.jitter >= 0.0);
    } catch (const amctl::Error&) {
    }
  }
  for (char axis : {'x', 'y'}) {
    rs::CalibrateOptions opt;
    opt.axis = axis;
    try {
      const rs::CalibrationReport rep = rs::calibrate(file, "fuzz.csv", opt);
      // No per-axis PSD (a several-record file): no axis peak, NaN (null in the JSON).
      require(std::isfinite(rep.peak_axis_hz) == !rep.psd.psd_x.empty() && std::isfinite(rep.peak_xyz_hz));
      require(rep.sources.size() == 1 + file.more_psd.size());
      (void)rs::to_json(rep);
    } catch (const amctl::Error&) {
    }
  }
  return 0;
}
