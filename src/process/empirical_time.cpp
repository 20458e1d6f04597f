#include "amctl/process/empirical_time.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/gcode/events.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::process {
namespace {

enum class FeatureClass { infill, contour };

FeatureClass classify(std::string name) {
  for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const char* k : {"perimeter", "wall", "skirt", "brim", "gap", "outer", "inner"}) {
    if (name.find(k) != std::string::npos) return FeatureClass::contour;
  }
  for (const char* k : {"infill", "fill", "skin", "support", "bridge", "ironing"}) {
    if (name.find(k) != std::string::npos) return FeatureClass::infill;
  }
  return FeatureClass::contour;
}

// Hat-function weights of width w over the sorted table.
void add_link(std::vector<double>& by_width, const std::vector<double>& widths, double w,
              double len) {
  const std::size_t k = widths.size();
  if (k == 1 || w <= widths.front()) {
    by_width.front() += len;
    return;
  }
  if (w >= widths.back()) {
    by_width.back() += len;
    return;
  }
  std::size_t i = 0;
  while (!(w <= widths[i + 1])) ++i;
  const double t = (w - widths[i]) / (widths[i + 1] - widths[i]);
  by_width[i] += (1.0 - t) * len;
  by_width[i + 1] += t * len;
}

class ScanSink final : public gcode::EventSink {
 public:
  ScanSink(const ScanOptions& o, GcodeTimeScan& out) : opt_(o), out_(out) {
    out_.total.link_mm_by_width.assign(o.link_widths_mm.size(), 0.0);
    out_.total.files = 1.0;
    filament_area_ = std::numbers::pi * o.filament_diameter_mm * o.filament_diameter_mm / 4.0;
  }
  const gcode::Interpreter* interp = nullptr;

  TimeFeatures& layer_slot(std::int32_t layer) {
    if (layer < 0) return scratch_;
    if (out_.layers.size() <= static_cast<std::size_t>(layer)) {
      TimeFeatures f;
      f.link_mm_by_width.assign(opt_.link_widths_mm.size(), 0.0);
      out_.layers.resize(static_cast<std::size_t>(layer) + 1, f);
    }
    return out_.layers[static_cast<std::size_t>(layer)];
  }

  void on_move(const gcode::MoveRequest& m) override {
    const double dx = m.end_mm[0] - m.start_mm[0], dy = m.end_mm[1] - m.start_mm[1],
                 dz = m.end_mm[2] - m.start_mm[2], de = m.end_mm[3] - m.start_mm[3];
    const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double xy = std::hypot(dx, dy);
    const bool extruding = de > 0 && xy > 0;
    std::int32_t layer = m.layer;
    if (extruding && m.end_mm[2] > last_layer_z_ + 1e-6) {
      // A new extrusion height: a layer change (counted once per layer).
      layer_height_ = have_layer_ ? m.end_mm[2] - last_layer_z_ : m.end_mm[2];
      last_layer_z_ = m.end_mm[2];
      have_layer_ = true;
      ++z_layer_;
      pending_layer_change_ = true;
    }
    if (layer < 0 && have_layer_) layer = z_layer_ - 1;
    TimeFeatures& lf = layer_slot(layer);
    auto both = [&](auto&& fn) {
      fn(out_.total);
      fn(lf);
    };
    if (pending_layer_change_ && extruding) {
      both([](TimeFeatures& f) { f.layer_changes += 1.0; });
      pending_layer_change_ = false;
    }
    if (extruding) {
      const double area = de * filament_area_ / xy;
      const double h = layer_height_ > 0 ? layer_height_ : 0.0;
      const double w = h > 0 ? area / h + h * (1.0 - std::numbers::pi / 4.0) : opt_.default_width_mm;
      const auto& names = interp->annotations().feature_names;
      const std::string name = m.feature < names.size() ? names[m.feature] : "unknown";
      if (classify(name) == FeatureClass::contour) {
        both([&](TimeFeatures& f) { f.contour_mm += xy; });
      } else if (xy <= opt_.link_length_widths * w) {
        both([&](TimeFeatures& f) {
          f.link_mm += xy;
          add_link(f.link_mm_by_width, opt_.link_widths_mm, w, xy);
        });
        ++out_.link_moves;
      } else {
        both([&](TimeFeatures& f) { f.raster_mm += xy; });
        ++out_.raster_moves;
        raster_width_sum_ += w * xy;
        raster_len_ += xy;
      }
    } else if (len > 0) {
      both([&](TimeFeatures& f) { f.travel_mm += len; });
      if (de < 0 && xy > 0) both([](TimeFeatures& f) { f.wipes += 1.0; });
    } else if (de < 0) {
      both([](TimeFeatures& f) { f.retracts += 1.0; });
    }
  }

  void finish() {
    out_.mean_raster_width_mm = raster_len_ > 0 ? raster_width_sum_ / raster_len_ : 0.0;
  }

 private:
  const ScanOptions& opt_;
  GcodeTimeScan& out_;
  TimeFeatures scratch_;
  double filament_area_ = 0.0;
  double last_layer_z_ = -1e300;
  double layer_height_ = 0.0;
  bool have_layer_ = false;
  bool pending_layer_change_ = false;
  std::int32_t z_layer_ = 0;
  double raster_width_sum_ = 0.0, raster_len_ = 0.0;
};

void check_scan_options(const ScanOptions& o) {
  if (o.link_widths_mm.empty()) throw Error("link width table is empty");
  for (std::size_t i = 0; i < o.link_widths_mm.size(); ++i) {
    require_positive("link width", o.link_widths_mm[i]);
    if (i && !(o.link_widths_mm[i] > o.link_widths_mm[i - 1])) {
      throw Error(fmt::format("link widths must be strictly increasing: {} follows {}",
                              o.link_widths_mm[i], o.link_widths_mm[i - 1]));
    }
  }
  require_positive("link_length_widths", o.link_length_widths);
  require_positive("filament_diameter_mm", o.filament_diameter_mm);
  require_positive("default_width_mm", o.default_width_mm);
}

GcodeTimeScan run_scan(gcode::LineReader& reader, const ScanOptions& o) {
  check_scan_options(o);
  GcodeTimeScan out;
  ScanSink sink(o, out);
  gcode::Interpreter interp(gcode::InterpreterOptions{}, reader.name());
  sink.interp = &interp;
  interp.run(reader, sink);
  sink.finish();
  out.feature_names = interp.annotations().feature_names;
  out.slicer_estimate_s = interp.annotations().slicer_estimate_s;
  return out;
}

}  // namespace

GcodeTimeScan scan_gcode_for_time(std::string_view text, const std::string& name,
                                  const ScanOptions& o) {
  gcode::LineReader reader(text, name);
  return run_scan(reader, o);
}

GcodeTimeScan scan_gcode_file_for_time(const std::string& path, const ScanOptions& o) {
  const auto reader = formats::open_gcode_reader(path);
  return run_scan(*reader, o);
}

void EmpiricalTimeModel::validate() const {
  require_positive("raster_speed_mm_s", raster_speed_mm_s);
  require_positive("contour_speed_mm_s", contour_speed_mm_s);
  require_positive("travel_speed_mm_s", travel_speed_mm_s);
  if (link_widths_mm.empty() || link_widths_mm.size() != link_speeds_mm_s.size()) {
    throw Error(fmt::format("link table needs one speed per width ({} widths, {} speeds)",
                            link_widths_mm.size(), link_speeds_mm_s.size()));
  }
  for (std::size_t i = 0; i < link_widths_mm.size(); ++i) {
    require_positive("link width", link_widths_mm[i]);
    require_positive("link speed", link_speeds_mm_s[i]);
    if (i && !(link_widths_mm[i] > link_widths_mm[i - 1])) {
      throw Error("link widths must be strictly increasing");
    }
  }
  require_finite("layer_change_s", layer_change_s);
  require_finite("retract_s", retract_s);
  require_finite("wipe_s", wipe_s);
  require_finite("fixed_s", fixed_s);
}

EmpiricalTimeModel EmpiricalTimeModel::fdm2000_seed() { return EmpiricalTimeModel{}; }

std::vector<std::string> empirical_parameter_names(const EmpiricalTimeModel& m) {
  std::vector<std::string> n{"raster_pace", "contour_pace"};
  for (double w : m.link_widths_mm) n.push_back(fmt::format("link_pace@{:g}", w));
  for (const char* s : {"travel_pace", "layer_change_s", "retract_s", "wipe_s", "fixed_s"}) {
    n.emplace_back(s);
  }
  return n;
}

std::vector<double> empirical_parameters(const EmpiricalTimeModel& m) {
  std::vector<double> p{1.0 / m.raster_speed_mm_s, 1.0 / m.contour_speed_mm_s};
  for (double v : m.link_speeds_mm_s) p.push_back(1.0 / v);
  p.push_back(1.0 / m.travel_speed_mm_s);
  p.push_back(m.layer_change_s);
  p.push_back(m.retract_s);
  p.push_back(m.wipe_s);
  p.push_back(m.fixed_s);
  return p;
}

EmpiricalTimeModel with_parameters(const EmpiricalTimeModel& base, const std::vector<double>& p) {
  AMCTL_CHECK(p.size() == empirical_parameter_names(base).size(), "parameter count");
  const auto names = empirical_parameter_names(base);
  auto speed = [&](std::size_t i) {
    if (!(p[i] > 0.0)) {
      throw Error(fmt::format("fitted {} = {:.4g} s/mm is not positive, so no finite speed "
                              "explains the data; fix it (--fix {}=...) or add samples that "
                              "vary it",
                              names[i], p[i], names[i]));
    }
    return 1.0 / p[i];
  };
  EmpiricalTimeModel m = base;
  m.raster_speed_mm_s = speed(0);
  m.contour_speed_mm_s = speed(1);
  const std::size_t k = base.link_widths_mm.size();
  for (std::size_t i = 0; i < k; ++i) m.link_speeds_mm_s[i] = speed(2 + i);
  m.travel_speed_mm_s = speed(2 + k);
  m.layer_change_s = p[3 + k];
  m.retract_s = p[4 + k];
  m.wipe_s = p[5 + k];
  m.fixed_s = p[6 + k];
  return m;
}

std::vector<double> empirical_row(const TimeFeatures& f, const EmpiricalTimeModel& m) {
  if (f.link_mm_by_width.size() != m.link_widths_mm.size()) {
    throw Error(fmt::format("features were scanned with {} link widths but the model has {}",
                            f.link_mm_by_width.size(), m.link_widths_mm.size()));
  }
  std::vector<double> r{f.raster_mm, f.contour_mm};
  r.insert(r.end(), f.link_mm_by_width.begin(), f.link_mm_by_width.end());
  r.push_back(f.travel_mm);
  r.push_back(f.layer_changes);
  r.push_back(f.retracts);
  r.push_back(f.wipes);
  r.push_back(f.files);
  return r;
}

double EmpiricalTimeModel::estimate_s(const TimeFeatures& f) const {
  validate();
  const auto r = empirical_row(f, *this);
  const auto p = empirical_parameters(*this);
  double t = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) t += r[i] * p[i];
  return t;
}

EmpiricalFit fit_empirical(const std::vector<TimeFeatures>& samples,
                           const std::vector<double>& durations, const EmpiricalTimeModel& start,
                           const EmpiricalFitOptions& opt) {
  start.validate();
  if (samples.size() != durations.size()) {
    throw Error(fmt::format("{} samples but {} durations", samples.size(), durations.size()));
  }
  for (std::size_t i = 0; i < durations.size(); ++i) {
    if (!std::isfinite(durations[i]) || durations[i] < 0.0) {
      throw Error(fmt::format("measured duration {} must be a finite number >= 0 s, got {}", i + 1,
                              durations[i]));
    }
  }
  const auto names = empirical_parameter_names(start);
  const auto p0 = empirical_parameters(start);
  const std::size_t P = names.size(), n = samples.size();
  std::vector<bool> free(P, true);
  for (const auto& f : opt.fixed) {
    const auto it = std::find(names.begin(), names.end(), f);
    if (it == names.end()) {
      std::string all;
      for (const auto& s : names) all += (all.empty() ? "" : ", ") + s;
      throw Error(fmt::format("unknown parameter '{}' to fix (known: {})", f, all));
    }
    free[static_cast<std::size_t>(it - names.begin())] = false;
  }
  Eigen::MatrixXd X(n, P);
  Eigen::VectorXd y(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = empirical_row(samples[i], start);
    for (std::size_t j = 0; j < P; ++j) X(i, j) = r[j];
    y(i) = durations[i];
  }
  if (opt.contour_equals_raster) {
    // Contours run at the raster speed: one pace for both columns.
    if (free[0]) X.col(0) += X.col(1);
    else y -= X.col(1) * p0[0];
    free[1] = false;
  }
  EmpiricalFit fit;
  fit.names = names;
  for (std::size_t j = 0; j < P; ++j) {
    if (free[j] && X.col(j).cwiseAbs().maxCoeff() == 0.0) {
      free[j] = false;
      fit.not_identified.push_back(names[j]);
    }
  }
  std::vector<std::size_t> cols;
  for (std::size_t j = 0; j < P; ++j) {
    if (free[j]) cols.push_back(j);
    else if (!(opt.contour_equals_raster && j == 1)) y -= X.col(j) * p0[j];
  }
  const std::size_t k = cols.size();
  if (k == 0) throw Error("every parameter is fixed; nothing to fit");
  if (n < k) {
    std::string list;
    for (auto j : cols) list += (list.empty() ? "" : ", ") + names[j];
    throw Error(fmt::format("{} timed sample(s) cannot determine {} free parameters ({}); add "
                            "samples or fix some with --fix NAME=VALUE",
                            n, k, list));
  }
  Eigen::MatrixXd A(n, k);
  Eigen::VectorXd scale(k);
  for (std::size_t c = 0; c < k; ++c) {
    scale(c) = X.col(cols[c]).norm();
    A.col(c) = X.col(cols[c]) / scale(c);
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  qr.setThreshold(1e-10);
  if (static_cast<std::size_t>(qr.rank()) < k) {
    std::string list;
    const auto perm = qr.colsPermutation().indices();
    for (std::size_t c = static_cast<std::size_t>(qr.rank()); c < k; ++c) {
      list += (list.empty() ? "" : ", ") + names[cols[static_cast<std::size_t>(perm(c))]];
    }
    throw Error(fmt::format("singular fit: the samples do not separate {} from the other free "
                            "parameters (their lengths/counts are proportional); fix them with "
                            "--fix NAME=VALUE or time parts that differ in them",
                            list));
  }
  const Eigen::VectorXd b = qr.solve(y);
  const Eigen::VectorXd res = y - A * b;
  fit.dof = n - k;
  const double s2 = fit.dof > 0 ? res.squaredNorm() / static_cast<double>(fit.dof) : NAN;
  const Eigen::MatrixXd R = qr.matrixR().topLeftCorner(k, k).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd Rinv = R.inverse();
  const Eigen::MatrixXd cov_perm = Rinv * Rinv.transpose();
  std::vector<double> values = p0, se(P, 0.0);
  const auto perm = qr.colsPermutation().indices();
  for (std::size_t c = 0; c < k; ++c) values[cols[c]] = b(c) / scale(c);
  for (std::size_t c = 0; c < k; ++c) {
    const auto pc = static_cast<std::size_t>(perm(static_cast<Eigen::Index>(c)));
    se[cols[pc]] = std::sqrt(s2 * cov_perm(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(c))) / scale(pc);
  }
  if (opt.contour_equals_raster) {
    values[1] = values[0];
    se[1] = se[0];
  }
  fit.values = values;
  fit.std_errors = se;
  fit.free = free;
  if (opt.contour_equals_raster && free[0]) fit.free[1] = false;
  fit.model = with_parameters(start, values);
  double ss = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = empirical_row(samples[i], start);
    double t = 0.0;
    for (std::size_t j = 0; j < P; ++j) t += r[j] * values[j];
    fit.predicted_s.push_back(t);
    fit.residual_s.push_back(durations[i] - t);
    ss += (durations[i] - t) * (durations[i] - t);
  }
  fit.rms_s = std::sqrt(ss / static_cast<double>(n));
  return fit;
}

double link_speed_from_timing(double link_mm, double trajectory_s, double raster_mm,
                              double raster_speed_mm_s) {
  require_positive("link length", link_mm);
  require_positive("raster speed", raster_speed_mm_s);
  require_non_negative("raster length", raster_mm);
  const double t_links = trajectory_s - raster_mm / raster_speed_mm_s;
  if (!(t_links > 0.0)) {
    throw Error(fmt::format("trajectory time {} s leaves no time for the links after {} s of "
                            "rasters",
                            trajectory_s, raster_mm / raster_speed_mm_s));
  }
  return link_mm / t_links;
}

}  // namespace amctl::process
