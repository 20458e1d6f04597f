// libFuzzer target for the process CSV reader (process/csv.hpp) and the tables read from it:
// shrinkage measurements (`amctl shrink fit`, read_shrink_samples + fit_shrinkage) and print
// timings (`amctl calibrate-time --timings`, read_print_timings).
// Acceptable outcomes: values that keep the readers' promises (finite fits, positive
// durations) or amctl::Error.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/shrinkage.hpp"
#include "amctl/process/time_calibration.hpp"
#include "fuzz_support.hpp"

namespace pr = amctl::process;
using amctl::fuzz::require;

namespace {
// The fits are O(n^2 k) in the number of distinct nominal values; a few hundred rows keep an
// input well under the timeout (the reader itself sees every input).
constexpr std::size_t kMaxFitRows = 400;

void fit(const std::vector<pr::ShrinkSample>& samples, const pr::ShrinkFitOptions& opt) {
  try {
    for (const auto& f : pr::fit_shrinkage(samples, opt)) {
      require(!f.ranges.empty());
      for (const auto& r : f.ranges) {
        require(std::isfinite(r.line.slope) && std::isfinite(r.line.intercept));
        require(!std::isnan(r.factor));
      }
    }
  } catch (const amctl::Error&) {
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  pr::CsvTable t;
  try {
    t = pr::CsvTable::parse(text, "fuzz.csv");
  } catch (const amctl::Error&) {
    return 0;
  }
  for (std::size_t r = 0; r < t.rows(); ++r) {
    for (std::size_t c = 0; c < t.header().size(); ++c) {
      (void)t.text(r, c);
      require(t.where(r, c).line > 0);
    }
  }
  try {
    const auto samples = pr::read_shrink_samples(t);
    require(!samples.empty());
    for (const auto& s : samples) {
      require(std::isfinite(s.nominal_mm) && s.nominal_mm > 0.0);
      require(std::isfinite(s.measured_mm) && s.measured_mm >= 0.0);
    }
    if (samples.size() <= kMaxFitRows) {
      pr::ShrinkFitOptions opt;
      fit(samples, opt);
      opt.average_repeats = true;
      opt.ranges = 0;
      fit(samples, opt);
    }
  } catch (const amctl::Error&) {
  }
  try {
    for (const auto& p : pr::read_print_timings(t)) {
      require(std::isfinite(p.duration_s) && p.duration_s > 0.0);
    }
  } catch (const amctl::Error&) {
  }
  return 0;
}
