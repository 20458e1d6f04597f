#include "commands.hpp"

#include <cmath>
#include <cstdlib>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"

namespace amctl::cli {
void register_all(CLI::App& app) {
  register_estimate(app);
  register_plan(app);
  register_report(app);
  register_dynamics(app);
  register_compensate(app);
  register_compare(app);
  register_thermal(app);
  register_process(app);
  register_machine(app);
  register_shaper(app);
  register_resonance(app);
  register_steps(app);
  register_stepper(app);
  refuse_non_finite_flags(app);
}

void refuse_non_finite_flags(CLI::App& app) {
  // Every number on the command line is a physical value or a count: NaN, an infinity or a
  // subnormal (0 < |v| < 2.2e-308, which no reciprocal, square or product survives) is never
  // one, whichever flag it is given to. Checked on the text before the command runs, so the
  // message names the flag even where the value would otherwise only be caught deep inside a
  // model ("extra_settle_s must be finite"). Each flag's own range is checked by its command.
  const CLI::Validator finite(
      [](std::string& text) -> std::string {
        std::string out;
        std::size_t start = 0;
        // A list value ("1,2,3") is checked element by element.
        while (start <= text.size()) {
          std::size_t end = text.find(',', start);
          if (end == std::string::npos) end = text.size();
          const std::string item = text.substr(start, end - start);
          char* stop = nullptr;
          const double v = std::strtod(item.c_str(), &stop);
          if (stop != item.c_str() &&
              (!std::isfinite(v) || (v != 0.0 && std::fabs(v) < std::numeric_limits<double>::min()))) {
            return fmt::format("must be a finite number (and none closer to 0 than {:g}), got '{}'",
                               std::numeric_limits<double>::min(), item);
          }
          start = end + 1;
        }
        return out;
      },
      "", "finite");
  for (CLI::Option* o : app.get_options()) {
    if (o->get_type_name().rfind("FLOAT", 0) == 0) o->check(finite);
  }
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) refuse_non_finite_flags(*sub);
}

void require_positive_flag(std::string_view flag, double value) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw Error(fmt::format("{}: must be a finite number > 0, got {}", flag, value));
  }
}

void require_range_flag(std::string_view flag, const PhysicalRange& range, double value) {
  if (!in_range(range, value)) throw Error(fmt::format("{}: must be {}, got {}", flag, describe(range), value));
}

void require_mode_frequency_flag(std::string_view flag, double f_hz, double sample_rate_hz) {
  require_range_flag(flag, kFrequencyRange, f_hz);
  if (f_hz >= 0.5 * sample_rate_hz) {
    throw Error(fmt::format("{}: must be below half the sample rate ({} Hz at --sample-rate-hz {}: the "
                            "Nyquist limit), got {}",
                            flag, 0.5 * sample_rate_hz, sample_rate_hz, f_hz));
  }
}

void require_damping_ratio_flag(std::string_view flag, double zeta) {
  if (!(std::isfinite(zeta) && zeta >= 0.0 && zeta <= 10.0)) {
    throw Error(fmt::format("{}: must be a damping ratio in [0, 10], got {}", flag, zeta));
  }
}

void require_non_negative_flag(std::string_view flag, double value) {
  if (!(std::isfinite(value) && value >= 0.0)) {
    throw Error(fmt::format("{}: must be a finite number >= 0, got {}", flag, value));
  }
}
}  // namespace amctl::cli
