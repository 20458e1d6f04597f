// The bed mesh's move transform (docs/bedmesh.md section 3), in the order of Klipper's
// BedMesh.move / MoveSplitter.split so that each piece's end point is the same double.
#include "amctl/bedmesh/transform.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

namespace amctl::bedmesh {
namespace {

constexpr double kFadeDisable = 0x7FFFFFFF;  // Klipper's FADE_DISABLE

double lerp(double t, double a, double b) { return (1.0 - t) * a + t * b; }

}  // namespace

MeshTransform::MeshTransform(Settings settings, gcode::EventSink& next)
    : settings_(std::move(settings)), next_(next) {
  fade_dist_mm_ = settings_.fade_end_mm - settings_.fade_start_mm;
  if (fade_dist_mm_ <= 0.0) {
    fade_start_mm_ = fade_end_mm_ = kFadeDisable;
  } else {
    fade_start_mm_ = settings_.fade_start_mm;
    fade_end_mm_ = settings_.fade_end_mm;
  }
}

double MeshTransform::fade_factor(double z_mm) const {
  z_mm += tool_offset_mm_;
  if (z_mm >= fade_end_mm_) return 0.0;
  if (z_mm >= fade_start_mm_) return (fade_end_mm_ - z_mm) / fade_dist_mm_;
  return 1.0;
}

double MeshTransform::z_offset(double x, double y, double factor) const {
  const double z = mesh_->z_at(x, y);
  return factor * (z - fade_target_mm_) + fade_target_mm_;
}

double MeshTransform::adjusted_z(double x_mm, double y_mm, double z_mm) const {
  const double factor = fade_factor(z_mm);
  if (!mesh_ || factor == 0.0) return z_mm + fade_target_mm_;
  return z_mm + z_offset(x_mm, y_mm, factor);
}

void MeshTransform::emit(const gcode::MoveRequest& r, const std::array<double, 4>& end) {
  gcode::MoveRequest piece = r;
  piece.start_mm = toolhead_;
  piece.end_mm = end;
  toolhead_ = end;
  ++stats_.pieces_out;
  next_.on_move(piece);
}

void MeshTransform::on_move(const gcode::MoveRequest& r) {
  if (pass_through_) {
    toolhead_ = last_ = r.end_mm;
    next_.on_move(r);
    return;
  }
  ++stats_.moves_in;
  // Klipper's target: the interpreter's, except a Z the move leaves as it is, which stays at
  // Klipper's G-code Z (after a mesh load, a clear or homing with a mesh, gcode_move takes
  // its position back from the toolhead through the inverse transform; amctl's interpreter
  // does not, so the two differ by the mesh's z there until the file sets Z again).
  std::array<double, 4> newpos = r.end_mm;
  if (r.end_mm[2] == r.start_mm[2]) newpos[2] = last_[2];
  const double factor = fade_factor(newpos[2]);
  if (!mesh_ || factor == 0.0) {
    std::array<double, 4> end = newpos;
    end[2] += fade_target_mm_;
    emit(r, end);
  } else {
    // MoveSplitter.build_move / split.
    const std::array<double, 4> prev = last_;
    std::array<double, 4> current = prev;
    double z_off = z_offset(prev[0], prev[1], factor);
    std::array<bool, 4> axis_move{};
    double len2 = 0.0;
    for (std::size_t i = 0; i < 4; ++i) {
      const double d = newpos[i] - prev[i];
      axis_move[i] = !(std::fabs(d) <= 1e-10);
      if (i < 3) len2 += d * d;
    }
    const double total = std::sqrt(len2);
    if (axis_move[0] || axis_move[1]) {
      const double step = settings_.move_check_distance_mm;
      double checked = 0.0;
      while (checked + step < total) {
        checked += step;
        const double t = checked / total;
        for (std::size_t i = 0; i < 4; ++i) {
          if (axis_move[i]) current[i] = lerp(t, prev[i], newpos[i]);
        }
        const double next_z = z_offset(current[0], current[1], factor);
        if (std::fabs(next_z - z_off) >= settings_.split_delta_z_mm) {
          z_off = next_z;
          std::array<double, 4> piece = current;
          piece[2] += z_off;
          emit(r, piece);
        }
      }
    }
    std::array<double, 4> end = newpos;
    end[2] += z_offset(newpos[0], newpos[1], factor);
    emit(r, end);
  }
  last_ = newpos;
  if (!mesh_ && toolhead_ == r.end_mm) pass_through_ = true;
}

void MeshTransform::reset_last_position() {
  // BedMesh.get_position: the G-code position of the toolhead's.
  last_ = toolhead_;
  if (!mesh_) {
    last_[2] -= fade_target_mm_;
    return;
  }
  const double x = toolhead_[0], y = toolhead_[1], z = toolhead_[2];
  const double max_adj = mesh_->z_at(x, y);
  double factor = 1.0;
  const double z_adj = max_adj - fade_target_mm_;
  const double fade_z = z + tool_offset_mm_;
  if (std::min(fade_z, fade_z - max_adj) >= fade_end_mm_) {
    factor = 0.0;
  } else if (std::max(fade_z, fade_z - max_adj) >= fade_start_mm_) {
    factor = (fade_end_mm_ + fade_target_mm_ - fade_z) / (fade_dist_mm_ - z_adj);
    factor = std::min(1.0, std::max(0.0, factor));
  }
  last_[2] = z - (factor * z_adj + fade_target_mm_);
}

void MeshTransform::on_set_position(const std::array<double, 4>& pos_mm, std::uint64_t line) {
  toolhead_ = pos_mm;
  next_.on_set_position(pos_mm, line);
  reset_last_position();
  pass_through_ = !mesh_ && last_ == toolhead_;
}

void MeshTransform::set_mesh(const Profile* profile, const gcode::BedMeshCommand& cmd) {
  const SourceLocation at{"", cmd.line, cmd.column};
  std::optional<ZMesh> mesh;
  if (profile != nullptr) mesh.emplace(*profile);
  if (mesh && fade_end_mm_ != kFadeDisable) {
    const auto [lo, hi] = mesh->z_range();
    if (!settings_.fade_target_mm) {
      fade_target_mm_ = mesh->z_average_rounded();
    } else {
      fade_target_mm_ = *settings_.fade_target_mm;
      if (!(lo <= fade_target_mm_ && fade_target_mm_ <= hi) && fade_target_mm_ != 0.0) {
        throw Error(at, fmt::format("bed_mesh: ERROR, fade_target lies outside of mesh z range "
                                    "(min: {:.4f}, max: {:.4f}, fade_target: {:.4f}); expected a "
                                    "[bed_mesh] fade_target inside the range of profile '{}' or 0",
                                    lo, hi, fade_target_mm_, mesh->profile_name()));
      }
    }
    if (fade_dist_mm_ <= std::max(std::fabs(lo), std::fabs(hi))) {
      throw Error(at, fmt::format("bed_mesh: Mesh extends outside of the fade range (fade distance "
                                  "{:.2f} mm, mesh min {:.4f} mm, max {:.4f} mm); expected fade_end - "
                                  "fade_start above the mesh's largest |z|",
                                  fade_dist_mm_, lo, hi));
    }
  } else {
    fade_target_mm_ = 0.0;
  }
  tool_offset_mm_ = 0.0;
  offset_x_mm_ = offset_y_mm_ = 0.0;
  mesh_ = std::move(mesh);
  if (profile != nullptr) {
    mesh_profile_ = *profile;
  } else {
    mesh_profile_.reset();
  }
  reset_last_position();
  pass_through_ = false;
}

void MeshTransform::on_bed_mesh(const gcode::BedMeshCommand& cmd) {
  using Kind = gcode::BedMeshCommand::Kind;
  switch (cmd.kind) {
    case Kind::load: {
      const Profile* p = settings_.find(cmd.profile);
      if (p == nullptr) {
        std::string known;
        for (const Profile& q : settings_.profiles) known += (known.empty() ? "" : ", ") + q.name;
        throw Error(SourceLocation{"", cmd.line, cmd.column},
                    fmt::format("bed_mesh: Unknown profile [{}]; expected a saved profile ({})", cmd.profile,
                                known.empty() ? "the printer.cfg has none" : known));
      }
      ++stats_.profile_loads;
      set_mesh(p, cmd);
      return;
    }
    case Kind::clear:
      set_mesh(nullptr, cmd);
      return;
    case Kind::offset:
      if (!mesh_) return;  // "No mesh loaded to offset"
      {
        // set_mesh_offsets keeps an offset that is not given.
        if (cmd.x_mm) offset_x_mm_ = *cmd.x_mm;
        if (cmd.y_mm) offset_y_mm_ = *cmd.y_mm;
        mesh_->set_offsets(offset_x_mm_, offset_y_mm_);
        if (cmd.zfade_mm) tool_offset_mm_ = *cmd.zfade_mm;
        reset_last_position();
      }
      return;
    case Kind::save:
      if (!mesh_) return;  // "Unable to save to profile": the bed has not been probed
      {
        Profile copy = *mesh_profile_;
        copy.name = cmd.profile;
        auto it = std::find_if(settings_.profiles.begin(), settings_.profiles.end(),
                               [&](const Profile& q) { return q.name == cmd.profile; });
        if (it != settings_.profiles.end()) {
          *it = std::move(copy);
        } else {
          settings_.profiles.push_back(std::move(copy));
        }
      }
      return;
    case Kind::remove:
      std::erase_if(settings_.profiles, [&](const Profile& q) { return q.name == cmd.profile; });
      return;
  }
}

}  // namespace amctl::bedmesh
