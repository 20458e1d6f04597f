// TOML reader and checks of the 3D scenario (amctl/sls3d/config.hpp).
#include "amctl/sls3d/config.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <set>

#include "amctl/core/input.hpp"
#include "amctl/core/process_ranges.hpp"
#include "amctl/sls3d/scan.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

namespace amctl::sls3d {

namespace {

constexpr double kKelvin = 273.15;
constexpr double kStefanBoltzmann = 5.670374419e-8;

SourceLocation place(const std::string& path, const toml::source_region& src) {
  return SourceLocation{path, src.begin.line, static_cast<std::uint32_t>(src.begin.column)};
}

std::string g(double v) { return fmt::format("{:g}", v); }

// One [section]: typed getters that record where each key was set.
class Section {
 public:
  Section(const std::string& path, const toml::table& root, std::string name,
          std::set<std::string> keys, ScenarioConfig& c)
      : path_(path), name_(std::move(name)), keys_(std::move(keys)), c_(c) {
    const toml::node* n = root.get(name_);
    if (!n) return;
    tbl_ = n->as_table();
    if (!tbl_) throw Error(place(path, n->source()), "[" + name_ + "]: found a value, expected a table");
    for (const auto& [k, v] : *tbl_) {
      if (keys_.count(std::string(k.str()))) continue;
      std::string list;
      for (const auto& key : keys_) list += (list.empty() ? "" : ", ") + key;
      // At the key (toml++ records where each key was written).
      throw Error(place(path, k.source().begin ? k.source() : v.source()), "unknown key '" + std::string(k.str()) + "' in [" +
                                               name_ + "], expected one of " + list);
    }
  }
  const toml::node* node(const char* key) {
    const toml::node* n = tbl_ ? tbl_->get(key) : nullptr;
    if (n) c_.where[name_ + "." + key] = place(path_, n->source());
    else c_.defaulted.push_back(name_ + "." + key);
    return n;
  }
  void number(const char* key, double& out, double scale = 1.0) {
    const toml::node* n = node(key);
    if (!n) return;
    std::optional<double> v;
    if (n->is_floating_point()) v = n->value<double>();
    if (n->is_integer()) v = double(*n->value<std::int64_t>());
    if (!v) throw Error(place(path_, n->source()), "[" + name_ + "] " + key + ": found " +
                                                       type(*n) + ", expected a number");
    if (!std::isfinite(*v))
      throw Error(place(path_, n->source()),
                  "[" + name_ + "] " + key + ": found " + g(*v) + ", expected a finite number");
    out = *v * scale;
  }
  void integer(const char* key, int& out) {
    const toml::node* n = node(key);
    if (!n) return;
    if (!n->is_integer())
      throw Error(place(path_, n->source()), "[" + name_ + "] " + key + ": found " + type(*n) +
                                                 ", expected an integer");
    const std::int64_t v = *n->value<std::int64_t>();
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      throw Error(place(path_, n->source()), "[" + name_ + "] " + key + ": found " +
                                                 std::to_string(v) + ", expected an integer in int range");
    out = int(v);
  }
  void boolean(const char* key, bool& out) {
    const toml::node* n = node(key);
    if (!n) return;
    if (!n->is_boolean())
      throw Error(place(path_, n->source()), "[" + name_ + "] " + key + ": found " + type(*n) +
                                                 ", expected true or false");
    out = *n->value<bool>();
  }
  std::string text(const char* key, const std::string& def) {
    const toml::node* n = node(key);
    if (!n) return def;
    if (!n->is_string())
      throw Error(place(path_, n->source()), "[" + name_ + "] " + key + ": found " + type(*n) +
                                                 ", expected a string");
    return *n->value<std::string>();
  }
  void numbers(const char* key, std::vector<double>& out) {
    const toml::node* n = node(key);
    if (!n) return;
    const toml::array* a = n->as_array();
    if (!a) throw Error(place(path_, n->source()), "[" + name_ + "] " + key + ": found " + type(*n) +
                                                       ", expected an array of numbers");
    out.clear();
    for (const auto& el : *a) {
      std::optional<double> v;
      if (el.is_floating_point()) v = el.value<double>();
      if (el.is_integer()) v = double(*el.value<std::int64_t>());
      if (!v || !std::isfinite(*v))
        throw Error(place(path_, el.source()), "[" + name_ + "] " + key + ": found " + type(el) +
                                                   ", expected a finite number");
      out.push_back(*v);
    }
  }
  [[nodiscard]] SourceLocation loc(const char* key) const { return c_.at(name_ + "." + key); }

 private:
  static std::string type(const toml::node& n) {
    if (n.is_string()) return "a string";
    if (n.is_boolean()) return "a boolean";
    if (n.is_array()) return "an array";
    if (n.is_table()) return "a table";
    if (n.is_integer()) return "an integer";
    if (n.is_floating_point()) return "a number";
    return "a date or time";
  }
  std::string path_, name_;
  std::set<std::string> keys_;
  ScenarioConfig& c_;
  const toml::table* tbl_ = nullptr;
};

void material(Section& s, Material& m) {
  s.number("conductivity_w_mk", m.conductivity_w_mk);
  s.number("density_kg_m3", m.density_kg_m3);
  s.number("specific_heat_j_kgk", m.specific_heat_j_kgk);
}

}  // namespace

SourceLocation ScenarioConfig::at(const std::string& key) const {
  auto it = where.find(key);
  if (it != where.end()) return it->second;
  return SourceLocation{source, 0, 0};
}

double holding_flux_w_m2(const SurfaceLosses& l, double temp_c) {
  const double a = temp_c + kKelvin, b = l.radiation_env_c + kKelvin;
  return l.emissivity * kStefanBoltzmann * (a * a * a * a - b * b * b * b) +
         l.convection_w_m2k * (temp_c - l.gas_temp_c);
}

std::vector<LayerSchedule> layer_schedule(const ScenarioConfig& c) {
  // Layers are spread at step boundaries: the first at t = 0, each later one at the first
  // step boundary after the exposure before it ends (plus the recoat time).
  std::vector<LayerSchedule> out;
  double spread = 0.0;
  for (int i = 1; spread < c.end_time_s - 1e-9 * c.dt_s && i <= 100000; ++i) {
    LayerSchedule s;
    s.spread_s = spread;
    s.exposure_start_s = (i == 1) ? c.first_exposure_s : spread + c.preheat_s;
    HatchSettings h{c.hatch_m, c.scan_speed_m_s, c.hatch_angle_rad + (i - 1) * c.layer_rotation_rad};
    s.exposure_end_s = s.exposure_start_s +
                       hatch_ring(c.part_inner_radius_m, c.part_outer_radius_m, h).duration_s();
    out.push_back(s);
    spread = std::ceil((s.exposure_end_s + c.recoat_s) / c.dt_s - 1e-9) * c.dt_s;
  }
  return out;
}

void ScenarioConfig::validate() const {
  auto positive = [&](const char* key, double v, const char* what) {
    if (!(v > 0) || !std::isfinite(v))
      throw Error(at(key), std::string(key) + " (" + what + ") must be > 0, got " + g(v));
  };
  auto non_negative = [&](const char* key, double v, const char* what) {
    if (!(v >= 0) || !std::isfinite(v))
      throw Error(at(key), std::string(key) + " (" + what + ") must be >= 0, got " + g(v));
  };
  // Physical ranges (sizes and rates checked before anything is allocated or run): a build
  // platform of at most 10 m, a time step of at least 1 us, at most 10^6 steps and 10^6 coarse
  // columns, a laser of a machine (core/quantity.hpp).
  auto within = [&](const char* key, double v, double lo, double hi, const char* what) {
    if (!(v >= lo && v <= hi))
      throw Error(at(key), std::string(key) + " (" + what + ") must be in [" + g(lo) + ", " + g(hi) + "], got " + g(v));
  };
  within("bed.disc_radius_mm", disc_radius_m * 1e3, 1e-3, 1e4, "radius of the build platform, mm");
  within("bed.base_depth_mm", base_depth_m * 1e3, 1e-3, 1e4, "powder below the first layer, mm");
  within("bed.layer_thickness_mm", layer_thickness_m * 1e3, 1e-3, 1e3, "layer thickness, mm");
  if (layers > 100000) throw Error(at("bed.layers"), "bed.layers must be in [1, 100000], got " + std::to_string(layers));
  within("laser.power_w", laser_power_w, kPowerRange.min, kPowerRange.max, "W");
  within("laser.speed_mm_s", scan_speed_m_s * 1e3, kSpeedRange.min, kSpeedRange.max, "mm/s");
  within("laser.hatch_mm", hatch_m * 1e3, 1e-4, 1e4, "mm");
  within("laser.spot_radius_mm", spot_radius_m * 1e3, 1e-4, 1e4, "1/e^2 radius, mm");
  within("laser.field_radius_mm", field_radius_m * 1e3, 1e-3, 1e5, "mm");
  within("numerics.coarse_cell_mm", coarse_cell_m * 1e3, 1e-3, 1e4, "in-plane size of the coarse cells, mm");
  within("numerics.dt_s", dt_s, 1e-6, 1e6, "time step, s");
  within("output.end_time_s", end_time_s, 1e-6, 1e7, "s");
  if (end_time_s / dt_s > 1e6)
    throw Error(at(where.count("output.end_time_s") ? "output.end_time_s" : "numerics.dt_s"),
                "the run to " + g(end_time_s) + " s in steps of " + g(dt_s) + " s: found " + g(end_time_s / dt_s) +
                    " steps, expected at most 1e6 (output.end_time_s / numerics.dt_s)");
  const double columns = std::pow(2.0 * disc_radius_m / coarse_cell_m, 2.0);
  if (columns > 1e6)
    throw Error(at(where.count("numerics.coarse_cell_mm") ? "numerics.coarse_cell_mm" : "bed.disc_radius_mm"),
                "a disc of radius " + g(disc_radius_m * 1e3) + " mm in coarse cells of " + g(coarse_cell_m * 1e3) +
                    " mm: found " + g(columns) + " columns of cells, expected at most 1e6");
  positive("bed.disc_radius_mm", disc_radius_m * 1e3, "radius of the build platform, mm");
  positive("bed.base_depth_mm", base_depth_m * 1e3, "powder below the first layer, mm");
  positive("bed.layer_thickness_mm", layer_thickness_m * 1e3, "layer thickness, mm");
  if (layers < 1) throw Error(at("bed.layers"), "bed.layers must be >= 1, got " + std::to_string(layers));
  const char* props[][2] = {{"conductivity_w_mk", "W/(m K)"}, {"density_kg_m3", "kg/m^3"},
                            {"specific_heat_j_kgk", "J/(kg K)"}};
  for (const char* section : {"powder", "sintered"}) {
    const Material& m = std::string(section) == "powder" ? powder : sintered;
    const double v[3] = {m.conductivity_w_mk, m.density_kg_m3, m.specific_heat_j_kgk};
    for (int i = 0; i < 3; ++i)
      positive((std::string(section) + "." + props[i][0]).c_str(), v[i], props[i][1]);
  }
  if (melting.enabled) {
    non_negative("melting.latent_heat_j_kg", melting.latent_heat_j_kg, "J/kg");
    if (!(melting.liquidus_c > melting.solidus_c))
      throw Error(at("melting.liquidus_c"), "melting.liquidus_c must be > solidus_c = " +
                                                g(melting.solidus_c) + ", got " + g(melting.liquidus_c));
  }
  if (!(losses.emissivity >= 0 && losses.emissivity <= 1))
    throw Error(at("losses.emissivity"), "losses.emissivity must be in [0, 1], got " + g(losses.emissivity));
  non_negative("losses.convection_w_m2k", losses.convection_w_m2k, "W/(m^2 K)");
  if (!(part_inner_radius_m >= 0))
    throw Error(at("part.inner_radius_mm"),
                "part.inner_radius_mm must be >= 0, got " + g(part_inner_radius_m * 1e3));
  if (!(part_outer_radius_m > part_inner_radius_m))
    throw Error(at("part.outer_radius_mm"), "part.outer_radius_mm must be > inner_radius_mm = " +
                                                g(part_inner_radius_m * 1e3) + ", got " +
                                                g(part_outer_radius_m * 1e3));
  if (!(part_outer_radius_m < disc_radius_m))
    throw Error(at(where.count("part.outer_radius_mm") || !where.count("bed.disc_radius_mm") ? "part.outer_radius_mm"
                                                                                            : "bed.disc_radius_mm"),
                "the part does not fit the disc: found outer radius " + g(part_outer_radius_m * 1e3) +
                    " mm, expected < the disc radius " + g(disc_radius_m * 1e3) + " mm");
  positive("laser.power_w", laser_power_w, "W");
  if (!(absorptivity > 0 && absorptivity <= 1))
    throw Error(at("laser.absorptivity"), "laser.absorptivity must be in (0, 1], got " + g(absorptivity));
  positive("laser.speed_mm_s", scan_speed_m_s * 1e3, "mm/s");
  positive("laser.hatch_mm", hatch_m * 1e3, "mm");
  positive("laser.spot_radius_mm", spot_radius_m * 1e3, "1/e^2 radius, mm");
  positive("laser.field_radius_mm", field_radius_m * 1e3, "mm");
  non_negative("laser.first_exposure_s", first_exposure_s, "s");
  non_negative("laser.preheat_s", preheat_s, "s");
  non_negative("laser.recoat_s", recoat_s, "s");
  if (!(hatch_m < part_outer_radius_m - part_inner_radius_m))
    throw Error(at("laser.hatch_mm"), "laser.hatch_mm must be below the ring's width " +
                                          g((part_outer_radius_m - part_inner_radius_m) * 1e3) +
                                          " mm, got " + g(hatch_m * 1e3));
  if (field_radius_m < part_outer_radius_m)
    throw Error(at("laser.field_radius_mm"),
                "the laser never reaches the part: found a scan field of radius " +
                    g(field_radius_m * 1e3) + " mm, expected at least the part's outer radius " +
                    g(part_outer_radius_m * 1e3) + " mm");
  positive("output.end_time_s", end_time_s, "s");
  if (!(first_exposure_s < end_time_s))
    throw Error(at("laser.first_exposure_s"),
                "the laser never reaches the part: found the first exposure at " + g(first_exposure_s) +
                    " s, expected before the end of the run at " + g(end_time_s) + " s");
  non_negative("controller.kp_w_m2k", kp_w_m2k, "W/(m^2 K)");
  positive("controller.ti_s", ti_s, "PI integral time, s");
  positive("controller.tracking_time_s", tracking_time_s, "s");
  if (!(flux_max_w_m2 > flux_min_w_m2) || !std::isfinite(flux_max_w_m2) || !std::isfinite(flux_min_w_m2))
    throw Error(at("controller.flux_max_w_m2"), "controller.flux_max_w_m2 must be > flux_min_w_m2 = " +
                                                    g(flux_min_w_m2) + ", got " + g(flux_max_w_m2));
  if (measurement.kind == TopWeight::Kind::spot)
    positive("measurement.radius_mm", measurement.radius_m * 1e3, "1/e^2 radius of the pyrometer spot, mm");
  if (std::hypot(measurement.x_m, measurement.y_m) >= disc_radius_m)
    throw Error(at("measurement.x_mm"), "the measured point (" + g(measurement.x_m * 1e3) + ", " +
                                            g(measurement.y_m * 1e3) +
                                            ") mm is off the disc, expected within its radius " +
                                            g(disc_radius_m * 1e3) + " mm");
  if (measurement.kind == TopWeight::Kind::area &&
      !(measurement.outer_radius_m > measurement.inner_radius_m && measurement.inner_radius_m >= 0))
    throw Error(at("measurement.outer_radius_mm"),
                "measurement.outer_radius_mm must be > inner_radius_mm >= 0, got " +
                    g(measurement.outer_radius_m * 1e3));
  // Time step.
  if (!(dt_s > 0) || !std::isfinite(dt_s))
    throw Error(at("numerics.dt_s"), "numerics.dt_s (time step) must be > 0, got " + g(dt_s));
  if (!(theta >= 0.5 && theta <= 1.0))
    throw Error(at("numerics.scheme"), "the time scheme's theta must be in [0.5, 1], got " + g(theta));
  auto on_grid = [&](double t) {
    const double n = std::round(t / dt_s);
    return std::abs(n * dt_s - t) <= 1e-9 * std::max(1.0, t);
  };
  if (!on_grid(end_time_s)) {
    // Blame the key the file set (the step when the end time is the default).
    if (where.count("output.end_time_s") || !where.count("numerics.dt_s"))
      throw Error(at("output.end_time_s"), "output.end_time_s: found " + g(end_time_s) +
                                               " s, expected a whole number of time steps of " + g(dt_s) + " s");
    throw Error(at("numerics.dt_s"), "numerics.dt_s: found " + g(dt_s) + " s, expected a step that divides the run's " +
                                         g(end_time_s) + " s (output.end_time_s)");
  }
  for (double t : snapshot_times_s)
    if (!(t >= 0 && t <= end_time_s) || !on_grid(t))
      throw Error(at("output.snapshot_times_s"),
                  "output.snapshot_times_s: found " + g(t) + " s, expected a whole number of time steps of " +
                      g(dt_s) + " s within [0, " + g(end_time_s) + "] s");
  const double period = preheat_s + recoat_s + std::numbers::pi *
                            (part_outer_radius_m * part_outer_radius_m -
                             part_inner_radius_m * part_inner_radius_m) /
                            (hatch_m * scan_speed_m_s);
  if (dt_s > period)
    throw Error(at("numerics.dt_s"), "numerics.dt_s: found " + g(dt_s) +
                                         " s, expected at most the layer period " + g(period) +
                                         " s (preheat + scan + recoat), so that each layer gets its own steps");
  if (dt_s > end_time_s)
    throw Error(at("numerics.dt_s"), "numerics.dt_s: found " + g(dt_s) + " s, expected at most the run's " +
                                         g(end_time_s) + " s");
  if (source_scale == SourceScale::fine && scan_speed_m_s * dt_s > spot_radius_m)
    throw Error(at("numerics.dt_s"),
                "numerics.dt_s: the fine source scale needs the spot to move at most its radius per step: found v dt = " +
                    g(scan_speed_m_s * dt_s * 1e3) + " mm, expected <= " + g(spot_radius_m * 1e3) +
                    " mm (dt <= " + g(spot_radius_m / scan_speed_m_s) + " s)");
  const std::size_t spread = layer_schedule(*this).size();
  if (spread > std::size_t(layers))
    throw Error(at("bed.layers"), "the run to " + g(end_time_s) + " s spreads " + std::to_string(spread) +
                                      " layers: found bed.layers = " + std::to_string(layers) +
                                      ", expected at least " + std::to_string(spread));
  positive("numerics.coarse_cell_mm", coarse_cell_m * 1e3, "in-plane size of the coarse cells, mm");
  if (cells_per_layer < 1 || cells_per_layer > 16)
    throw Error(at("numerics.cells_per_layer"),
                "numerics.cells_per_layer must be in [1, 16], got " + std::to_string(cells_per_layer));
  for (auto [key, v] : {std::pair{"numerics.edge_level", edge_level}, {"numerics.part_level", part_level},
                        {"numerics.laser_level", laser_level}})
    if (v < 0 || v > 6)
      throw Error(at(key), std::string(key) + " must be in [0, 6], got " + std::to_string(v));
  if (global_refinements < 0 || global_refinements > 3)
    throw Error(at("numerics.global_refinements"),
                "numerics.global_refinements must be in [0, 3], got " + std::to_string(global_refinements));
  positive("numerics.edge_band_mm", edge_band_m * 1e3, "mm");
  positive("numerics.refine_depth_mm", refine_depth_m * 1e3, "mm");
  if (map_pixels < 8 || map_pixels > 2000)
    throw Error(at("output.map_pixels"), "output.map_pixels must be in [8, 2000], got " + std::to_string(map_pixels));
  positive("numerics.linear_tolerance", solver.linear_rel_tol, "relative");
  positive("numerics.newton_tolerance", solver.newton_rel_tol, "relative");
}

ScenarioConfig load_scenario_config(const std::string& path) {
  // Through amctl's one reader: a directory, a missing file, standard input ("-") or a FIFO
  // behave as everywhere else.
  const std::string text =
      read_whole_input(path, InputOptions{"3D SLS scenario configuration (TOML)", false, 16ull << 20});
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw Error(place(path, e.source()), "TOML: " + std::string(e.description()) + ", expected valid TOML");
  }
  const std::set<std::string> sections{"bed", "part", "powder", "sintered", "melting", "losses",
                                       "laser", "controller", "measurement", "numerics", "output"};
  // An empty file (or one of comments only) is a mistake, not a request for the defaults:
  // those run without --config.
  if (root.empty())
    throw Error(SourceLocation{path, 1, 1},
                "found no section (the file is empty or holds only comments), expected at least one of "
                "[bed], [part], [powder], [sintered], [melting], [losses], [laser], [controller], "
                "[measurement], [numerics] or [output] (without --config the built-in values run)");
  for (const auto& [k, v] : root)
    if (!sections.count(std::string(k.str())))
      throw Error(place(path, v.source()),
                  "unknown section '" + std::string(k.str()) +
                      "', expected bed, part, powder, sintered, melting, losses, laser, controller, "
                      "measurement, numerics or output");
  ScenarioConfig c;
  c.source = path;
  {
    Section s(path, root, "bed",
              {"disc_radius_mm", "base_depth_mm", "layer_thickness_mm", "layers", "initial_temp_c",
               "fresh_powder_temp_c"}, c);
    s.number("disc_radius_mm", c.disc_radius_m, 1e-3);
    s.number("base_depth_mm", c.base_depth_m, 1e-3);
    s.number("layer_thickness_mm", c.layer_thickness_m, 1e-3);
    s.integer("layers", c.layers);
    s.number("initial_temp_c", c.initial_temp_c);
    s.number("fresh_powder_temp_c", c.fresh_powder_temp_c);
  }
  {
    Section s(path, root, "part", {"inner_radius_mm", "outer_radius_mm"}, c);
    s.number("inner_radius_mm", c.part_inner_radius_m, 1e-3);
    s.number("outer_radius_mm", c.part_outer_radius_m, 1e-3);
  }
  {
    Section s(path, root, "powder", {"conductivity_w_mk", "density_kg_m3", "specific_heat_j_kgk"}, c);
    material(s, c.powder);
  }
  {
    Section s(path, root, "sintered", {"conductivity_w_mk", "density_kg_m3", "specific_heat_j_kgk"}, c);
    material(s, c.sintered);
  }
  {
    Section s(path, root, "melting", {"enabled", "solidus_c", "liquidus_c", "latent_heat_j_kg"}, c);
    s.boolean("enabled", c.melting.enabled);
    s.number("solidus_c", c.melting.solidus_c);
    s.number("liquidus_c", c.melting.liquidus_c);
    s.number("latent_heat_j_kg", c.melting.latent_heat_j_kg);
  }
  {
    Section s(path, root, "losses", {"emissivity", "radiation_env_c", "convection_w_m2k", "gas_temp_c"}, c);
    s.number("emissivity", c.losses.emissivity);
    s.number("radiation_env_c", c.losses.radiation_env_c);
    s.number("convection_w_m2k", c.losses.convection_w_m2k);
    s.number("gas_temp_c", c.losses.gas_temp_c);
  }
  {
    Section s(path, root, "laser",
              {"power_w", "absorptivity", "speed_mm_s", "hatch_mm", "spot_radius_mm", "field_radius_mm",
               "hatch_angle_deg", "layer_rotation_deg", "first_exposure_s", "preheat_s", "recoat_s"}, c);
    s.number("power_w", c.laser_power_w);
    s.number("absorptivity", c.absorptivity);
    s.number("speed_mm_s", c.scan_speed_m_s, 1e-3);
    s.number("hatch_mm", c.hatch_m, 1e-3);
    s.number("spot_radius_mm", c.spot_radius_m, 1e-3);
    s.number("field_radius_mm", c.field_radius_m, 1e-3);
    s.number("hatch_angle_deg", c.hatch_angle_rad, std::numbers::pi / 180.0);
    s.number("layer_rotation_deg", c.layer_rotation_rad, std::numbers::pi / 180.0);
    s.number("first_exposure_s", c.first_exposure_s);
    s.number("preheat_s", c.preheat_s);
    s.number("recoat_s", c.recoat_s);
  }
  {
    Section s(path, root, "controller",
              {"setpoint_c", "kp_w_m2k", "ti_s", "flux_min_w_m2", "flux_max_w_m2", "anti_windup",
               "tracking_time_s", "start_at_holding_flux"}, c);
    s.number("setpoint_c", c.setpoint_c);
    s.number("kp_w_m2k", c.kp_w_m2k);
    s.number("ti_s", c.ti_s);
    s.number("flux_min_w_m2", c.flux_min_w_m2);
    s.number("flux_max_w_m2", c.flux_max_w_m2);
    s.number("tracking_time_s", c.tracking_time_s);
    s.boolean("start_at_holding_flux", c.start_at_holding_flux);
    const std::string aw = s.text("anti_windup", control::to_string(c.anti_windup));
    const auto parsed = control::anti_windup_from_string(aw);
    if (!parsed)
      throw Error(s.loc("anti_windup"), "[controller] anti_windup: found '" + aw +
                                            "', expected none, clamp_integral, back_calculation or "
                                            "conditional_integration");
    c.anti_windup = *parsed;
  }
  {
    Section s(path, root, "measurement",
              {"kind", "x_mm", "y_mm", "radius_mm", "inner_radius_mm", "outer_radius_mm"}, c);
    const std::string kind = s.text("kind", "spot");
    if (kind == "spot") c.measurement.kind = TopWeight::Kind::spot;
    else if (kind == "area_mean") c.measurement.kind = TopWeight::Kind::area;
    else
      throw Error(s.loc("kind"), "[measurement] kind: found '" + kind + "', expected spot or area_mean");
    s.number("x_mm", c.measurement.x_m, 1e-3);
    s.number("y_mm", c.measurement.y_m, 1e-3);
    s.number("radius_mm", c.measurement.radius_m, 1e-3);
    s.number("inner_radius_mm", c.measurement.inner_radius_m, 1e-3);
    s.number("outer_radius_mm", c.measurement.outer_radius_m, 1e-3);
  }
  {
    Section s(path, root, "numerics",
              {"source_scale", "dt_s", "scheme", "coarse_cell_mm", "cells_per_layer", "edge_level",
               "edge_band_mm", "part_level", "laser_level", "refine_depth_mm", "preconditioner",
               "linear_tolerance", "newton_tolerance", "global_refinements"}, c);
    const std::string scale = s.text("source_scale", "part_scale");
    if (scale == "part_scale") c.source_scale = SourceScale::part_scale;
    else if (scale == "fine") c.source_scale = SourceScale::fine;
    else
      throw Error(s.loc("source_scale"), "[numerics] source_scale: found '" + scale +
                                             "', expected part_scale or fine");
    s.number("dt_s", c.dt_s);
    const std::string scheme = s.text("scheme", "backward_euler");
    if (scheme == "backward_euler") c.theta = 1.0;
    else if (scheme == "crank_nicolson") c.theta = 0.5;
    else
      throw Error(s.loc("scheme"), "[numerics] scheme: found '" + scheme +
                                       "', expected backward_euler or crank_nicolson");
    s.number("coarse_cell_mm", c.coarse_cell_m, 1e-3);
    s.integer("cells_per_layer", c.cells_per_layer);
    s.integer("edge_level", c.edge_level);
    s.number("edge_band_mm", c.edge_band_m, 1e-3);
    s.integer("part_level", c.part_level);
    s.integer("laser_level", c.laser_level);
    s.number("refine_depth_mm", c.refine_depth_m, 1e-3);
    s.integer("global_refinements", c.global_refinements);
    const std::string pre = s.text("preconditioner", "amg");
    if (pre == "amg") c.solver.preconditioner = SolverSettings::Preconditioner::amg;
    else if (pre == "jacobi") c.solver.preconditioner = SolverSettings::Preconditioner::jacobi;
    else if (pre == "ssor") c.solver.preconditioner = SolverSettings::Preconditioner::ssor;
    else
      throw Error(s.loc("preconditioner"), "[numerics] preconditioner: found '" + pre +
                                               "', expected amg, jacobi or ssor");
    s.number("linear_tolerance", c.solver.linear_rel_tol);
    s.number("newton_tolerance", c.solver.newton_rel_tol);
  }
  {
    Section s(path, root, "output", {"end_time_s", "snapshot_times_s", "map_pixels"}, c);
    s.number("end_time_s", c.end_time_s);
    s.numbers("snapshot_times_s", c.snapshot_times_s);
    s.integer("map_pixels", c.map_pixels);
  }
  c.validate();
  return c;
}

}  // namespace amctl::sls3d
