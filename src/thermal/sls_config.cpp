// TOML reader for SlsBuildConfig (configs/sls_pa12.toml documents every key).
#include <limits>
#include <set>
#include <string>

#include <toml++/toml.h>

#include "amctl/core/error.hpp"
#include "amctl/core/input.hpp"
#include "amctl/thermal/powder_bed_sim.hpp"

namespace amctl::thermal {

namespace {

SourceLocation where(const std::string& path, const toml::source_region& src) {
  return SourceLocation{path, src.begin.line, static_cast<std::uint32_t>(src.begin.column)};
}

class Section {
 public:
  Section(const std::string& path, const toml::table& root, const char* name,
          std::set<std::string> keys)
      : path_(path), name_(name), keys_(std::move(keys)) {
    const toml::node* n = root.get(name);
    if (!n) return;
    tbl_ = n->as_table();
    if (!tbl_) throw Error(where(path, n->source()), std::string("[") + name + "] must be a table");
    for (const auto& [k, v] : *tbl_)
      if (!keys_.count(std::string(k.str())))
        throw Error(where(path, v.source()),
                    "unknown key '" + std::string(k.str()) + "' in [" + name_ +
                        "], expected one of the keys of configs/sls_pa12.toml");
  }
  void get(const char* key, double& out) const {
    const toml::node* n = tbl_ ? tbl_->get(key) : nullptr;
    if (!n) return;
    if (auto v = n->value<double>()) {
      out = *v;
      return;
    }
    throw Error(where(path_, n->source()), "[" + name_ + "] " + key + " must be a number");
  }
  void get(const char* key, int& out) const {
    const toml::node* n = tbl_ ? tbl_->get(key) : nullptr;
    if (!n) return;
    // Only an integer node: toml++'s value<int64_t>() converts a float node with a plain
    // cast, undefined for 1e308 (found by fuzz_sls_config under UBSan).
    if (auto v = n->is_integer() ? n->value<std::int64_t>() : std::nullopt) {
      if (*v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max()) {
        throw Error(where(path_, n->source()), "[" + name_ + "] " + key + ": found " +
                                                   std::to_string(*v) +
                                                   ", expected an integer in [-2147483648, 2147483647]");
      }
      out = int(*v);
      return;
    }
    throw Error(where(path_, n->source()), "[" + name_ + "] " + key + " must be an integer");
  }
  const toml::node* node(const char* key) const { return tbl_ ? tbl_->get(key) : nullptr; }
  std::string get_string(const char* key, const std::string& def) const {
    const toml::node* n = node(key);
    if (!n) return def;
    if (auto v = n->value<std::string>()) return *v;
    throw Error(where(path_, n->source()), "[" + name_ + "] " + key + " must be a string");
  }
  SourceLocation loc(const char* key) const {
    const toml::node* n = node(key);
    return n ? where(path_, n->source()) : SourceLocation{path_, 0, 0};
  }

 private:
  std::string path_, name_;
  std::set<std::string> keys_;
  const toml::table* tbl_ = nullptr;
};

// validate() names the field first ("density_kg_m3 (rho) must be ..."): the place of the
// key in the file that sets it, or the file alone when the value is a default or a
// combination of keys.
SourceLocation validated_key_location(const std::string& path, const toml::table& root,
                                      const std::string& message) {
  std::string field = message.substr(0, message.find_first_of(" ("));
  if (field == "layer_thickness_m") field = "layer_thickness_mm";
  for (const auto& [section, node] : root) {
    const toml::table* t = node.as_table();
    if (!t) continue;
    std::string key = field;
    if (section.str() == "laser" && key.rfind("laser_", 0) == 0) key = key.substr(6);
    if (const toml::node* n = t->get(key)) return where(path, n->source());
  }
  return SourceLocation{path, 0, 0};
}

}  // namespace

SlsBuildConfig load_sls_config(const std::string& path) {
  // Through amctl's one reader: a directory, a missing file, standard input ("-") or a FIFO
  // behave as everywhere else.
  const std::string text = read_whole_input(path, InputOptions{"SLS configuration (TOML)", false, 16ull << 20});
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    throw Error(where(path, e.source()), std::string("TOML parse error: ") + std::string(e.description()));
  }
  static const std::set<std::string> top{"material", "build", "controller", "laser", "numerics"};
  for (const auto& [k, v] : root)
    if (!top.count(std::string(k.str())))
      throw Error(where(path, v.source()), "unknown section '" + std::string(k.str()) +
                                              "', expected material, build, controller, "
                                              "laser or numerics");

  SlsBuildConfig c;
  const Section mat(path, root, "material",
                    {"density_kg_m3", "specific_heat_j_kgk", "conductivity_w_mk"});
  mat.get("density_kg_m3", c.material.density_kg_m3);
  mat.get("specific_heat_j_kgk", c.material.specific_heat_j_kgk);
  mat.get("conductivity_w_mk", c.material.conductivity_w_mk);

  const Section b(path, root, "build",
                  {"layer_thickness_mm", "initial_layers", "layers_added", "layer_time_s",
                   "initial_temp_c", "fresh_powder_temp_c", "setpoint_c", "setpoint_changes"});
  double l0_mm = c.layer_thickness_m * 1e3;
  b.get("layer_thickness_mm", l0_mm);
  c.layer_thickness_m = l0_mm * 1e-3;
  b.get("initial_layers", c.initial_layers);
  b.get("layers_added", c.layers_added);
  b.get("layer_time_s", c.layer_time_s);
  b.get("initial_temp_c", c.initial_temp_c);
  b.get("fresh_powder_temp_c", c.fresh_powder_temp_c);
  b.get("setpoint_c", c.setpoint_c);
  if (const toml::node* n = b.node("setpoint_changes")) {
    const toml::array* arr = n->as_array();
    if (!arr) throw Error(where(path, n->source()), "[build] setpoint_changes must be an array of tables");
    for (const auto& el : *arr) {
      const toml::table* t = el.as_table();
      auto from = t ? t->get("from_layer") : nullptr;
      auto sp = t ? t->get("setpoint_c") : nullptr;
      if (!t || !from || !sp || !from->is_integer() || !sp->value<double>())
        throw Error(where(path, el.source()),
                    "setpoint_changes entries need integer from_layer and number setpoint_c");
      const std::int64_t from_layer = *from->value<std::int64_t>();
      if (from_layer < 0 || from_layer > std::numeric_limits<int>::max())
        throw Error(where(path, from->source()),
                    "setpoint_changes from_layer: found " + std::to_string(from_layer) +
                        ", expected a layer number >= 0");
      c.setpoint_changes.push_back({int(from_layer), *sp->value<double>()});
    }
  }

  const Section ctl(path, root, "controller",
                    {"kp_w_m2k", "ti_s", "flux_min_w_m2", "flux_max_w_m2", "anti_windup",
                     "tracking_time_s"});
  ctl.get("kp_w_m2k", c.kp_w_m2k);
  ctl.get("ti_s", c.ti_s);
  ctl.get("flux_min_w_m2", c.flux_min_w_m2);
  ctl.get("flux_max_w_m2", c.flux_max_w_m2);
  ctl.get("tracking_time_s", c.tracking_time_s);
  const std::string aw = ctl.get_string("anti_windup", control::to_string(c.anti_windup));
  const auto parsed = control::anti_windup_from_string(aw);
  if (!parsed)
    throw Error(ctl.loc("anti_windup"),
                "[controller] anti_windup '" + aw +
                    "' unknown; expected none, clamp_integral, back_calculation or "
                    "conditional_integration");
  c.anti_windup = *parsed;

  const Section las(path, root, "laser", {"flux_w_m2", "start_s", "duration_s"});
  las.get("flux_w_m2", c.laser_flux_w_m2);
  las.get("start_s", c.laser_start_s);
  las.get("duration_s", c.laser_duration_s);

  const Section num(path, root, "numerics",
                    {"cells_per_layer", "dt_s", "scheme", "settle_band_k", "csv_every",
                     "coarsen", "coarsen_below_mm", "coarsen_grading"});
  num.get("cells_per_layer", c.cells_per_layer);
  num.get("dt_s", c.dt_s);
  num.get("settle_band_k", c.settle_band_k);
  num.get("csv_every", c.csv_every);
  if (const toml::node* n = num.node("coarsen")) {
    if (auto v = n->value<bool>()) c.coarsening.enabled = *v;
    else throw Error(where(path, n->source()), "[numerics] coarsen must be true or false");
  }
  double below_mm = c.coarsening.min_depth_m * 1e3;
  num.get("coarsen_below_mm", below_mm);
  c.coarsening.min_depth_m = below_mm * 1e-3;
  num.get("coarsen_grading", c.coarsening.grading);
  const std::string sc = num.get_string("scheme", to_string(c.scheme));
  if (sc == "tr_bdf2") c.scheme = TimeScheme::tr_bdf2;
  else if (sc == "bdf2") c.scheme = TimeScheme::bdf2;
  else if (sc == "crank_nicolson") c.scheme = TimeScheme::crank_nicolson;
  else if (sc == "backward_euler") c.scheme = TimeScheme::backward_euler;
  else
    throw Error(num.loc("scheme"), "[numerics] scheme '" + sc +
                "' unknown; expected tr_bdf2, bdf2, crank_nicolson or backward_euler");
  try {
    c.validate();
  } catch (const Error& e) {
    throw Error(validated_key_location(path, root, e.detail()), e.detail());
  }
  return c;
}

}  // namespace amctl::thermal
