#pragma once
// Klipper's [bed_mesh] as it affects motion (klippy/extras/bed_mesh.py): the saved profiles
// ([bed_mesh NAME] sections, usually in the SAVE_CONFIG block at the end of printer.cfg),
// fade, and the move splitting settings. Read from the sections of a printer.cfg as the
// machine reader keeps them (machine::Machine::klipper_config).
#include <optional>
#include <string>
#include <vector>

#include "amctl/bedmesh/mesh.hpp"
#include "amctl/core/config_section.hpp"
#include "amctl/core/json.hpp"

namespace amctl::bedmesh {

struct Settings {
  std::vector<Profile> profiles;  ///< in file order
  /// Profiles saved by another version of Klipper's format (version != 1): Klipper skips them
  /// (and offers to remove them); BED_MESH_PROFILE LOAD of one is "Unknown profile".
  std::vector<std::string> incompatible_profiles;
  double fade_start_mm = 1.0;
  double fade_end_mm = 0.0;
  bool fade_enabled = false;                 ///< fade_end > fade_start (else off, as Klipper)
  std::optional<double> fade_target_mm;      ///< unset: the mesh's rounded average
  double move_check_distance_mm = 5.0;       ///< >= 3
  double split_delta_z_mm = 0.025;           ///< >= 0.01
  SourceLocation where;                      ///< the [bed_mesh] header

  [[nodiscard]] const Profile* find(const std::string& name) const;
};

/// [bed_mesh] of a printer.cfg's sections, or nothing when the file has no [bed_mesh]
/// section (profiles without it are not loaded by Klipper either). Throws amctl::Error at
/// FILE:LINE:COL for what Klipper refuses (bad numbers, a mesh_min not below mesh_max, an
/// unknown algorithm) and for a saved profile whose points do not make the grid it declares
/// (a row of the wrong length, a value that is not a finite number, a missing key). A
/// fade_end at or below fade_start disables fade, as in Klipper.
[[nodiscard]] std::optional<Settings> read_klipper(const std::vector<ConfigSection>& sections,
                                                   const SourceLocation& file);

/// The listing of `amctl machine show --json` ("bed_mesh"): settings and each profile's
/// grid, counts and z range.
[[nodiscard]] Json to_json(const Settings& s);
/// The same as comment lines for `amctl machine show` (each starting with "# ").
[[nodiscard]] std::string to_text(const Settings& s);

}  // namespace amctl::bedmesh
