#include "amctl/process/stl.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_map>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"

namespace amctl::process {
namespace {

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Vec3 unit_normal(const Triangle& t) {
  // The edges scaled by their largest component first: the cross product of coordinates near
  // the double range (an STL may hold 1e301) would overflow to inf and NaN.
  Vec3 a = sub(t.v[1], t.v[0]), b = sub(t.v[2], t.v[0]);
  for (Vec3* e : {&a, &b}) {
    const double s = std::max({std::abs((*e)[0]), std::abs((*e)[1]), std::abs((*e)[2])});
    if (s > 0 && std::isfinite(s)) *e = {(*e)[0] / s, (*e)[1] / s, (*e)[2] / s};
  }
  Vec3 n = cross(a, b);
  const double l = std::sqrt(dot(n, n));
  if (l > 0 && std::isfinite(l)) n = {n[0] / l, n[1] / l, n[2] / l};
  if (!(std::isfinite(n[0]) && std::isfinite(n[1]) && std::isfinite(n[2]))) n = {0.0, 0.0, 0.0};
  return n;
}

float read_f32(const char* p) {
  float f;
  std::memcpy(&f, p, 4);
  return f;
}

Mesh parse_binary(std::string_view b, const std::string& file, std::uint32_t n) {
  Mesh m;
  m.format = StlFormat::binary;
  std::string header(b.substr(0, 80));
  header.erase(std::find(header.begin(), header.end(), '\0'), header.end());
  m.name = header;
  m.triangles.resize(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const char* p = b.data() + 84 + 50 * static_cast<std::size_t>(i);
    Triangle& t = m.triangles[i];
    for (int k = 0; k < 3; ++k) t.normal[k] = read_f32(p + 4 * k);
    for (int v = 0; v < 3; ++v) {
      for (int k = 0; k < 3; ++k) {
        const double c = read_f32(p + 12 + 12 * v + 4 * k);
        if (!std::isfinite(c)) {
          throw Error(SourceLocation{file, 0, 0},
                      fmt::format("triangle {} vertex {} has a non-finite coordinate", i + 1, v + 1));
        }
        t.v[v][k] = c;
      }
    }
  }
  return m;
}

struct Lexer {
  std::string_view s;
  std::size_t pos = 0;
  std::uint64_t line = 1;
  std::string file;
  std::size_t line_begin = 0;  // offset of the current line's first byte
  std::uint32_t column = 0;    // 1-based column of the last word read, 0 at the end of file
  std::string_view next() {
    while (pos < s.size() && std::isspace(static_cast<unsigned char>(s[pos]))) {
      if (s[pos] == '\n') {
        ++line;
        line_begin = pos + 1;
      }
      ++pos;
    }
    const std::size_t b = pos;
    while (pos < s.size() && !std::isspace(static_cast<unsigned char>(s[pos]))) ++pos;
    column = b < s.size() ? static_cast<std::uint32_t>(b - line_begin + 1) : 0;
    return s.substr(b, pos - b);
  }
  std::string rest_of_line() {
    const std::size_t e = s.find('\n', pos);
    std::string r(s.substr(pos, (e == std::string_view::npos ? s.size() : e) - pos));
    pos = e == std::string_view::npos ? s.size() : e;
    while (!r.empty() && std::isspace(static_cast<unsigned char>(r.back()))) r.pop_back();
    while (!r.empty() && std::isspace(static_cast<unsigned char>(r.front()))) r.erase(0, 1);
    return r;
  }
  [[noreturn]] void fail(const std::string& msg) const {
    throw Error(SourceLocation{file, line, column}, msg);
  }
  void expect(std::string_view word) {
    const auto w = next();
    if (w != word) {
      fail(fmt::format("expected '{}', found '{}'", word, w.empty() ? "end of file" : std::string(w)));
    }
  }
  double number() {
    const auto w = next();
    double v = 0;
    const char* b = w.data();
    if (!w.empty() && *b == '+') ++b;
    auto [p, ec] = std::from_chars(b, w.data() + w.size(), v);
    if (w.empty()) fail("unexpected end of file inside a facet (truncated STL?)");
    if (ec != std::errc() || p != w.data() + w.size() || !std::isfinite(v)) {
      fail(fmt::format("expected a finite number, found '{}'", w));
    }
    return v;
  }
};

Mesh parse_ascii(std::string_view s, const std::string& file) {
  Mesh m;
  m.format = StlFormat::ascii;
  Lexer lx{s, 0, 1, file};
  lx.expect("solid");
  m.name = lx.rest_of_line();
  while (true) {
    const auto w = lx.next();
    if (w == "endsolid") break;
    if (w.empty()) lx.fail("unexpected end of file: missing 'endsolid'");
    if (w != "facet") lx.fail(fmt::format("expected 'facet' or 'endsolid', found '{}'", w));
    Triangle t;
    lx.expect("normal");
    for (int k = 0; k < 3; ++k) t.normal[k] = lx.number();
    lx.expect("outer");
    lx.expect("loop");
    for (int v = 0; v < 3; ++v) {
      lx.expect("vertex");
      for (int k = 0; k < 3; ++k) t.v[v][k] = lx.number();
    }
    lx.expect("endloop");
    lx.expect("endfacet");
    m.triangles.push_back(t);
  }
  return m;
}

}  // namespace

Vec3 Mesh::min_corner() const {
  Vec3 c{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
         std::numeric_limits<double>::infinity()};
  for (const auto& t : triangles)
    for (const auto& v : t.v)
      for (int k = 0; k < 3; ++k) c[k] = std::min(c[k], v[k]);
  return c;
}

Vec3 Mesh::max_corner() const {
  Vec3 c{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
         -std::numeric_limits<double>::infinity()};
  for (const auto& t : triangles)
    for (const auto& v : t.v)
      for (int k = 0; k < 3; ++k) c[k] = std::max(c[k], v[k]);
  return c;
}

Mesh parse_stl(std::string_view b, const std::string& file) {
  if (b.size() >= 84) {
    std::uint32_t n;
    std::memcpy(&n, b.data() + 80, 4);
    if (b.size() == 84 + 50 * static_cast<std::uint64_t>(n)) {
      if (n == 0) throw Error(SourceLocation{file, 0, 0}, "binary STL holds no triangles");
      return parse_binary(b, file, n);
    }
  }
  std::size_t i = 0;
  while (i < b.size() && std::isspace(static_cast<unsigned char>(b[i]))) ++i;
  if (b.substr(i, 5) == "solid") {
    Mesh m = parse_ascii(b, file);
    if (m.triangles.empty()) throw Error(SourceLocation{file, 0, 0}, "ASCII STL holds no facets");
    return m;
  }
  if (b.size() >= 84) {
    std::uint32_t n;
    std::memcpy(&n, b.data() + 80, 4);
    throw Error(SourceLocation{file, 0, 0},
                fmt::format("not an STL file: {} bytes, but a binary STL with the {} triangles "
                            "its header announces has {} bytes, and it does not start with 'solid'",
                            b.size(), n, 84 + 50 * static_cast<std::uint64_t>(n)));
  }
  throw Error(SourceLocation{file, 0, 0},
              fmt::format("found {} bytes, too short for a binary STL and not ASCII STL text; expected an STL model", b.size()));
}

Mesh read_stl(const std::string& path) { return parse_stl(read_file_bytes(path, "STL model", 2ull << 30), path); }

namespace {
// The name after "solid" ends at the line's end: a binary header may hold line breaks and
// other control bytes (and then text such as "outer loop" that would be read as the mesh),
// so each of them becomes a space.
std::string ascii_solid_name(const std::string& name) {
  std::string out = name;
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  }
  const auto b = out.find_first_not_of(' ');
  if (b == std::string::npos) return "amctl";
  return out.substr(b, out.find_last_not_of(' ') + 1 - b);
}
}  // namespace

std::string serialize_stl(const Mesh& m, StlFormat format) {
  if (format == StlFormat::ascii) {
    const std::string name = ascii_solid_name(m.name);
    std::string out = fmt::format("solid {}\n", name);
    for (const auto& t : m.triangles) {
      const Vec3 n = unit_normal(t);
      out += fmt::format("  facet normal {:.9g} {:.9g} {:.9g}\n    outer loop\n", n[0], n[1], n[2]);
      for (const auto& v : t.v) out += fmt::format("      vertex {:.9g} {:.9g} {:.9g}\n", v[0], v[1], v[2]);
      out += "    endloop\n  endfacet\n";
    }
    out += fmt::format("endsolid {}\n", name);
    return out;
  }
  std::string out(84 + 50 * m.triangles.size(), '\0');
  std::string header = m.name.substr(0, 80);
  // A binary header must not begin with "solid" or readers may take it for ASCII.
  if (header.rfind("solid", 0) == 0) header = "amctl " + header.substr(5);
  std::memcpy(out.data(), header.data(), std::min<std::size_t>(header.size(), 80));
  const auto n = static_cast<std::uint32_t>(m.triangles.size());
  std::memcpy(out.data() + 80, &n, 4);
  for (std::size_t i = 0; i < m.triangles.size(); ++i) {
    char* p = out.data() + 84 + 50 * i;
    const Vec3 nn = unit_normal(m.triangles[i]);
    for (int k = 0; k < 3; ++k) {
      const float f = static_cast<float>(nn[k]);
      std::memcpy(p + 4 * k, &f, 4);
    }
    for (int v = 0; v < 3; ++v) {
      for (int k = 0; k < 3; ++k) {
        const float f = static_cast<float>(m.triangles[i].v[v][k]);
        std::memcpy(p + 12 + 12 * v + 4 * k, &f, 4);
      }
    }
  }
  return out;
}

MeshCheck check_mesh(const Mesh& m) {
  MeshCheck c;
  std::map<Vec3, std::uint32_t> ids;
  std::vector<Vec3> pts;
  auto id_of = [&](const Vec3& p) {
    auto [it, inserted] = ids.emplace(p, static_cast<std::uint32_t>(pts.size()));
    if (inserted) pts.push_back(p);
    return it->second;
  };
  // Per undirected edge: uses, and net direction count (+1 for a->b with a < b, -1 otherwise).
  struct EdgeUse {
    int uses = 0;
    int forward = 0;
  };
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  auto describe = [&](std::uint32_t a, std::uint32_t b) {
    return fmt::format("({:.4g}, {:.4g}, {:.4g})-({:.4g}, {:.4g}, {:.4g})", pts[a][0], pts[a][1],
                       pts[a][2], pts[b][0], pts[b][1], pts[b][2]);
  };
  for (std::size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& t = m.triangles[i];
    const std::uint32_t v[3] = {id_of(t.v[0]), id_of(t.v[1]), id_of(t.v[2])};
    const Vec3 n = cross(sub(t.v[1], t.v[0]), sub(t.v[2], t.v[0]));
    c.volume_mm3 += dot(t.v[0], cross(t.v[1], t.v[2])) / 6.0;
    if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2] || dot(n, n) == 0.0) {
      if (c.first_problem.empty()) {
        c.first_problem = fmt::format("triangle {} is degenerate (zero area)", i + 1);
      }
      ++c.degenerate_triangles;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = v[k], b = v[(k + 1) % 3];
      const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
      auto& e = edges[key];
      ++e.uses;
      e.forward += a < b ? 1 : -1;
    }
  }
  c.vertices = pts.size();
  c.edges = edges.size();
  for (const auto& [key, e] : edges) {
    const auto a = static_cast<std::uint32_t>(key >> 32), b = static_cast<std::uint32_t>(key);
    if (e.uses == 1) {
      if (c.first_problem.empty()) c.first_problem = "open edge " + describe(a, b);
      ++c.boundary_edges;
    } else if (e.uses > 2) {
      if (c.first_problem.empty()) {
        c.first_problem = fmt::format("edge {} shared by {} triangles", describe(a, b), e.uses);
      }
      ++c.nonmanifold_edges;
    } else if (e.forward != 0) {
      if (c.first_problem.empty()) {
        c.first_problem = "edge " + describe(a, b) + " traversed the same way by both triangles";
      }
      ++c.misoriented_edges;
    }
  }
  return c;
}

void require_closed_manifold(const Mesh& mesh, const std::string& file) {
  const MeshCheck c = check_mesh(mesh);
  if (c.ok()) return;
  throw Error(SourceLocation{file, 0, 0},
              fmt::format("broken mesh, refusing to scale it: {} open edge(s), {} non-manifold "
                          "edge(s), {} inconsistently oriented edge(s), {} degenerate "
                          "triangle(s); first: {} (repair it, e.g. in PrusaSlicer or admesh)",
                          c.boundary_edges, c.nonmanifold_edges, c.misoriented_edges,
                          c.degenerate_triangles, c.first_problem));
}

Mesh scale_mesh(const Mesh& mesh, const ScaleMap& map) {
  Mesh out = mesh;
  for (auto& t : out.triangles) {
    for (auto& v : t.v) v = map.apply(v);
    t.normal = unit_normal(t);
  }
  return out;
}

}  // namespace amctl::process
