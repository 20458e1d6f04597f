#pragma once
// Where the tests find their inputs.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "amctl/resonance/synthetic.hpp"

namespace amctl::resonance::test {

/// The corpus folder of accelerometer records: $AMCTL_CORPUS_DIR/accel, else
/// ../shared/corpus/accel (or ../../shared/corpus/accel) beside the source tree; nothing
/// when absent.
inline std::optional<std::filesystem::path> corpus_accel_dir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("AMCTL_CORPUS_DIR"); env && *env) {
    const fs::path p = fs::path(env) / "accel";
    if (fs::is_directory(p)) return p;
  }
  // ../shared beside a clone; ../../shared beside a worktree under wt/.
  for (const char* up : {"..", "../.."}) {
    const fs::path p = fs::path(AMCTL_SOURCE_DIR) / up / "shared" / "corpus" / "accel";
    if (fs::is_directory(p)) return p;
  }
  return std::nullopt;
}

inline std::filesystem::path reference_dir() {
  return std::filesystem::path(AMCTL_SOURCE_DIR) / "tests" / "reference" / "resonance";
}

inline nlohmann::json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return nlohmann::json::parse(ss.str());
}

/// The synthetic record given to Klipper (tests/reference/resonance/README.md): a 42 Hz mode
/// with damping ratio 0.08 on X, swept 5 -> 120 Hz at 10 Hz/s, 3 000 mm/s^2, 3.2 kHz.
inline SyntheticSweep reference_synthetic() {
  SyntheticSweep s;
  s.natural_freq_hz = 42.0;
  s.damping_ratio = 0.08;
  s.f0_hz = 5.0;
  s.f1_hz = 120.0;
  s.rate_hz_s = 10.0;
  s.accel_mm_s2 = 3000.0;
  s.sample_rate_hz = 3200.0;
  s.axis = 'x';
  s.seed = 1;
  return s;
}

/// The same mode excited as Klipper's own test excites it: amplitude 75 mm/s^2 per Hz.
inline SyntheticSweep reference_synthetic_per_hz() {
  SyntheticSweep s = reference_synthetic();
  s.accel_per_hz_mm_s2 = 75.0;
  return s;
}

inline std::filesystem::path temp_path(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("amctl_resonance_" + std::to_string(::getpid()) + "_" + name);
}

}  // namespace amctl::resonance::test
