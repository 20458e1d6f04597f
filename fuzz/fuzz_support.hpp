#pragma once
// Shared pieces of the libFuzzer harnesses (fuzz/fuzz_*.cpp).
//
// Readers that take a path (printer.cfg with its [include]s, the SLS TOML) are fed through a
// scratch directory of the fuzzing process, created once and removed at exit.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include <unistd.h>

namespace amctl::fuzz {

/// Abort (libFuzzer keeps the input as a crash) when an invariant of the code under test fails.
inline void require(bool ok) {
  if (!ok) __builtin_trap();
}

/// A directory of this process under the system temp dir, emptied by reset().
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() /
              ("amctl_fuzz_" + name + "_" + std::to_string(::getpid()))) {
    reset();
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  void reset() const {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
    std::filesystem::create_directories(path_);
  }
  /// Writes `bytes` to `rel` (sub-directories created) and returns the full path.
  std::string write(const std::string& rel, std::string_view bytes) const {
    const auto p = path_ / rel;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p.string();
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Splits `text` at every occurrence of `separator` (a line of its own in the seeds).
inline std::vector<std::string_view> split(std::string_view text, std::string_view separator) {
  std::vector<std::string_view> parts;
  std::size_t begin = 0;
  for (;;) {
    const std::size_t at = text.find(separator, begin);
    if (at == std::string_view::npos) {
      parts.push_back(text.substr(begin));
      return parts;
    }
    parts.push_back(text.substr(begin, at - begin));
    begin = at + separator.size();
  }
}

}  // namespace amctl::fuzz
