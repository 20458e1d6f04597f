#include "amctl/formats/sources.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::formats {

std::size_t MemorySource::read(char* dst, std::size_t n) {
  const std::size_t k = std::min(n, bytes_.size());
  if (k > 0) std::memcpy(dst, bytes_.data(), k);
  bytes_.remove_prefix(k);
  return k;
}

std::size_t read_fully(gcode::ByteSource& src, char* dst, std::size_t n) {
  std::size_t k = 0;
  while (k < n) {
    const std::size_t got = src.read(dst + k, n - k);
    if (got == 0) break;
    k += got;
  }
  return k;
}

}  // namespace amctl::formats
