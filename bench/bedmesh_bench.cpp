// The cost of Klipper's [bed_mesh] in the estimate (docs/bedmesh.md section 6): the same
// synthetic print as BM_EstimateKlipper (plan_bench.cpp) on a printer.cfg with a 7x7 bicubic
// mesh, without loading it (the transform passes moves through) and with it loaded (every move
// gets its z; moves longer than move_check_distance are split). Items: the file's moves, so
// the rates compare with BM_EstimateKlipper's. And one z lookup on the upsampled mesh.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "amctl/bedmesh/mesh.hpp"
#include "amctl/plan/estimate.hpp"
#include "synthetic.hpp"

namespace {

amctl::bedmesh::Profile tilted_bowl() {
  amctl::bedmesh::Profile p;
  p.name = "default";
  p.params = {20.0, 280.0, 20.0, 280.0, 7, 7, 2, 2, amctl::bedmesh::Algorithm::bicubic, 0.2};
  for (int j = 0; j < 7; ++j) {
    for (int i = 0; i < 7; ++i) {
      const double u = i / 6.0 - 0.5, v = j / 6.0 - 0.5;
      p.points_mm.push_back(0.06 * u - 0.045 * v + 0.22 * (u * u + v * v) - 0.05);
    }
  }
  return p;
}

amctl::machine::Machine mesh_machine() {
  amctl::machine::Machine m;  // Klipper, as BM_EstimateKlipper
  amctl::ConfigSection bm;
  bm.name = "bed_mesh";
  bm.options["mesh_min"] = amctl::ConfigValue{"20, 20", {}, {1}};
  bm.options["mesh_max"] = amctl::ConfigValue{"280, 280", {}, {2}};
  bm.options["probe_count"] = amctl::ConfigValue{"7, 7", {}, {3}};
  m.klipper_config.push_back(bm);
  const amctl::bedmesh::Profile p = tilted_bowl();
  amctl::ConfigSection s;
  s.name = "bed_mesh default";
  std::string points;
  std::vector<std::uint64_t> lines{10};
  for (int j = 0; j < 7; ++j) {
    points += '\n';
    for (int i = 0; i < 7; ++i) points += fmt::format("{}{:.6f}", i ? ", " : "", p.points_mm[j * 7 + i]);
    lines.push_back(11 + j);
  }
  s.options["version"] = amctl::ConfigValue{"1", {}, {9}};
  s.options["points"] = amctl::ConfigValue{points, {}, lines};
  for (const auto& [k, v] : {std::pair<const char*, const char*>{"min_x", "20"}, {"max_x", "280"}, {"min_y", "20"},
                             {"max_y", "280"}, {"x_count", "7"}, {"y_count", "7"}, {"mesh_x_pps", "2"},
                             {"mesh_y_pps", "2"}, {"algo", "bicubic"}, {"tension", "0.2"}}) {
    s.options[k] = amctl::ConfigValue{v, {}, {20}};
  }
  m.klipper_config.push_back(s);
  return m;
}

void run(benchmark::State& state, const std::string& g, const amctl::machine::Machine& m) {
  for (auto _ : state) {
    auto r = amctl::plan::estimate_text(g, "bench", m);
    benchmark::DoNotOptimize(r.total_time_s);
  }
  state.SetItemsProcessed(state.range(0) * state.iterations());
}

void BM_EstimateKlipperBedMeshNotLoaded(benchmark::State& state) {
  run(state, amctl::bench::synthetic_gcode(static_cast<std::size_t>(state.range(0))), mesh_machine());
}
BENCHMARK(BM_EstimateKlipperBedMeshNotLoaded)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

void BM_EstimateKlipperBedMeshLoaded(benchmark::State& state) {
  run(state, "BED_MESH_PROFILE LOAD=default\n" + amctl::bench::synthetic_gcode(static_cast<std::size_t>(state.range(0))),
      mesh_machine());
}
BENCHMARK(BM_EstimateKlipperBedMeshLoaded)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

void BM_BedMeshZAt(benchmark::State& state) {
  const amctl::bedmesh::ZMesh mesh(tilted_bowl());
  double x = 20.0, sum = 0.0;
  for (auto _ : state) {
    x = x > 280.0 ? 20.0 : x + 0.37;
    sum += mesh.z_at(x, 300.0 - x);
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_BedMeshZAt);

}  // namespace
