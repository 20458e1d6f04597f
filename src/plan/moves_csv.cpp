#include "amctl/plan/moves_csv.hpp"

#include <cstdio>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::plan {
namespace {

const char* profile_name(machine::VelocityProfile p) {
  switch (p) {
    case machine::VelocityProfile::trapezoid: return "trapezoid";
    case machine::VelocityProfile::scurve7: return "scurve7";
    case machine::VelocityProfile::bezier5: return "bezier5";
  }
  return "unknown";
}

std::string csv_field(std::string_view s) {
  if (s.find_first_of(",\"\n") == std::string_view::npos) return std::string(s);
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + '"';
}

std::string_view feature_of(const PlanBatch& b, const PlannedMove& m) {
  if (b.feature_names == nullptr || m.feature >= b.feature_names->size()) return {};
  return (*b.feature_names)[m.feature];
}

}  // namespace

const std::string& moves_csv_header() {
  static const std::string h =
      "line,layer,feature,start_time_s,duration_s,x0_mm,y0_mm,z0_mm,e0_mm,x1_mm,y1_mm,z1_mm,"
      "e1_mm,distance_mm,start_v_mm_s,cruise_v_mm_s,end_v_mm_s,accel_mm_s2,jerk_mm_s3,"
      "accel_t_s,cruise_t_s,decel_t_s,profile,extrude_only\n";
  return h;
}

std::string moves_csv_row(const PlannedMove& m, std::string_view feature_name) {
  std::array<double, 4> end{};
  for (std::size_t i = 0; i < 4; ++i) end[i] = m.start_mm[i] + m.axes_r[i] * m.distance_mm;
  // fmt's "{}" for a double is the shortest representation that reads back exactly.
  return fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                     m.line, m.layer, csv_field(feature_name), m.start_time_s, m.duration_s(), m.start_mm[0],
                     m.start_mm[1], m.start_mm[2], m.start_mm[3], end[0], end[1], end[2], end[3],
                     m.distance_mm, m.start_v_mm_s, m.cruise_v_mm_s, m.end_v_mm_s, m.accel_mm_s2,
                     m.jerk_mm_s3, m.accel_t_s, m.cruise_t_s, m.decel_t_s, profile_name(m.profile),
                     m.extrude_only ? 1 : 0);
}

MovesCsvSink::MovesCsvSink(std::ostream& out) : out_(out) { out_ << moves_csv_header(); }

void MovesCsvSink::consume(const PlanBatch& batch) {
  for (const PlannedMove& m : batch.moves) out_ << moves_csv_row(m, feature_of(batch, m));
  rows_ += batch.moves.size();
}

namespace {

std::vector<NpyColumn> moves_columns() {
  std::vector<NpyColumn> c{{"line", NpyType::u8, 0}, {"layer", NpyType::i4, 0},
                           {"feature", NpyType::text, kMovesNpyFeatureBytes}};
  for (const char* name : {"start_time_s", "duration_s", "x0_mm", "y0_mm", "z0_mm", "e0_mm",
                           "x1_mm", "y1_mm", "z1_mm", "e1_mm", "distance_mm", "start_v_mm_s",
                           "cruise_v_mm_s", "end_v_mm_s", "accel_mm_s2", "jerk_mm_s3",
                           "accel_t_s", "cruise_t_s", "decel_t_s"}) {
    c.push_back({name, NpyType::f8, 0});
  }
  c.push_back({"profile", NpyType::text, 9});
  c.push_back({"extrude_only", NpyType::b1, 0});
  return c;
}

}  // namespace

MovesFile::MovesFile(std::string path, OutputOptions options)
    : format_(table_format_for(path)), path_(path) {
  if (format_ == TableFormat::npy) {
    npy_.emplace(std::move(path), moves_columns(), std::move(options));
  } else {
    csv_.emplace(std::move(path), std::move(options));
    csv_->write(moves_csv_header());
  }
}

void MovesFile::consume(const PlanBatch& batch) {
  if (csv_) {
    for (const PlannedMove& m : batch.moves) csv_->write(moves_csv_row(m, feature_of(batch, m)));
    rows_ += batch.moves.size();
    return;
  }
  NpyRecord r(*npy_);
  for (const PlannedMove& m : batch.moves) {
    const std::string_view feature = feature_of(batch, m);
    if (feature.size() > kMovesNpyFeatureBytes) {
      throw Error(SourceLocation{path_, 0, 0},
                  fmt::format("the feature name at G-code line {} is {} bytes long; a .npy moves "
                              "table holds names of up to {} bytes: expected a .csv output for "
                              "this file",
                              m.line, feature.size(), kMovesNpyFeatureBytes));
    }
    std::size_t i = 0;
    r.set_int(i++, static_cast<std::int64_t>(m.line)).set_int(i++, m.layer).set_text(i++, feature);
    r.set(i++, m.start_time_s).set(i++, m.duration_s());
    for (std::size_t k = 0; k < 4; ++k) r.set(i++, m.start_mm[k]);
    for (std::size_t k = 0; k < 4; ++k) r.set(i++, m.start_mm[k] + m.axes_r[k] * m.distance_mm);
    r.set(i++, m.distance_mm).set(i++, m.start_v_mm_s).set(i++, m.cruise_v_mm_s);
    r.set(i++, m.end_v_mm_s).set(i++, m.accel_mm_s2).set(i++, m.jerk_mm_s3);
    r.set(i++, m.accel_t_s).set(i++, m.cruise_t_s).set(i++, m.decel_t_s);
    r.set_text(i++, profile_name(m.profile)).set_int(i++, m.extrude_only ? 1 : 0);
    npy_->append(r.bytes());
  }
  rows_ += batch.moves.size();
}

void MovesFile::commit() {
  if (npy_) {
    npy_->commit();
  } else {
    csv_->commit();
  }
}

}  // namespace amctl::plan
