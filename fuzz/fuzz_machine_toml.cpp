// libFuzzer target for amctl's TOML machine description (parse_machine_toml) and for one
// `--set section.key=value` assignment (apply_override). Acceptable outcomes: a Machine or
// amctl::Error. A machine that was read must survive to_toml and read back equal to itself
// (what `amctl machine show` prints is a machine file).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "fuzz_support.hpp"
#include "machine_round_trip.hpp"

namespace mc = amctl::machine;
using amctl::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const mc::Machine m = mc::parse_machine_toml(text, "fuzz.toml");
    amctl::fuzz::require_toml_round_trip(m);
  } catch (const amctl::Error&) {
  }
  // Lines shaped like "section.key=value" (a '.' before the '='), at most 8 of them, as
  // overrides of the default machine: each is applied or refused. (Every TOML line would be
  // refused for want of a section, an exception each: a third of the time for nothing.)
  std::size_t begin = 0;
  int overrides = 0;
  while (begin < text.size() && overrides < 8) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(begin, end - begin);
    begin = end + 1;
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos || line.substr(0, eq).find('.') == std::string_view::npos) {
      continue;
    }
    ++overrides;
    mc::Machine m;
    try {
      mc::apply_override(m, line);
    } catch (const amctl::Error&) {
      continue;
    }
    try {
      mc::validate(m);
    } catch (const amctl::Error&) {
    }
  }
  return 0;
}
