// [bed_mesh] and its saved profiles read with Klipper's checks (klippy/extras/bed_mesh.py:
// BedMesh, MoveSplitter, BedMeshCalibrate._init_mesh_config, ProfileManager), plus the checks
// Klipper leaves to a crash or to silence (a points block that does not fill its grid, NaN).
#include "amctl/bedmesh/config.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>

#include <fmt/format.h>

#include "amctl/core/quantity.hpp"
#include "amctl/kinematics/klipper_config.hpp"

namespace amctl::bedmesh {
namespace {

using kinematics::KlipperSection;
using kinematics::Limits;

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

/// Python's float() of a trimmed item (accepts "nan", "inf": refused by the caller).
bool parse_double(std::string_view s, double& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  return ec == std::errc() && p == s.data() + s.size() && !s.empty();
}

/// A pair "a, b" of numbers (Klipper getfloatlist / getintlist with two elements).
std::array<double, 2> read_pair(const KlipperSection& s, std::string_view key, bool integer,
                                std::optional<std::array<double, 2>> def) {
  const ConfigValue* v = s.raw(key);
  if (v == nullptr) {
    if (def) return *def;
    throw s.missing(key);
  }
  std::vector<double> out;
  std::string_view rest = v->text;
  std::size_t col = 0;
  while (true) {
    const std::size_t comma = rest.find(',');
    const std::string_view item = trim(rest.substr(0, comma));
    double x = 0.0;
    if (!parse_double(item, x) || !std::isfinite(x) || std::abs(x) > kLengthRange.max ||
        (integer && x != std::floor(x))) {
      throw Error(SourceLocation{v->where.file, v->where.line, v->where.column + static_cast<std::uint32_t>(col)},
                  fmt::format("[{}] {}: expected {} separated by a comma (each within +-{:g}), found '{}'",
                              s.name(), key, integer ? "integers" : "numbers", kLengthRange.max, v->text));
    }
    out.push_back(x);
    if (comma == std::string_view::npos) break;
    col += comma + 1;
    rest.remove_prefix(comma + 1);
  }
  if (out.size() == 1 && integer) out.push_back(out[0]);  // parse_config_pair: one value for both
  if (out.size() != 2) {
    throw Error(v->where, fmt::format("[{}] {}: expected 2 values, found {} in '{}'", s.name(), key,
                                      out.size(), v->text));
  }
  return {out[0], out[1]};
}

/// The 1-based file column of `offset` in `piece` (a trimmed piece of a value on `line`):
/// the reader keeps each piece trimmed, so the piece is found again in the file's line (an
/// error path only). Falls back to the offset in the piece when the file cannot be read.
std::uint32_t file_column(const std::string& file, std::uint64_t line, std::string_view piece,
                          std::size_t offset) {
  std::ifstream in(file, std::ios::binary);
  std::string text;
  for (std::uint64_t n = 0; n < line && std::getline(in, text); ++n) {
  }
  const std::size_t at = in ? text.find(piece) : std::string::npos;
  return static_cast<std::uint32_t>((at == std::string::npos ? 0 : at) + offset + 1);
}

/// A profile's `points`: rows separated by line breaks, values by commas.
std::vector<std::vector<double>> read_points(const KlipperSection& s, const ConfigValue& v) {
  std::vector<std::vector<double>> rows;
  std::string_view text = v.text;
  std::size_t piece = 0;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t nl = text.find('\n', pos);
    const std::string_view row = text.substr(pos, nl == std::string_view::npos ? text.npos : nl - pos);
    const std::uint64_t line = piece < v.lines.size() ? v.lines[piece] : v.where.line;
    pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    ++piece;
    if (trim(row).empty()) continue;
    std::vector<double>& out = rows.emplace_back();
    std::size_t at = 0;
    while (true) {
      const std::size_t comma = row.find(',', at);
      const std::string_view item = trim(row.substr(at, comma == std::string_view::npos ? row.npos : comma - at));
      double x = 0.0;
      if (!parse_double(item, x) || !std::isfinite(x)) {
        const std::size_t lead = row.substr(at).find_first_not_of(" \t");
        const std::size_t c = at + (lead == std::string_view::npos ? 0 : lead);
        throw Error(SourceLocation{v.where.file, line, file_column(v.where.file, line, trim(row), c)},
                    fmt::format("[{}] points: found '{}' in row {}, expected a finite number (the "
                                "probed z in mm)",
                                s.name(), item, rows.size()));
      }
      out.push_back(x);
      if (comma == std::string_view::npos) break;
      at = comma + 1;
    }
  }
  return rows;
}

Profile read_profile(const KlipperSection& s, std::string name) {
  Profile p;
  p.name = std::move(name);
  p.where = s.where();
  MeshParams& m = p.params;
  // ProfileManager reads every key SAVE_CONFIG writes, without a default.
  for (std::string_view key : {"points", "min_x", "max_x", "min_y", "max_y", "x_count", "y_count",
                               "mesh_x_pps", "mesh_y_pps", "algo", "tension"}) {
    if (!s.has(key)) {
      throw Error(s.where(), fmt::format("[{}] has no '{}', expected every key a saved profile has "
                                         "(points, min_x, max_x, min_y, max_y, x_count, y_count, "
                                         "mesh_x_pps, mesh_y_pps, algo, tension)",
                                         s.name(), key));
    }
  }
  const ConfigValue* pts = s.raw("points");
  const auto rows = read_points(s, *pts);
  // Coordinates of the bed: within amctl's largest machine length (core/quantity.hpp), so
  // that the spacing of the grid is a finite, non-zero number.
  const Limits coordinate{.minval = -kLengthRange.max, .maxval = kLengthRange.max};
  m.min_x_mm = s.require_float("min_x", coordinate);
  m.max_x_mm = s.require_float("max_x", coordinate);
  m.min_y_mm = s.require_float("min_y", coordinate);
  m.max_y_mm = s.require_float("max_y", coordinate);
  m.x_count = s.require_int("x_count", {.minval = 2, .maxval = kMaxFineCount});
  m.y_count = s.require_int("y_count", {.minval = 2, .maxval = kMaxFineCount});
  m.mesh_x_pps = s.require_int("mesh_x_pps", {.minval = 0, .maxval = kMaxFineCount});
  m.mesh_y_pps = s.require_int("mesh_y_pps", {.minval = 0, .maxval = kMaxFineCount});
  m.tension = s.require_float("tension", {.minval = 0.0, .maxval = 2.0});
  const std::string algo = std::string(trim(s.require_text("algo")));
  if (algo == "lagrange") {
    m.algo = Algorithm::lagrange;
  } else if (algo == "bicubic") {
    m.algo = Algorithm::bicubic;
  } else if (algo == "direct") {
    m.algo = Algorithm::direct;
  } else {
    throw Error(s.raw("algo")->where,
                fmt::format("[{}] algo: found '{}', expected lagrange, bicubic or direct", s.name(), algo));
  }
  if (!(m.max_x_mm > m.min_x_mm) || !(m.max_y_mm > m.min_y_mm)) {
    throw Error(s.raw(m.max_x_mm > m.min_x_mm ? "max_y" : "max_x")->where,
                fmt::format("[{}] the mesh spans x {:g}..{:g}, y {:g}..{:g}: expected min_x < max_x "
                            "and min_y < max_y",
                            s.name(), m.min_x_mm, m.max_x_mm, m.min_y_mm, m.max_y_mm));
  }
  if (m.algo == Algorithm::direct && (m.mesh_x_pps != 0 || m.mesh_y_pps != 0)) {
    throw Error(s.raw("algo")->where,
                fmt::format("[{}] algo: direct with mesh_x_pps {} and mesh_y_pps {}: expected both 0 "
                            "(Klipper saves 'direct' only for a mesh without interpolated points)",
                            s.name(), m.mesh_x_pps, m.mesh_y_pps));
  }
  if (m.algo == Algorithm::bicubic && (m.mesh_x_pps > 0 || m.mesh_y_pps > 0) &&
      std::min(m.x_count, m.y_count) < 3) {
    throw Error(s.raw("algo")->where,
                fmt::format("[{}] algo: bicubic needs at least 3 probed points along each axis, "
                            "found x_count {} and y_count {}",
                            s.name(), m.x_count, m.y_count));
  }
  // The upsampled grid is allocated whole: its size is checked before (Klipper has no limit;
  // a mesh of 15 x 15 probes at 4 points between them is 71 x 71).
  const bool upsample = m.algo != Algorithm::direct;
  const std::int64_t fine_x = std::int64_t{m.x_count - 1} * (upsample ? m.mesh_x_pps : 0) + m.x_count;
  const std::int64_t fine_y = std::int64_t{m.y_count - 1} * (upsample ? m.mesh_y_pps : 0) + m.y_count;
  if (fine_x > kMaxFineCount || fine_y > kMaxFineCount || fine_x * fine_y > kMaxFinePoints) {
    const char* key = fine_x > kMaxFineCount || (fine_y <= kMaxFineCount && m.mesh_x_pps > m.mesh_y_pps)
                          ? "mesh_x_pps" : "mesh_y_pps";
    throw Error(s.raw(key)->where,
                fmt::format("[{}] {}: found {} x {} probes with mesh_x_pps {} and mesh_y_pps {}, an "
                            "upsampled mesh of {} x {} points, expected at most {} along an axis and "
                            "{} in all",
                            s.name(), key, m.x_count, m.y_count, m.mesh_x_pps, m.mesh_y_pps, fine_x,
                            fine_y, kMaxFineCount, kMaxFinePoints));
  }
  if (rows.size() != static_cast<std::size_t>(m.y_count)) {
    throw Error(pts->where, fmt::format("[{}] points: found {} rows, expected y_count = {} rows of "
                                        "x_count = {} values",
                                        s.name(), rows.size(), m.y_count, m.x_count));
  }
  for (std::size_t j = 0; j < rows.size(); ++j) {
    if (rows[j].size() != static_cast<std::size_t>(m.x_count)) {
      std::uint64_t line = pts->where.line;
      std::string_view row_text;
      std::size_t seen = 0;
      std::string_view text = pts->text;
      std::size_t pos = 0, piece = 0;
      while (pos <= text.size()) {
        const std::size_t nl = text.find('\n', pos);
        const std::string_view r = text.substr(pos, nl == std::string_view::npos ? text.npos : nl - pos);
        if (!trim(r).empty() && seen++ == j) {
          line = piece < pts->lines.size() ? pts->lines[piece] : line;
          row_text = trim(r);
          break;
        }
        pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
        ++piece;
      }
      throw Error(SourceLocation{pts->where.file, line, file_column(pts->where.file, line, row_text, 0)},
                  fmt::format("[{}] points: row {} has {} values, expected x_count = {}", s.name(), j,
                              rows[j].size(), m.x_count));
    }
  }
  p.points_mm.reserve(static_cast<std::size_t>(m.x_count) * m.y_count);
  for (const auto& r : rows) p.points_mm.insert(p.points_mm.end(), r.begin(), r.end());
  return p;
}

std::string format_number(double v) { return fmt::format("{:.6g}", v); }

}  // namespace

const Profile* Settings::find(const std::string& name) const {
  for (const Profile& p : profiles) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

std::optional<Settings> read_klipper(const std::vector<ConfigSection>& sections, const SourceLocation& file) {
  std::vector<ConfigSection> own(sections);  // KlipperSection records defaults in the section
  ConfigSection* main = nullptr;
  for (ConfigSection& s : own) {
    if (s.name == "bed_mesh") main = &s;
  }
  if (main == nullptr) return std::nullopt;
  Settings out;
  const KlipperSection bm(main, "bed_mesh", file);
  out.where = bm.where();
  // The probing grid Klipper checks at start-up (BedMeshCalibrate._init_mesh_config).
  if (bm.has("mesh_radius")) {
    (void)bm.require_float("mesh_radius", {.above = 0.0});
    const int n = bm.get_int("round_probe_count", {.minval = 3}).value_or(5);
    if (n % 2 == 0) {
      throw Error(bm.raw("round_probe_count")->where,
                  fmt::format("[bed_mesh] round_probe_count: found {}, expected an odd number for a "
                              "round bed",
                              n));
    }
  } else {
    const auto count = read_pair(bm, "probe_count", true, std::array<double, 2>{3, 3});
    if (count[0] < 3 || count[1] < 3) {
      throw Error(bm.raw("probe_count")->where,
                  fmt::format("[bed_mesh] probe_count: found {:g}, {:g}, expected at least 3 each",
                              count[0], count[1]));
    }
    const auto lo = read_pair(bm, "mesh_min", false, std::nullopt);
    const auto hi = read_pair(bm, "mesh_max", false, std::nullopt);
    if (hi[0] <= lo[0] || hi[1] <= lo[1]) {
      throw Error(bm.raw("mesh_max")->where,
                  fmt::format("[bed_mesh] mesh_max: found {:g}, {:g} with mesh_min {:g}, {:g}, "
                              "expected each above mesh_min (Klipper: \"invalid min/max points\")",
                              hi[0], hi[1], lo[0], lo[1]));
    }
  }
  (void)bm.get_float("bicubic_tension", 0.2, {.minval = 0.0, .maxval = 2.0});
  if (const ConfigValue* a = bm.raw("algorithm")) {
    std::string algo(trim(a->text));
    for (char& c : algo) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (algo != "lagrange" && algo != "bicubic") {
      throw Error(a->where, fmt::format("[bed_mesh] algorithm: found '{}', expected lagrange or "
                                        "bicubic (Klipper: \"Unknown algorithm\")",
                                        a->text));
    }
  }
  out.fade_start_mm = bm.get_float("fade_start", 1.0);
  out.fade_end_mm = bm.get_float("fade_end", 0.0);
  // fade_end at or below fade_start turns fade off, as Klipper does (its Bed_Mesh document:
  // fade_end 0 disables it; any value not above fade_start leaves no fade distance). The
  // printer prints so, so amctl plans so; `machine show` says why fade is off.
  out.fade_enabled = out.fade_end_mm - out.fade_start_mm > 0.0;
  out.fade_target_mm = bm.get_float("fade_target");
  out.split_delta_z_mm = bm.get_float("split_delta_z", 0.025, {.minval = 0.01});
  out.move_check_distance_mm = bm.get_float("move_check_distance", 5.0, {.minval = 3.0});
  for (ConfigSection& s : own) {
    if (s.name.rfind("bed_mesh ", 0) != 0) continue;
    const std::string name(trim(std::string_view(s.name).substr(9)));
    const KlipperSection ps(&s, s.name, file);
    if (ps.get_int("version").value_or(0) != 1) {
      out.incompatible_profiles.push_back(name);
      continue;
    }
    out.profiles.push_back(read_profile(ps, name));
    (void)ZMesh(out.profiles.back());  // a grid its algorithm cannot upsample fails here
  }
  return out;
}

Json to_json(const Settings& s) {
  Json j;
  j["fade_start_mm"] = json_number(s.fade_start_mm);
  j["fade_end_mm"] = json_number(s.fade_end_mm);
  j["fade_enabled"] = s.fade_enabled;
  j["fade_target_mm"] = s.fade_target_mm ? json_number(*s.fade_target_mm) : Json(nullptr);
  j["move_check_distance_mm"] = json_number(s.move_check_distance_mm);
  j["split_delta_z_mm"] = json_number(s.split_delta_z_mm);
  Json profiles = Json::array();
  for (const Profile& p : s.profiles) {
    const ZMesh mesh(p);
    const auto [lo, hi] = mesh.z_range();
    double plo = p.points_mm.front(), phi = plo;
    for (double z : p.points_mm) {
      plo = std::min(plo, z);
      phi = std::max(phi, z);
    }
    Json e;
    e["name"] = p.name;
    e["algo"] = name(p.params.algo);
    e["x_count"] = p.params.x_count;
    e["y_count"] = p.params.y_count;
    e["mesh_x_pps"] = p.params.mesh_x_pps;
    e["mesh_y_pps"] = p.params.mesh_y_pps;
    e["tension"] = json_number(p.params.tension);
    e["min_mm"] = {json_number(p.params.min_x_mm), json_number(p.params.min_y_mm)};
    e["max_mm"] = {json_number(p.params.max_x_mm), json_number(p.params.max_y_mm)};
    e["probed_z_range_mm"] = {json_number(plo), json_number(phi)};
    e["mesh_count"] = {mesh.fine_x_count(), mesh.fine_y_count()};
    e["mesh_z_range_mm"] = {json_number(lo), json_number(hi)};
    e["mesh_z_average_mm"] = json_number(mesh.z_average_rounded());
    profiles.push_back(std::move(e));
  }
  j["profiles"] = std::move(profiles);
  j["incompatible_profiles"] = s.incompatible_profiles;
  return j;
}

std::string to_text(const Settings& s) {
  std::string out = fmt::format(
      "\n# Bed mesh ([bed_mesh]; applied from BED_MESH_PROFILE LOAD=NAME in the G-code on):\n"
      "#   fade                      {}\n"
      "#   move_check_distance       {} mm, split_delta_z {} mm\n",
      s.fade_enabled ? fmt::format("{} mm to {} mm", format_number(s.fade_start_mm), format_number(s.fade_end_mm))
      : s.fade_end_mm != 0.0
          ? fmt::format("off (fade_end {} mm is not above fade_start {} mm: Klipper disables fade)",
                        format_number(s.fade_end_mm), format_number(s.fade_start_mm))
          : std::string("off"),
      format_number(s.move_check_distance_mm), format_number(s.split_delta_z_mm));
  for (const Profile& p : s.profiles) {
    const ZMesh mesh(p);
    const auto [lo, hi] = mesh.z_range();
    out += fmt::format(
        "#   profile {:<17} {} x {} probed over x {}..{}, y {}..{} mm, {} to {} x {}, z {} .. {} mm\n",
        p.name, p.params.x_count, p.params.y_count, format_number(p.params.min_x_mm),
        format_number(p.params.max_x_mm), format_number(p.params.min_y_mm), format_number(p.params.max_y_mm),
        name(p.params.algo), mesh.fine_x_count(), mesh.fine_y_count(), format_number(lo), format_number(hi));
  }
  for (const std::string& n : s.incompatible_profiles) {
    out += fmt::format("#   profile {:<17} skipped: saved by another version of the format\n", n);
  }
  return out;
}

}  // namespace amctl::bedmesh
