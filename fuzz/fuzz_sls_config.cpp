// libFuzzer target for the SLS build configuration (TOML, `amctl thermal sls --config`,
// thermal::load_sls_config). The reader takes a path: each input is written to a scratch
// file first. Acceptable outcomes: a configuration or amctl::Error.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/thermal/powder_bed_sim.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const amctl::fuzz::ScratchDir dir("sls_config");
  const std::string path =
      dir.write("sls.toml", std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    (void)amctl::thermal::load_sls_config(path);
  } catch (const amctl::Error&) {
  }
  return 0;
}
