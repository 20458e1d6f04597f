// Hot paths of module process: shrinkage fit with breakpoint search, G-code scaling, mesh
// check and the empirical G-code scan.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/process/empirical_time.hpp"
#include "amctl/process/gcode_scale.hpp"
#include "amctl/process/shrinkage.hpp"
#include "amctl/process/stl.hpp"

namespace pr = amctl::process;

namespace {

std::vector<pr::ShrinkSample> samples(int levels, int repeats) {
  std::vector<pr::ShrinkSample> s;
  for (int i = 1; i <= levels; ++i) {
    const double h = 0.254 * 5 * i;
    for (int k = 0; k < repeats; ++k) {
      const double e = (h < 10 ? 0.02 * h : 0.2 - 0.003 * (h - 10)) + 0.01 * std::sin(7.0 * i + k);
      s.push_back({'Z', h, h + e, 0});
    }
  }
  return s;
}

std::string zigzag_gcode(int layers, int lines_per_layer) {
  std::string g = "G90\nM83\n";
  for (int l = 1; l <= layers; ++l) {
    g += ";LAYER_CHANGE\nG1 Z" + std::to_string(0.2 * l) + " F600\n;TYPE:Solid infill\n";
    for (int i = 0; i < lines_per_layer; ++i) {
      g += "G1 X" + std::to_string(i % 2 ? 0 : 50) + " Y" + std::to_string(0.45 * i) +
           " E1.7 F3000\n";
    }
  }
  return g;
}

pr::Mesh sphere(int n) {
  pr::Mesh m;
  const double pi = 3.14159265358979323846;
  auto p = [&](int i, int j) {
    const double th = pi * i / n, ph = 2 * pi * j / n;
    return pr::Vec3{std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
  };
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const auto a = p(i, j), b = p(i + 1, j), c = p(i + 1, j + 1), d = p(i, j + 1);
      if (i != n - 1) m.triangles.push_back({{}, {a, b, c}});
      if (i != 0) m.triangles.push_back({{}, {a, c, d}});
    }
  }
  return m;
}

}  // namespace

static void BM_ShrinkFitTwoRanges(benchmark::State& st) {
  const auto s = samples(static_cast<int>(st.range(0)), 5);
  pr::ShrinkFitOptions opt;
  opt.ranges = 2;
  for (auto _ : st) benchmark::DoNotOptimize(pr::fit_shrinkage_axis(s, opt));
  st.SetItemsProcessed(st.iterations() * static_cast<long>(s.size()));
}
BENCHMARK(BM_ShrinkFitTwoRanges)->Arg(20)->Arg(200);

static void BM_ScaleGcode(benchmark::State& st) {
  const std::string g = zigzag_gcode(50, 200);
  pr::ScaleMap map;
  map.axes = pr::parse_factor_spec("xy=1.008,z=0.9902:10:1.0032");
  std::string out;
  out.reserve(g.size() + g.size() / 8);
  for (auto _ : st) {
    // The scaler itself, line by line from memory (scale_gcode_file adds the file I/O).
    pr::GcodeScaler scaler(map, {}, "b.gcode");
    out.clear();
    std::uint64_t line_no = 0;
    for (std::size_t begin = 0; begin < g.size();) {
      const std::size_t end = g.find('\n', begin);
      scaler.feed(std::string_view(g).substr(begin, end - begin), ++line_no, out);
      out += '\n';
      begin = end + 1;
    }
    benchmark::DoNotOptimize(out.data());
  }
  st.SetBytesProcessed(st.iterations() * static_cast<long>(g.size()));
}
BENCHMARK(BM_ScaleGcode);

static void BM_CheckMesh(benchmark::State& st) {
  const auto m = sphere(static_cast<int>(st.range(0)));
  for (auto _ : st) benchmark::DoNotOptimize(pr::check_mesh(m));
  st.SetItemsProcessed(st.iterations() * static_cast<long>(m.triangles.size()));
}
BENCHMARK(BM_CheckMesh)->Arg(64)->Arg(256);

static void BM_EmpiricalScan(benchmark::State& st) {
  const std::string g = zigzag_gcode(50, 200);
  for (auto _ : st) benchmark::DoNotOptimize(pr::scan_gcode_for_time(g, "b.gcode", {}));
  st.SetBytesProcessed(st.iterations() * static_cast<long>(g.size()));
}
BENCHMARK(BM_EmpiricalScan);
