// libFuzzer target for the macro engine's expressions: the input is put between `{` and `}`
// (one Jinja2 expression as Klipper's delimiters write it) and rendered (fuzz_macro.hpp).
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_macro.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 20000) return 0;
  std::string text = "G1 X{ ";
  text.append(reinterpret_cast<const char*>(data), size);
  text += " }\n";
  amctl::fuzz::fuzz_template(text);
  return 0;
}
