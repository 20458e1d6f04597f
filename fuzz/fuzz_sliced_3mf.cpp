// libFuzzer target for the G-code inputs read by content (formats/input.hpp): a sliced 3MF
// through libzip, gzip, binary G-code, models refused. The input is written to a scratch file
// and opened as `amctl estimate` opens it. Acceptable outcomes: text or amctl::Error; a zip
// member never gives more bytes than its directory entry says.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/formats/input.hpp"
#include "fuzz_support.hpp"

namespace fm = amctl::formats;
using amctl::fuzz::require;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const amctl::fuzz::ScratchDir dir("sliced_3mf");
  const std::string path = dir.write("f.gcode.3mf", std::string(reinterpret_cast<const char*>(data), size));
  fm::InputLimits limits;
  limits.archive.max_member_bytes = 1u << 24;
  limits.archive.ratio_floor_bytes = 1u << 20;
  limits.bgcode.max_block_bytes = 1u << 20;
  try {
    for (const std::string& part : fm::gcode_parts(path, limits)) {
      try {
        fm::GcodeInput in = fm::open_gcode_input(part, limits);
        std::vector<char> buf(65536);
        std::uint64_t total = 0;
        for (std::size_t k; (k = in.bytes->read(buf.data(), buf.size())) > 0;) {
          total += k;
          require(total <= (1u << 26));  // the limits above bound every format
        }
      } catch (const amctl::Error&) {
      }
    }
  } catch (const amctl::Error&) {
  }
  return 0;
}
