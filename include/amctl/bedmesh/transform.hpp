#pragma once
// Klipper's bed mesh as a move transform between the G-code interpreter and the planner
// (klippy/extras/bed_mesh.py BedMesh.move and MoveSplitter; docs/bedmesh.md section 3): while
// a profile is loaded, each move is split where the mesh's z along it changes by
// split_delta_z (checked every move_check_distance), and every piece ends at its point's
// height plus the mesh's z there (faded with height). Each piece is a move of its own for
// the planner, as for Klipper's toolhead: that is what changes the print time, and it makes
// Z step during XY moves. Memory: the current mesh and one move (a move is split as it is
// forwarded).
#include <array>
#include <cstdint>
#include <optional>

#include "amctl/bedmesh/config.hpp"
#include "amctl/bedmesh/mesh.hpp"
#include "amctl/gcode/events.hpp"

namespace amctl::bedmesh {

/// Counts of what the transform did (for reports and tests).
struct TransformStats {
  std::uint64_t moves_in = 0;        ///< moves received while a mesh was loaded
  std::uint64_t pieces_out = 0;      ///< moves forwarded for them (each >= 1 per move)
  std::uint64_t profile_loads = 0;
};

class MeshTransform final : public gcode::EventSink {
 public:
  /// `next` receives every event (the planner); `settings` from read_klipper.
  MeshTransform(Settings settings, gcode::EventSink& next);

  void on_move(const gcode::MoveRequest& move) override;
  void on_bed_mesh(const gcode::BedMeshCommand& cmd) override;
  void on_set_position(const std::array<double, 4>& pos_mm, std::uint64_t line) override;

  // Everything else passes through unchanged.
  void on_dwell(double duration_s, std::uint64_t line) override { next_.on_dwell(duration_s, line); }
  void on_wait_moves(std::uint64_t line) override { next_.on_wait_moves(line); }
  void on_step_flush(std::uint64_t line) override { next_.on_step_flush(line); }
  void on_limits(const gcode::LimitsCommand& cmd) override { next_.on_limits(cmd); }
  void on_axis_range(int axis, double min_mm, double max_mm, std::uint64_t line) override {
    next_.on_axis_range(axis, min_mm, max_mm, line);
  }
  void on_heater(const gcode::HeaterCommand& cmd) override { next_.on_heater(cmd); }
  void on_fan(double fraction, std::uint64_t line) override { next_.on_fan(fraction, line); }
  void on_progress(const gcode::ProgressMarker& m) override { next_.on_progress(m); }
  void on_layer_change(std::int32_t layer, std::uint64_t line) override { next_.on_layer_change(layer, line); }
  void on_untimed(std::string_view name, std::uint64_t line) override { next_.on_untimed(name, line); }
  void on_input_shaping(const gcode::InputShapingCommand& cmd) override { next_.on_input_shaping(cmd); }

  [[nodiscard]] const TransformStats& stats() const { return stats_; }
  /// The mesh in use (null: none loaded, or cleared).
  [[nodiscard]] const ZMesh* mesh() const { return mesh_ ? &*mesh_ : nullptr; }
  /// The mesh's fade factor at G-code height z: 1 below fade_start, 0 from fade_end on.
  [[nodiscard]] double fade_factor(double z_mm) const;
  /// The z the toolhead goes to for a G-code position (x, y, z) [mm].
  [[nodiscard]] double adjusted_z(double x_mm, double y_mm, double z_mm) const;

 private:
  void set_mesh(const Profile* profile, const gcode::BedMeshCommand& cmd);
  void reset_last_position();
  double z_offset(double x, double y, double factor) const;
  void emit(const gcode::MoveRequest& r, const std::array<double, 4>& end);

  Settings settings_;
  gcode::EventSink& next_;
  std::optional<ZMesh> mesh_;
  std::optional<Profile> mesh_profile_;  ///< what mesh_ was built from (BED_MESH_PROFILE SAVE)
  double offset_x_mm_ = 0.0, offset_y_mm_ = 0.0;  ///< BED_MESH_OFFSET X, Y
  double fade_target_mm_ = 0.0;
  double tool_offset_mm_ = 0.0;
  double fade_start_mm_, fade_end_mm_, fade_dist_mm_;
  /// Klipper's toolhead position (mesh applied) and bed_mesh's last_position (G-code space).
  std::array<double, 4> toolhead_{}, last_{};
  /// No mesh and no difference between the two: moves pass through untouched.
  bool pass_through_ = true;
  TransformStats stats_;
};

}  // namespace amctl::bedmesh
