// libFuzzer target for Marlin machines (machine/marlin.hpp): the input as M503 output and as
// a Configuration.h (the first half) with a Configuration_adv.h (the second). Acceptable
// outcomes: a Machine or amctl::Error; a machine that was read must survive to_toml and read
// back equal to itself.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/machine/marlin.hpp"
#include "fuzz_support.hpp"
#include "machine_round_trip.hpp"

namespace mc = amctl::machine;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  (void)mc::looks_like_m503(text);
  (void)mc::looks_like_marlin_configuration(text);
  try {
    amctl::fuzz::require_toml_round_trip(mc::parse_marlin_m503(text, "m503.txt"));
  } catch (const amctl::Error&) {
  }
  const std::size_t half = text.find("\n---\n");
  const std::string_view conf = half == std::string_view::npos ? text : text.substr(0, half);
  const std::string_view adv = half == std::string_view::npos ? std::string_view() : text.substr(half + 5);
  try {
    amctl::fuzz::require_toml_round_trip(mc::parse_marlin_configuration(conf, "Configuration.h", adv, "Configuration_adv.h"));
  } catch (const amctl::Error&) {
  }
  return 0;
}
