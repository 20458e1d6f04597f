#pragma once
// Plain byte sources: an open file (or standard input) with the bytes already read to
// recognise its content put back in front, and a span of memory (tests, fuzzing).
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>

#include "amctl/gcode/byte_source.hpp"

namespace amctl::formats {

/// Reads an open FILE. `prefix` is given out first: the bytes already taken from the file to
/// look at its content (so standard input and pipes are read once). Closes the file if `owns`.
class FileSource final : public gcode::ByteSource {
 public:
  FileSource(std::FILE* file, bool owns, std::string name, std::string prefix = {});
  ~FileSource() override;
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;
  std::size_t read(char* dst, std::size_t n) override;

 private:
  std::FILE* file_;
  bool owns_;
  std::string name_;
  std::string prefix_;
  std::size_t prefix_pos_ = 0;
};

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
