#include "amctl/process/gcode_scale.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/core/output.hpp"

namespace amctl::process {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto up = [](char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c; };
    if (up(a[i]) != up(b[i])) return false;
  }
  return true;
}

int axis_of(char letter) {
  switch (letter) {
    case 'X': return 0;
    case 'Y': return 1;
    case 'Z': return 2;
    case 'E': return 3;
    default: return -1;
  }
}

// Recomputes a "*<checksum>" after the words before it changed (the XOR of the bytes before
// '*', as parse_line() checks it). Lines without one are left alone.
void fix_checksum(std::string& line) {
  const std::size_t semi = line.find(';');
  const std::size_t star = line.rfind('*', semi == std::string::npos ? std::string::npos : semi);
  if (star == std::string::npos || (semi != std::string::npos && star > semi)) return;
  std::size_t k = star + 1;
  while (k < line.size() && (line[k] == ' ' || line[k] == '\t')) ++k;
  std::size_t e = k;
  while (e < line.size() && line[e] >= '0' && line[e] <= '9') ++e;
  unsigned char x = 0;
  for (std::size_t j = 0; j < star; ++j) x ^= static_cast<unsigned char>(line[j]);
  line.replace(k, e - k, std::to_string(int{x}));
}

}  // namespace

std::string format_coord(double v, int decimals) {
  std::string s = fmt::format("{:.{}f}", v, decimals);
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  return s;
}

GcodeScaler::GcodeScaler(ScaleMap map, GcodeScaleOptions options, std::string file)
    : map_(std::move(map)), opt_(options), file_(std::move(file)) {
  rep_.extrusion_min_mm = rep_.scaled_min_mm = {kInf, kInf, kInf};
  rep_.extrusion_max_mm = rep_.scaled_max_mm = {-kInf, -kInf, -kInf};
}

GcodeScaleReport GcodeScaler::report() const {
  GcodeScaleReport r = rep_;
  r.layers = layer_z_.size();
  if (layer_z_.empty()) {
    // Nothing extruded: report empty extents rather than infinities.
    r.extrusion_min_mm = r.extrusion_max_mm = r.scaled_min_mm = r.scaled_max_mm = {0, 0, 0};
  }
  return r;
}

double GcodeScaler::format(double v, int decimals, std::string& text) const {
  text = format_coord(v, decimals);
  double back = 0.0;
  const std::size_t used = gcode::parse_number(text, back);
  AMCTL_CHECK(used == text.size(), "format_coord wrote a number parse_number does not read");
  return back;
}

std::vector<gcode::WordSpan>& GcodeScaler::words(const gcode::Command& cmd, std::string_view line,
                                                 std::uint64_t line_no) {
  if (!gcode::split_words(line, cmd, words_, params_, issue_)) {
    throw Error(SourceLocation{file_, line_no, issue_.column},
                fmt::format("{} in {}", issue_.message, cmd.name));
  }
  return words_;
}

void GcodeScaler::feed(std::string_view line, std::uint64_t line_no, std::string& out) {
  ++rep_.lines;
  if (!gcode::parse_line(line, cmd_, issue_)) {
    throw Error(SourceLocation{file_, line_no, issue_.column},
                fmt::format("{} in '{}'", issue_.message, trim(line)));
  }
  const gcode::Command& cmd = cmd_;
  if (cmd.kind == gcode::CommandKind::none) {
    // PrusaSlicer's ";Z:<height>" layer annotation follows the moves' Z.
    const std::string_view c = cmd.comment;
    if (!line.empty() && line.front() == ';' && c.substr(0, 2) == "Z:") {
      double z = 0.0;
      const std::size_t used = gcode::parse_number(c.substr(2), z);
      if (used != 0 && trim(c.substr(2 + used)).empty()) {
        out += ";Z:";
        out += format_coord(map_axis(2, z), opt_.xyz_decimals);
        return;
      }
    }
    out += line;
    return;
  }
  if (cmd.kind == gcode::CommandKind::extended) {
    if (iequals(cmd.name, "SET_KINEMATIC_POSITION")) {
      for (int a = 0; a < 3; ++a) {
        const char key[2] = {"XYZ"[a], 0};
        std::string_view text;
        std::uint32_t col = 0;
        if (!gcode::find_extended_arg(cmd, key, text, col)) continue;
        double v = 0.0;
        const std::size_t used = gcode::parse_number(text, v);
        if (used == 0 || used != text.size() || !std::isfinite(v)) {
          throw Error(SourceLocation{file_, line_no, col},
                      fmt::format("{} {}= expects a number, found '{}'", cmd.name, key, text));
        }
        in_pos_[a] = in_gcode_[a] = out_pos_[a] = out_gcode_[a] = v;
      }
    }
    out += line;
    return;
  }
  if (cmd.letter == 'G' && cmd.subcode < 0) {
    switch (cmd.code) {
      case 0: case 1: case 2: case 3:
        move(cmd, line, line_no, out);
        return;
      case 17: case 18: case 19:
        arc_plane_ = cmd.code;
        break;
      case 20:
        unit_mm_ = 25.4;
        break;
      case 21:
        unit_mm_ = 1.0;
        break;
      case 90:
        absolute_xyz_ = true;
        break;
      case 91:
        absolute_xyz_ = false;
        break;
      case 92: {
        // Sets the file's coordinates without moving: the same in both files, so the line is
        // kept and both files agree on where the machine is afterwards.
        (void)words(cmd, line, line_no);
        bool any = false;
        for (int a = 0; a < 4; ++a) {
          if (!params_.has("XYZE"[a])) continue;
          in_gcode_[a] = out_gcode_[a] = params_.get("XYZE"[a]) * unit_mm_;
          any = true;
        }
        if (!any) in_gcode_ = out_gcode_ = {0, 0, 0, 0};
        break;
      }
      case 28: {
        (void)words(cmd, line, line_no);
        const bool any = params_.has('X') || params_.has('Y') || params_.has('Z');
        for (int a = 0; a < 3; ++a) {
          if (!any || params_.has("XYZ"[a])) {
            in_pos_[a] = in_gcode_[a] = out_pos_[a] = out_gcode_[a] = 0.0;
          }
        }
        break;
      }
      default:
        break;
    }
  } else if (cmd.letter == 'M' && cmd.subcode < 0 && (cmd.code == 82 || cmd.code == 83)) {
    absolute_e_ = cmd.code == 82;
  }
  out += line;
}

void GcodeScaler::move(const gcode::Command& cmd, std::string_view line, std::uint64_t line_no,
                       std::string& out) {
  const auto& ws = words(cmd, line, line_no);
  const gcode::Params& p = params_;
  for (const auto& w : ws) {
    if (w.bare()) {  // as the interpreter: a bare letter has no meaning in a move
      throw Error(SourceLocation{file_, line_no, w.letter_offset + 2},
                  fmt::format("expected a number after '{}' (is the file truncated?)", w.letter));
    }
  }
  const bool arc = cmd.code == 2 || cmd.code == 3;
  bool any_axis = false;
  for (char l : {'X', 'Y', 'Z', 'E'}) any_axis = any_axis || p.has(l);
  if (!any_axis && !arc) {  // F only
    out += line;
    return;
  }
  // The input's target, as Interpreter::modal_target computes it.
  const std::array<double, 3> start{in_pos_[0], in_pos_[1], in_pos_[2]};
  std::array<double, 3> end = start;
  for (int a = 0; a < 3; ++a) {
    if (!p.has("XYZ"[a])) continue;
    const double v = p.get("XYZ"[a]) * unit_mm_;
    if (absolute_xyz_) {
      end[a] = in_pos_[a] + (v - in_gcode_[a]);
      in_gcode_[a] = v;
    } else {
      end[a] = in_pos_[a] + v;
      in_gcode_[a] += v;
    }
  }
  const bool relative_e = !absolute_xyz_ || !absolute_e_;
  double de = 0.0;
  if (p.has('E')) {
    const double v = p.get('E') * unit_mm_;
    de = relative_e ? v : v - in_gcode_[3];
    in_gcode_[3] = relative_e ? in_gcode_[3] + v : v;
  }
  const auto new_start = map_.apply(start);
  const auto new_end = map_.apply(end);

  // Extrusion scale: path length ratio times the local layer-height ratio.
  const double len = std::hypot(end[0] - start[0], end[1] - start[1]);
  double e_scale = 1.0;
  if (opt_.scale_extrusion && len > 0 && de > 0) {
    // For arcs the chord ratio stands in for the arc-length ratio (equal for a uniform XY
    // scale, the common case).
    const double new_len = std::hypot(new_end[0] - new_start[0], new_end[1] - new_start[1]);
    e_scale = (new_len / len) *
              map_.axes[2].slope_at(0.5 * (start[2] + end[2]) - map_.origin_mm[2]);
  }
  const double new_de = de * e_scale;
  if (de > 0 && len > 0) {
    layer_z_.insert(end[2]);
    rep_.extruded_mm += de;
    rep_.scaled_extruded_mm += new_de;
    for (int a = 0; a < 3; ++a) {
      rep_.extrusion_min_mm[a] = std::min({rep_.extrusion_min_mm[a], start[a], end[a]});
      rep_.extrusion_max_mm[a] = std::max({rep_.extrusion_max_mm[a], start[a], end[a]});
      rep_.scaled_min_mm[a] = std::min({rep_.scaled_min_mm[a], new_start[a], new_end[a]});
      rep_.scaled_max_mm[a] = std::max({rep_.scaled_max_mm[a], new_start[a], new_end[a]});
    }
  }

  // Arcs: the centre (I/J/K offsets from the start) goes through the map; R only survives a
  // uniform scale equal on both plane axes.
  int p0 = 0, p1 = 1;
  if (arc_plane_ == 18) { p0 = 0; p1 = 2; }
  if (arc_plane_ == 19) { p0 = 1; p1 = 2; }
  std::array<double, 3> new_centre{};
  if (arc) {
    ++rep_.arcs;
    std::array<double, 3> centre = start;
    for (int k = 0; k < 3; ++k) centre[k] += p.get_or("IJK"[k], 0.0) * unit_mm_;
    new_centre = map_.apply(centre);
    if (p.has('R')) {
      const auto& m0 = map_.axes[p0];
      const auto& m1 = map_.axes[p1];
      if (!m0.is_uniform() || !m1.is_uniform() || m0.factors() != m1.factors()) {
        throw Error(SourceLocation{file_, line_no, p.column['R' - 'A']},
                    "R-form arc under different or piecewise factors of the arc plane's axes "
                    "cannot stay an arc; re-slice with I/J arcs or use equal uniform factors");
      }
    } else if (p.has('I') || p.has('J') || p.has('K')) {
      const double r0 = std::hypot(new_start[p0] - new_centre[p0], new_start[p1] - new_centre[p1]);
      const double r1 = std::hypot(new_end[p0] - new_centre[p0], new_end[p1] - new_centre[p1]);
      rep_.max_arc_radius_mismatch_mm = std::max(rep_.max_arc_radius_mismatch_mm, std::fabs(r0 - r1));
    }
  }

  // The numbers to write (in the file's units), then the output file's state as a reader of
  // the new text will see it. A number whose value does not change keeps its text.
  std::array<std::string, 26> text{};
  std::array<bool, 26> changed{};
  auto decide = [&](char l, double exact, int decimals) {
    const auto i = static_cast<std::size_t>(l - 'A');
    const double written = format(exact, decimals, text[i]);
    changed[i] = written != p.get(l);
    return changed[i] ? written : p.get(l);
  };
  const std::array<double, 4> out_pos_before = out_pos_;
  for (int a = 0; a < 3; ++a) {
    const char l = "XYZ"[a];
    if (!p.has(l)) continue;
    const double exact = absolute_xyz_ ? (out_gcode_[a] + new_end[a] - out_pos_[a]) / unit_mm_
                                       : (new_end[a] - out_pos_[a]) / unit_mm_;
    const double v = decide(l, exact, opt_.xyz_decimals) * unit_mm_;
    if (absolute_xyz_) {
      out_pos_[a] += v - out_gcode_[a];
      out_gcode_[a] = v;
    } else {
      out_pos_[a] += v;
      out_gcode_[a] += v;
    }
  }
  if (p.has('E')) {
    const double exact = relative_e ? new_de / unit_mm_ : (out_gcode_[3] + new_de) / unit_mm_;
    const double v = decide('E', exact, opt_.e_decimals) * unit_mm_;
    out_gcode_[3] = relative_e ? out_gcode_[3] + v : v;
  }
  if (arc) {
    for (int k = 0; k < 3; ++k) {
      const char l = "IJK"[k];
      if (p.has(l)) decide(l, (new_centre[k] - out_pos_before[k]) / unit_mm_, opt_.xyz_decimals);
    }
    if (p.has('R')) decide('R', p.get('R') * map_.axes[p0].factors()[0], opt_.xyz_decimals);
  }
  for (int a = 0; a < 3; ++a) in_pos_[a] = end[a];

  line_out_.clear();
  std::size_t copied = 0;
  bool any_change = false;
  for (const auto& w : ws) {
    const auto i = static_cast<std::size_t>(w.letter - 'A');
    const bool rewritable = axis_of(w.letter) >= 0 ||
                            (arc && (w.letter == 'I' || w.letter == 'J' || w.letter == 'K' ||
                                     w.letter == 'R'));
    if (!rewritable || !changed[i]) continue;
    line_out_.append(line.substr(copied, w.number_offset - copied));
    line_out_ += text[i];
    copied = w.number_offset + w.number_size;
    any_change = true;
  }
  if (!any_change) {
    out += line;
    return;
  }
  line_out_.append(line.substr(copied));
  fix_checksum(line_out_);
  out += line_out_;
  ++rep_.moves_rewritten;
}

GcodeExtent gcode_extrusion_extent(const std::string& path) {
  InputFile input(path, gcode::gcode_input_options());
  return gcode_extrusion_extent(input);
}

GcodeExtent gcode_extrusion_extent(InputFile& input) {
  if (input.position() != 0) input.rewind();
  const std::string& path = input.name();
  const auto reader_ptr = formats::open_gcode_reader(input);
  gcode::LineReader& reader = *reader_ptr;
  GcodeScaler scan(ScaleMap{}, GcodeScaleOptions{}, path);
  std::string sink;
  std::string_view line;
  while (reader.next(line)) {
    scan.feed(line, reader.line_number(), sink);
    sink.clear();
  }
  if (!scan.extruded()) throw Error(SourceLocation{path, 0, 0}, "G-code has no extruding XY moves");
  const auto r = scan.report();
  return {r.extrusion_min_mm, r.extrusion_max_mm};
}

GcodeScaleReport scale_gcode_file(const std::string& input, const std::string& output,
                                  const ScaleMap& map, const GcodeScaleOptions& options) {
  InputFile in(input, gcode::gcode_input_options());
  return scale_gcode_file(in, output, map, options);
}

GcodeScaleReport scale_gcode_file(InputFile& input, const std::string& output, const ScaleMap& map,
                                  const GcodeScaleOptions& options) {
  OutputOptions oo{"-o/--output", {input.path()}, {}};
  if (input.identity()) oo.input_ids.push_back(*input.identity());
  OutputFile writer(output, oo);  // first: an output that is the input fails before reading
  if (input.position() != 0) input.rewind();
  const auto reader_ptr = formats::open_gcode_reader(input);
  gcode::LineReader& reader = *reader_ptr;
  GcodeScaler scaler(map, options, input.name());
  constexpr std::size_t kFlushBytes = 1u << 20;
  std::string buf;
  buf.reserve(kFlushBytes + 4096);
  std::string_view line;
  while (reader.next(line)) {
    scaler.feed(line, reader.line_number(), buf);
    buf += reader.terminator();  // kept as it was (LF, CR LF, a lone CR, none at the end)
    if (buf.size() >= kFlushBytes) {
      writer.write(buf);
      buf.clear();
    }
  }
  writer.write(buf);
  writer.commit();
  return scaler.report();
}

}  // namespace amctl::process
