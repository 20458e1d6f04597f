// libFuzzer target for the JSON inputs of the process commands: the shrink model
// (`amctl shrink apply --factors FILE.json`, parse_shrink_model) and the empirical time
// parameters (`amctl calibrate-time --params FILE.json`, parse_empirical_params).
// Acceptable outcomes: finite factors or amctl::Error.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/process/shrink_model.hpp"
#include "amctl/process/time_study.hpp"
#include "fuzz_support.hpp"

namespace pr = amctl::process;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const auto maps = pr::parse_shrink_model(text, "fuzz.json");
    for (const auto& m : maps) {
      for (double f : m.factors()) amctl::fuzz::require(std::isfinite(f) && f > 0.0);
    }
  } catch (const amctl::Error&) {
  }
  try {
    (void)pr::empirical_params_json(pr::parse_empirical_params(text, "fuzz.json").model, {});
  } catch (const amctl::Error&) {
  }
  return 0;
}
