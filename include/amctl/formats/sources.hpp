#pragma once
// A byte source over a span of memory (tests, fuzzing); files are read by core/input.hpp.
#include <memory>
#include <string>
#include <string_view>

#include "amctl/gcode/byte_source.hpp"

namespace amctl::formats {

/// Reads a span of memory the caller keeps alive.
class MemorySource final : public gcode::ByteSource {
 public:
  explicit MemorySource(std::string_view bytes) : bytes_(bytes) {}
  std::size_t read(char* dst, std::size_t n) override;

 private:
  std::string_view bytes_;
};

/// Reads until `n` bytes or the end of `src`; returns how many were read.
std::size_t read_fully(gcode::ByteSource& src, char* dst, std::size_t n);

}  // namespace amctl::formats
