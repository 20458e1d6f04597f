#pragma once
// The TOML round trip both machine harnesses check (fuzz_machine_toml, fuzz_klipper_cfg):
// what amctl writes it reads back, equal to the machine it wrote.
#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "fuzz_support.hpp"

namespace amctl::fuzz {

inline void require_toml_round_trip(const machine::Machine& m) {
  machine::Machine back;
  try {
    back = machine::parse_machine_toml(machine::to_toml(m), "again.toml");
  } catch (const amctl::Error&) {
    __builtin_trap();  // amctl wrote a file it refuses to read
  }
  // A printer.cfg's sections as written (kept for the macros) are not part of the TOML form.
  machine::Machine written = m;
  written.klipper_config.clear();
  require(back == written);
}

}  // namespace amctl::fuzz
