// libFuzzer target for the macro engine's statements: the input is a whole template (text,
// `{ }` expressions, `{% %}` statements: if/elif/else, for/else, set, namespace attributes,
// `{# #}` comments and whitespace control) compiled and rendered (fuzz_macro.hpp).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_macro.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size > 20000) return 0;
  amctl::fuzz::fuzz_template(std::string_view(reinterpret_cast<const char*>(data), size));
  return 0;
}
