#pragma once
#include <filesystem>
#include <fstream>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/machine/kinematics.hpp"

namespace amctl::machine::test {

/// The message of the amctl::Error `f` throws, or "<no error>".
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const amctl::Error& e) {
    return e.what();
  }
  return "<no error>";
}

/// A fresh directory under the system temp dir, removed at scope exit.
class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() / ("amctl_machine_test_" + name)) {
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string write(const std::string& rel, const std::string& text) const {
    const auto p = path_ / rel;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// The geometry a kinematics derives from machine m (the kinematics held must be that one).
inline kinematics::DeltaGeometry delta_geometry(const Machine& m) {
  const auto c = kinematics_context(m);
  return kinematics::delta_geometry(std::get<kinematics::Delta>(m.kinematics),
                                    {c.step_distance.at("a"), c.step_distance.at("b"),
                                     c.step_distance.at("c")});
}
inline kinematics::DeltesianGeometry deltesian_geometry(const Machine& m) {
  return kinematics::deltesian_geometry(std::get<kinematics::Deltesian>(m.kinematics));
}
inline kinematics::PolarGeometry polar_geometry(const Machine& m) {
  return kinematics::polar_geometry(std::get<kinematics::Polar>(m.kinematics));
}
inline kinematics::RotaryDeltaGeometry rotary_delta_geometry(const Machine& m) {
  return kinematics::rotary_delta_geometry(std::get<kinematics::RotaryDelta>(m.kinematics));
}
inline kinematics::GenericCartesianGeometry generic_cartesian_geometry(const Machine& m) {
  // Every stepper that is not an extruder needs carriages, as the kinematics checks.
  std::vector<std::string> keys, missing;
  for (const auto& [k, s] : m.steppers) keys.push_back(k);
  (void)make_kinematics(m)->motors(keys, missing);
  return kinematics::generic_cartesian_geometry(
      std::get<kinematics::GenericCartesian>(m.kinematics));
}
inline std::array<double, 3> parse_carriages(std::string_view expr, const Machine& m,
                                             std::string_view label, bool with_dual) {
  return kinematics::parse_carriages(
      expr, std::get<kinematics::GenericCartesian>(m.kinematics), label, with_dual);
}

}  // namespace amctl::machine::test
