#include "amctl/formats/sources.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::formats {

FileSource::FileSource(std::FILE* file, bool owns, std::string name, std::string prefix)
    : file_(file), owns_(owns), name_(std::move(name)), prefix_(std::move(prefix)) {}

FileSource::~FileSource() {
  if (owns_ && file_ != nullptr) std::fclose(file_);
}

std::size_t FileSource::read(char* dst, std::size_t n) {
  std::size_t k = 0;
  if (prefix_pos_ < prefix_.size()) {
    k = std::min(n, prefix_.size() - prefix_pos_);
    std::memcpy(dst, prefix_.data() + prefix_pos_, k);
    prefix_pos_ += k;
    if (prefix_pos_ == prefix_.size()) {
      prefix_.clear();
      prefix_.shrink_to_fit();
      prefix_pos_ = 0;
    }
    if (k == n) return k;
  }
  const std::size_t got = std::fread(dst + k, 1, n - k, file_);
  if (got == 0 && std::ferror(file_)) {
    throw Error(SourceLocation{name_, 0, 0}, fmt::format("read error: {}", std::strerror(errno)));
  }
  return k + got;
}

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
