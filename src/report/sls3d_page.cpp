// The page of the 3D powder-bed scenario (amctl/report/sls3d_page.hpp).
#include "amctl/report/sls3d_page.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/report/line_chart.hpp"

namespace amctl::report {

namespace {

std::uint32_t crc32(const unsigned char* data, std::size_t n, std::uint32_t crc = 0) {
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

void put32(std::string& s, std::uint32_t v) {
  for (int k = 3; k >= 0; --k) s.push_back(char((v >> (8 * k)) & 0xFF));
}

void chunk(std::string& png, const char* type, const std::string& data) {
  put32(png, std::uint32_t(data.size()));
  std::string body(type, 4);
  body += data;
  png += body;
  put32(png, crc32(reinterpret_cast<const unsigned char*>(body.data()), body.size()));
}

std::string base64(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const std::uint32_t v = (std::uint8_t(in[i]) << 16) | (std::uint8_t(in[i + 1]) << 8) | std::uint8_t(in[i + 2]);
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += t[(v >> 6) & 63];
    out += t[v & 63];
  }
  if (i + 1 == in.size()) {
    const std::uint32_t v = std::uint8_t(in[i]) << 16;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    const std::uint32_t v = (std::uint8_t(in[i]) << 16) | (std::uint8_t(in[i + 1]) << 8);
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += t[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

// A perceptually ordered map from dark blue through red to light yellow (anchors of the
// "inferno" colour map, interpolated linearly).
std::array<unsigned char, 3> colour(double u) {
  static const double a[][3] = {{0, 0, 4},      {40, 11, 84},   {101, 21, 110}, {159, 42, 99},
                                {212, 72, 66},  {245, 125, 21}, {250, 193, 39}, {252, 255, 164}};
  u = std::clamp(u, 0.0, 1.0) * 7.0;
  const int i = std::min(6, int(u));
  const double f = u - i;
  std::array<unsigned char, 3> c{};
  for (int k = 0; k < 3; ++k) c[k] = static_cast<unsigned char>(std::lround(a[i][k] + f * (a[i + 1][k] - a[i][k])));
  return c;
}

std::string svg_body(const std::string& svg) {
  const auto p = svg.find("<svg");
  return p == std::string::npos ? svg : svg.substr(p);
}

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

}  // namespace

std::string png_rgba(int width, int height, const std::vector<unsigned char>& rgba) {
  AMCTL_CHECK(width > 0 && height > 0 && rgba.size() == std::size_t(width) * height * 4, "png_rgba: size");
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put32(ihdr, std::uint32_t(width));
  put32(ihdr, std::uint32_t(height));
  ihdr += std::string("\x08\x06\x00\x00\x00", 5);  // 8 bits, RGBA, deflate, no filter, no interlace
  chunk(png, "IHDR", ihdr);
  // Scanlines, each with filter byte 0.
  std::string raw;
  raw.reserve(std::size_t(height) * (1 + 4 * std::size_t(width)));
  for (int y = 0; y < height; ++y) {
    raw.push_back('\0');
    raw.append(reinterpret_cast<const char*>(rgba.data()) + std::size_t(y) * width * 4, std::size_t(width) * 4);
  }
  // zlib stream of stored deflate blocks.
  std::string z("\x78\x01", 2);
  std::uint32_t a = 1, b = 0;
  for (unsigned char c : raw) {
    a = (a + c) % 65521u;
    b = (b + a) % 65521u;
  }
  for (std::size_t off = 0; off < raw.size() || off == 0; off += 65535) {
    const std::size_t len = std::min<std::size_t>(65535, raw.size() - off);
    const bool last = off + len >= raw.size();
    z.push_back(last ? '\x01' : '\x00');
    z.push_back(char(len & 0xFF));
    z.push_back(char(len >> 8));
    z.push_back(char(~len & 0xFF));
    z.push_back(char((~len >> 8) & 0xFF));
    z.append(raw, off, len);
    if (last) break;
  }
  put32(z, (b << 16) | a);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", "");
  return png;
}

std::string sls3d_page_html(const sls3d::ScenarioResult& r) {
  const sls3d::ScenarioConfig& c = r.config;
  // One colour scale for every map: the range of all of them.
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& s : r.snapshots)
    for (double v : s.map.temp_c)
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  if (!(hi > lo)) {
    lo = c.setpoint_c - 1;
    hi = c.setpoint_c + 1;
  }
  std::string maps;
  for (const auto& s : r.snapshots) {
    const sls3d::TopRaster& m = s.map;
    if (m.nx == 0) continue;
    std::vector<unsigned char> px(std::size_t(m.nx) * m.ny * 4, 0);
    for (int j = 0; j < m.ny; ++j)
      for (int i = 0; i < m.nx; ++i) {
        const double v = m.temp_c[std::size_t(j) * m.nx + i];
        // Image rows run top to bottom: y decreasing.
        unsigned char* p = &px[(std::size_t(m.ny - 1 - j) * m.nx + i) * 4];
        if (!std::isfinite(v)) continue;
        const auto col = colour((v - lo) / (hi - lo));
        p[0] = col[0];
        p[1] = col[1];
        p[2] = col[2];
        p[3] = 255;
      }
    maps += fmt::format(
        "<figure><img width=\"320\" height=\"320\" alt=\"top surface at {0:g} s\" src=\"data:image/png;base64,{1}\">"
        "<figcaption>t = {0:g} s: measured {2:.2f} C, surface mean {3:.2f} C{4}</figcaption></figure>\n",
        s.time_s, base64(png_rgba(m.nx, m.ny, px)), s.measured_c, s.top_mean_c,
        s.file.empty() ? "" : ", " + esc(s.file));
  }
  // Colour bar.
  std::vector<unsigned char> bar(256 * 12 * 4);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 256; ++x) {
      const auto col = colour(x / 255.0);
      unsigned char* p = &bar[(std::size_t(y) * 256 + x) * 4];
      p[0] = col[0];
      p[1] = col[1];
      p[2] = col[2];
      p[3] = 255;
    }
  const std::string colour_bar = fmt::format(
      "<p class=\"bar\">{:.1f} C <img width=\"256\" height=\"12\" alt=\"colour scale\" src=\"data:image/png;base64,{}\"> {:.1f} C</p>",
      lo, base64(png_rgba(256, 12, bar)), hi);

  LineChart u_chart;
  u_chart.title = "Preheating flux U(t) (the control signal)";
  u_chart.x_label = "t [s]";
  u_chart.y_label = "U [W/m^2]";
  ChartPanel up;
  ChartSeries u{"U", {}, {}}, uu{"PI request (before saturation)", {}, {}}, umin{"flux_min", {}, {}},
      umax{"flux_max", {}, {}}, sat{"saturated samples", {}, {}};
  for (const auto& p : r.trace) {
    u.x.push_back(p.t_s);
    u.y.push_back(p.flux_w_m2);
    uu.x.push_back(p.t_s);
    uu.y.push_back(std::clamp(p.unsaturated_flux_w_m2, c.flux_min_w_m2 - 0.25 * (c.flux_max_w_m2 - c.flux_min_w_m2),
                              c.flux_max_w_m2 + 0.25 * (c.flux_max_w_m2 - c.flux_min_w_m2)));
    if (p.saturated) {
      sat.x.push_back(p.t_s);
      sat.y.push_back(p.flux_w_m2);
    }
  }
  if (!r.trace.empty()) {
    umin.x = {r.trace.front().t_s, r.trace.back().t_s};
    umin.y = {c.flux_min_w_m2, c.flux_min_w_m2};
    umax.x = umin.x;
    umax.y = {c.flux_max_w_m2, c.flux_max_w_m2};
  }
  up.series = {u, uu, umin, umax};
  if (!sat.x.empty()) up.series.push_back(sat);
  u_chart.panels = {up};

  LineChart y_chart;
  y_chart.title = "Measured top temperature y(t) and set point";
  y_chart.x_label = "t [s]";
  y_chart.y_label = "T [C]";
  ChartPanel yp;
  ChartSeries y{"y (measured)", {}, {}}, sp{"set point", {}, {}}, tmax{"surface maximum", {}, {}};
  for (const auto& p : r.trace) {
    y.x.push_back(p.t_s);
    y.y.push_back(p.measured_c);
    sp.x.push_back(p.t_s);
    sp.y.push_back(p.setpoint_c);
  }
  yp.series = {y, sp};
  y_chart.panels = {yp};
  ChartPanel mp;
  for (const auto& p : r.trace) {
    tmax.x.push_back(p.t_s);
    tmax.y.push_back(p.top_max_c);
  }
  mp.title = "Largest top-surface temperature";
  mp.series = {tmax};
  y_chart.panels.push_back(mp);

  const sls3d::EnergyTotals& e = r.energy;
  std::string layers;
  for (const auto& l : r.layers)
    layers += fmt::format("<tr><td>{}</td><td>{:.2f}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.0f}</td><td>{:.2f}</td></tr>\n",
                          l.layer, l.spread_s, l.exposure_start_s, l.exposure_end_s, l.scan_length_m * 1e3,
                          l.laser_energy_j);
  std::string html;
  html += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
          "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'\">\n"
          "<title>amctl: SLS powder bed in 3D</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em}"
          "figure{display:inline-block;margin:0.5em}figcaption{font-size:90%;max-width:320px}"
          "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}"
          ".bar img{vertical-align:middle}img{image-rendering:pixelated}</style></head><body>\n";
  html += "<h1>SLS powder bed in 3D under the PI</h1>\n";
  html += fmt::format(
      "<p>Disc of radius {:g} mm, {} layers of {:g} mm on a {:g} mm base; hollow cylinder {:g}-{:g} mm; laser {:g} W "
      "(absorbed {:g} %), {:g} mm/s, hatch {:g} mm; PI kp = {:g} W/(m<sup>2</sup> K), Ti = {:g} s, U in [{:g}, {:g}] W/m<sup>2</sup>, "
      "anti-windup {}, measuring {}. Source scale: {}. {} MPI rank(s).</p>\n",
      c.disc_radius_m * 1e3, c.layers, c.layer_thickness_m * 1e3, c.base_depth_m * 1e3, c.part_inner_radius_m * 1e3,
      c.part_outer_radius_m * 1e3, c.laser_power_w, 100 * c.absorptivity, c.scan_speed_m_s * 1e3, c.hatch_m * 1e3,
      c.kp_w_m2k, c.ti_s, c.flux_min_w_m2, c.flux_max_w_m2, control::to_string(c.anti_windup),
      c.measurement.kind == sls3d::TopWeight::Kind::spot
          ? fmt::format("a pyrometer spot at ({:g}, {:g}) mm of 1/e<sup>2</sup> radius {:g} mm", c.measurement.x_m * 1e3,
                        c.measurement.y_m * 1e3, c.measurement.radius_m * 1e3)
          : fmt::format("the mean over {:g} mm &lt;= r &lt;= {:g} mm", c.measurement.inner_radius_m * 1e3,
                        c.measurement.outer_radius_m * 1e3),
      c.source_scale == sls3d::SourceScale::fine ? "fine (resolved spot)" : "part scale (heat lumped along the scan)",
      r.mesh_at_end.ranks);
  html += "<h2>Top surface</h2>\n" + colour_bar + "\n" + maps;
  html += "<h2>Control signal and output</h2>\n" + svg_body(to_svg(u_chart)) + "\n" + svg_body(to_svg(y_chart)) + "\n";
  html += "<h2>Layers</h2>\n<table><tr><th>layer</th><th>spread s</th><th>exposure from s</th><th>to s</th>"
          "<th>scan mm</th><th>laser J</th></tr>\n" + layers + "</table>\n";
  html += fmt::format(
      "<h2>Energy and cost</h2>\n<table>"
      "<tr><th>laser J</th><td>{:.4g}</td></tr><tr><th>preheating flux J</th><td>{:.4g}</td></tr>"
      "<tr><th>radiation J</th><td>{:.4g}</td></tr><tr><th>convection J</th><td>{:.4g}</td></tr>"
      "<tr><th>spreading J</th><td>{:.4g}</td></tr><tr><th>remeshing J</th><td>{:.4g}</td></tr>"
      "<tr><th>densification J</th><td>{:.4g}</td></tr><tr><th>enthalpy change J</th><td>{:.4g}</td></tr>"
      "<tr><th>largest per-step balance error</th><td>{:.2e}</td></tr>"
      "<tr><th>steps</th><td>{}</td></tr><tr><th>cells / dofs (largest)</th><td>{} / {}</td></tr>"
      "<tr><th>seconds per step</th><td>{:.3f}</td></tr><tr><th>wall s</th><td>{:.1f}</td></tr></table>\n",
      e.laser_j, e.top_flux_j, e.radiation_j, e.convection_j, e.spreading_j, e.remesh_j, e.densification_j,
      e.final_j - e.initial_j, r.energy_balance_rel_error, r.steps, r.max_cells, r.max_dofs, r.seconds_per_step,
      r.wall_s);
  html += "</body></html>\n";
  return html;
}

void write_sls3d_report(const sls3d::ScenarioResult& r, const std::string& path) {
  sls3d::write_file_atomically(path, sls3d_page_html(r));
}

}  // namespace amctl::report
