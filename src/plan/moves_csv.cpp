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

MovesCsvFile::MovesCsvFile(std::string path, OutputOptions options)
    : out_(std::move(path), std::move(options)) {
  out_.write(moves_csv_header());
}

void MovesCsvFile::consume(const PlanBatch& batch) {
  for (const PlannedMove& m : batch.moves) out_.write(moves_csv_row(m, feature_of(batch, m)));
  rows_ += batch.moves.size();
}

void MovesCsvFile::commit() { out_.commit(); }

}  // namespace amctl::plan
