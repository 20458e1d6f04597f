// libFuzzer target for the Klipper printer.cfg reader (parse_klipper_cfg) with [include]s.
//
// The input is several files separated by lines "#%%FILE\n": the first is printer.cfg, the
// others inc1.cfg, inc2.cfg and sub/inc3.cfg in a scratch directory of this process, so
// `[include inc1.cfg]`, `[include inc*.cfg]`, `[include sub/*.cfg]` and recursive includes
// all reach real files. Inputs whose includes leave the scratch directory (absolute paths,
// "..") are skipped: the harness must not read the rest of the machine.
//
// Acceptable outcomes: a Machine or amctl::Error. A machine that was read must survive
// to_toml and read back equal to itself.
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

namespace {

bool includes_stay_inside(std::string_view text) {
  if (text.find("..") != std::string_view::npos) return false;
  std::size_t at = 0;
  while ((at = text.find("[include", at)) != std::string_view::npos) {
    at += 8;
    std::size_t p = at;
    while (p < text.size() && (text[p] == ' ' || text[p] == '\t')) ++p;
    if (p < text.size() && (text[p] == '/' || text[p] == '~' || text[p] == '\\')) return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const amctl::fuzz::ScratchDir dir("klipper_cfg");
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  if (!includes_stay_inside(text)) return 0;
  const auto parts = amctl::fuzz::split(text, "#%%FILE\n");
  static const char* const names[] = {"printer.cfg", "inc1.cfg", "inc2.cfg", "sub/inc3.cfg"};
  dir.reset();
  std::string main_path;
  for (std::size_t i = 0; i < parts.size() && i < 4; ++i) {
    const std::string p = dir.write(names[i], parts[i]);
    if (i == 0) main_path = p;
  }
  try {
    const mc::Machine m = mc::parse_klipper_cfg(parts[0], main_path);
    amctl::fuzz::require_toml_round_trip(m);
  } catch (const amctl::Error&) {
  }
  return 0;
}
