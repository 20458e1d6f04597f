#include "amctl/process/gcode_scale.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/process/gcode_text.hpp"

namespace amctl::process {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Modal {
  bool abs_xyz = true;
  bool abs_e_flag = true;  // M82/M83
  // E is relative under G91 or M83 (Klipper's rule; Marlin's G91 also makes E relative).
  [[nodiscard]] bool abs_e() const { return abs_xyz && abs_e_flag; }
  std::array<double, 3> pos{0, 0, 0};
  double e = 0.0;
};

template <typename Fn>
void for_each_line(std::string_view text, Fn&& fn) {
  std::size_t pos = 0;
  std::uint64_t no = 0;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    const bool last = eol == std::string_view::npos;
    if (last) eol = text.size();
    std::string_view line = text.substr(pos, eol - pos);
    const bool cr = !line.empty() && line.back() == '\r';
    if (cr) line.remove_suffix(1);
    fn(line, ++no, !last, cr);
    pos = eol + 1;
  }
}

// Applies mode words (G90/G91/M82/M83/G92/G20/G21) and returns the motion number or -1.
int motion_of(const GcodeLine& g, Modal& m, const std::string& file, std::uint64_t no) {
  for (const auto& w : g.words) {
    if (w.letter == 'G') {
      if (w.text == "90") m.abs_xyz = true;
      else if (w.text == "91") m.abs_xyz = false;
      else if (w.text == "20") {
        throw Error(SourceLocation{file, no, 0},
                    "G20 selects inch units; the compensation factors and breakpoints are in "
                    "mm. Re-slice in mm (G21)");
      }
      else if (w.text == "0" || w.text == "00") return 0;
      else if (w.text == "1" || w.text == "01") return 1;
      else if (w.text == "2" || w.text == "02") return 2;
      else if (w.text == "3" || w.text == "03") return 3;
      else if (w.text == "92") return 92;
    } else if (w.letter == 'M') {
      if (w.text == "82") m.abs_e_flag = true;
      else if (w.text == "83") m.abs_e_flag = false;
    }
  }
  return -1;
}

}  // namespace

GcodeExtent gcode_extrusion_extent(std::string_view text, const std::string& file) {
  Modal m;
  GcodeExtent ex{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}};
  bool any = false;
  for_each_line(text, [&](std::string_view line, std::uint64_t no, bool, bool) {
    const GcodeLine g = parse_gcode_line(line, file, no);
    const int mo = motion_of(g, m, file, no);
    if (mo == 92) {
      for (int a = 0; a < 3; ++a)
        if (auto* w = g.find("XYZ"[a])) m.pos[a] = w->value;
      if (auto* w = g.find('E')) m.e = w->value;
      return;
    }
    if (mo < 0) return;
    const auto start = m.pos;
    for (int a = 0; a < 3; ++a) {
      if (auto* w = g.find("XYZ"[a])) m.pos[a] = m.abs_xyz ? w->value : m.pos[a] + w->value;
    }
    double de = 0.0;
    if (auto* w = g.find('E')) {
      de = m.abs_e() ? w->value - m.e : w->value;
      m.e = m.abs_e() ? w->value : m.e + w->value;
    }
    if (de > 0 && (start[0] != m.pos[0] || start[1] != m.pos[1])) {
      any = true;
      for (int a = 0; a < 3; ++a) {
        ex.min_mm[a] = std::min({ex.min_mm[a], start[a], m.pos[a]});
        ex.max_mm[a] = std::max({ex.max_mm[a], start[a], m.pos[a]});
      }
    }
  });
  if (!any) throw Error(SourceLocation{file, 0, 0}, "G-code has no extruding XY moves");
  return ex;
}

GcodeScaleReport scale_gcode(std::string_view text, const std::string& file, const ScaleMap& map,
                             const GcodeScaleOptions& opt, std::string& out) {
  GcodeScaleReport rep;
  rep.extrusion_min_mm = rep.scaled_min_mm = {kInf, kInf, kInf};
  rep.extrusion_max_mm = rep.scaled_max_mm = {-kInf, -kInf, -kInf};
  out.clear();
  out.reserve(text.size() + text.size() / 16);
  Modal m;
  double new_e = 0.0;            // absolute E written so far (absolute-E mode)
  std::set<double> layer_z;
  const bool xy_same = map.axes[0].factors() == map.axes[1].factors() &&
                       map.axes[0].breaks_mm() == map.axes[1].breaks_mm() &&
                       map.axes[0].is_uniform();
  for_each_line(text, [&](std::string_view line, std::uint64_t no, bool newline, bool cr) {
    ++rep.lines;
    const GcodeLine g = parse_gcode_line(line, file, no);
    const int mo = motion_of(g, m, file, no);
    const std::string eol = std::string(cr ? "\r" : "") + (newline ? "\n" : "");
    // Keep PrusaSlicer's ";Z:" layer annotations in step with the moves.
    if (g.words.empty() && g.has_comment && g.comment.rfind("Z:", 0) == 0 && line.front() == ';') {
      try {
        const double z = std::stod(g.comment.substr(2));
        out += ";Z:" +
               format_coord(map.origin_mm[2] + map.axes[2].map(z - map.origin_mm[2]),
                            opt.xyz_decimals) +
               eol;
        return;
      } catch (const std::exception&) {
      }
    }
    if (mo < 0) {
      out += line;
      out += eol;
      return;
    }
    if (mo == 92) {
      // G92 sets the logical position: map XYZ like a target, keep E resets in both streams.
      std::string s;
      for (const auto& w : g.words) {
        if (!s.empty()) s += ' ';
        const int a = w.letter == 'X' ? 0 : w.letter == 'Y' ? 1 : w.letter == 'Z' ? 2 : -1;
        if (a >= 0) {
          m.pos[a] = w.value;
          s += w.letter + format_coord(map.origin_mm[a] + map.axes[a].map(w.value - map.origin_mm[a]),
                                       opt.xyz_decimals);
        } else if (w.letter == 'E') {
          m.e = w.value;
          new_e = w.value;
          s += w.letter + w.text;
        } else {
          s += w.letter + w.text;
        }
      }
      if (g.has_comment) s += " ;" + g.comment;
      out += s + eol;
      return;
    }
    const auto start = m.pos;
    auto end = m.pos;
    for (int a = 0; a < 3; ++a) {
      if (auto* w = g.find("XYZ"[a])) end[a] = m.abs_xyz ? w->value : m.pos[a] + w->value;
    }
    const auto new_start = map.apply(start);
    const auto new_end = map.apply(end);
    double de = 0.0;
    const GcodeWord* ew = g.find('E');
    if (ew) de = m.abs_e() ? ew->value - m.e : ew->value;
    // Extrusion scale: path length ratio times the local layer-height ratio.
    double e_scale = 1.0;
    const double dx = end[0] - start[0], dy = end[1] - start[1];
    const double len = std::hypot(dx, dy);
    if (opt.scale_extrusion && len > 0 && de > 0) {
      double new_len = std::hypot(new_end[0] - new_start[0], new_end[1] - new_start[1]);
      // For arcs the chord ratio stands in for the arc-length ratio (equal for a uniform
      // XY scale, the common case).
      e_scale = (new_len / len) * map.axes[2].slope_at(0.5 * (start[2] + end[2]) - map.origin_mm[2]);
    }
    const double new_de = de * e_scale;
    if (ew) {
      m.e = m.abs_e() ? ew->value : m.e + ew->value;
    }
    if (de > 0 && len > 0) {
      layer_z.insert(end[2]);
      rep.extruded_mm += de;
      rep.scaled_extruded_mm += new_de;
      for (int a = 0; a < 3; ++a) {
        rep.extrusion_min_mm[a] = std::min({rep.extrusion_min_mm[a], start[a], end[a]});
        rep.extrusion_max_mm[a] = std::max({rep.extrusion_max_mm[a], start[a], end[a]});
        rep.scaled_min_mm[a] = std::min({rep.scaled_min_mm[a], new_start[a], new_end[a]});
        rep.scaled_max_mm[a] = std::max({rep.scaled_max_mm[a], new_start[a], new_end[a]});
      }
    }
    std::string s;
    for (const auto& w : g.words) {
      if (!s.empty()) s += ' ';
      const int a = w.letter == 'X' ? 0 : w.letter == 'Y' ? 1 : w.letter == 'Z' ? 2 : -1;
      if (a >= 0) {
        const double v = m.abs_xyz ? new_end[a] : new_end[a] - new_start[a];
        s += w.letter + format_coord(v, opt.xyz_decimals);
      } else if (w.letter == 'E') {
        if (m.abs_e()) {
          new_e += new_de;
          // A non-extruding E word (retract/prime) keeps its own delta.
          s += 'E' + format_coord(new_e, opt.e_decimals);
        } else {
          s += 'E' + format_coord(new_de, opt.e_decimals);
        }
      } else if ((w.letter == 'I' || w.letter == 'J') && (mo == 2 || mo == 3)) {
        const int k = w.letter == 'I' ? 0 : 1;
        const double c = start[k] + w.value;
        const double nc = map.origin_mm[k] + map.axes[k].map(c - map.origin_mm[k]);
        s += w.letter + format_coord(nc - new_start[k], opt.xyz_decimals);
      } else if (w.letter == 'R' && (mo == 2 || mo == 3)) {
        if (!xy_same) {
          throw Error(SourceLocation{file, no, 0},
                      "R-form arc under different or piecewise X and Y factors cannot stay an "
                      "arc; re-slice with I/J arcs or use equal uniform X and Y factors");
        }
        s += 'R' + format_coord(w.value * map.axes[0].factors()[0], opt.xyz_decimals);
      } else {
        s += w.letter + w.text;
      }
    }
    if ((mo == 2 || mo == 3)) {
      ++rep.arcs;
      const GcodeWord* iw = g.find('I');
      const GcodeWord* jw = g.find('J');
      if (iw || jw) {
        const double cx = start[0] + (iw ? iw->value : 0.0), cy = start[1] + (jw ? jw->value : 0.0);
        const double ncx = map.origin_mm[0] + map.axes[0].map(cx - map.origin_mm[0]);
        const double ncy = map.origin_mm[1] + map.axes[1].map(cy - map.origin_mm[1]);
        const double r0 = std::hypot(new_start[0] - ncx, new_start[1] - ncy);
        const double r1 = std::hypot(new_end[0] - ncx, new_end[1] - ncy);
        rep.max_arc_radius_mismatch_mm = std::max(rep.max_arc_radius_mismatch_mm, std::fabs(r0 - r1));
      }
    }
    if (g.has_comment) s += " ;" + g.comment;
    out += s + eol;
    ++rep.moves_rewritten;
    m.pos = end;
  });
  rep.layers = layer_z.size();
  return rep;
}

}  // namespace amctl::process
