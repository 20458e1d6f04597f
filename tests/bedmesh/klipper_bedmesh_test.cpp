// amctl with a bed mesh against Klipper itself (tests/reference/klipper/README.md, "Bed
// mesh"): klipper_times_bedmesh.json and klipper_steps_bedmesh.json were made by
// tests/reference/klipper/bedmesh_crosscheck.py from Klipper's batch mode; this test runs
// without Klipper. The input of each case is built here as the script builds it (a preamble
// that sets the position and loads the mesh, the input or its first lines with every G28
// replaced, an M400). Corpus cases are skipped when the corpus is absent.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../plan/corpus_dir.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::bedmesh {
namespace {

const std::string kDir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/";

bool is_g28(const std::string& line) {
  std::size_t i = 0;
  while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
  if (line.size() < i + 3 || (line[i] != 'G' && line[i] != 'g') || line[i + 1] != '2' || line[i + 2] != '8') {
    return false;
  }
  return line.size() == i + 3 || !(std::isalnum(static_cast<unsigned char>(line[i + 3])) || line[i + 3] == '_');
}

/// bedmesh_crosscheck.py input_text(); nullopt when the input is in the absent corpus.
std::optional<std::string> input_text(const nlohmann::json& c) {
  const std::string input = c.at("input").get<std::string>();
  std::string path = kDir + input;
  if (input.rfind("corpus:", 0) == 0) {
    const auto root = test::corpus_dir();
    if (!root) return std::nullopt;
    path = (*root / "gcode" / input.substr(7)).string();
  }
  std::ifstream f(path, std::ios::binary);
  EXPECT_TRUE(f) << path;
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string all = ss.str();
  const long head = c.at("head_lines").is_null() ? -1 : c.at("head_lines").get<long>();
  std::string body;
  std::size_t pos = 0;
  long n = 0;
  while (head < 0 || n < head) {
    const std::size_t nl = all.find('\n', pos);
    const std::string line = all.substr(pos, nl == std::string::npos ? std::string::npos : nl - pos);
    if (n > 0) body += '\n';
    body += is_g28(line) ? "SET_KINEMATIC_POSITION X=0 Y=0 Z=0" : line;
    ++n;
    if (nl == std::string::npos) break;
    pos = nl + 1;
  }
  return c.at("preamble").get<std::string>() + body + "\nM400\n";
}

TEST(KlipperBedMesh, PrintTimeIsKlippersWithTheMeshLoaded) {
  std::ifstream in(kDir + "klipper_times_bedmesh.json");
  ASSERT_TRUE(in);
  const auto times = nlohmann::json::parse(in);
  int compared = 0;
  for (const auto& [key, c] : times.items()) {
    if (!c.is_object()) continue;
    const auto text = input_text(c);
    if (!text) continue;
    const auto m = machine::load_machine(kDir + c.at("cfg").get<std::string>());
    const plan::EstimateReport r = plan::estimate_text(*text, key, m);
    // Klipper's batch mode with its buffer-runout flush switched off (README.md): a printer
    // fed in time; the stock batch time differs from it by those stops only.
    const double klipper_s = c.at("motion_s").get<double>();
    EXPECT_NEAR(r.total_time_s, klipper_s, 1e-6) << key;
    EXPECT_FALSE(r.range_error.has_value()) << key;
    ++compared;
  }
  EXPECT_GE(compared, 2);  // the synthetic input on both printers at least
}

std::map<std::string, std::pair<double, double>> first_last_from_csv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  std::map<std::string, std::pair<double, double>> out;
  while (std::getline(in, line)) {
    const std::size_t a = line.find(',');
    const std::size_t b = line.find(',', a + 1);
    const std::string name = line.substr(0, a);
    const double t = std::stod(line.substr(a + 1, b - a - 1));
    auto it = out.find(name);
    if (it == out.end()) {
      out.emplace(name, std::make_pair(t, t));
    } else {
      it->second.second = t;
    }
  }
  return out;
}

// Every stepper's count (Z included: the mesh makes Z step during XY moves), forward count,
// first and last step within 25 us + one tick of Klipper's MCU stream.
TEST(KlipperBedMesh, StepsAreKlippersOnEveryStepperZIncluded) {
  std::ifstream in(kDir + "klipper_steps_bedmesh.json");
  ASSERT_TRUE(in);
  const auto ref = nlohmann::json::parse(in);
  const std::string gcode = std::string(AMCTL_BINARY_DIR) + "/klipper_bedmesh_steps.gcode";
  const std::string csv = std::string(AMCTL_BINARY_DIR) + "/klipper_bedmesh_steps.csv";
  int compared = 0;
  for (const auto& r : ref.at("results")) {
    const auto text = input_text(r);
    if (!text) continue;
    std::ofstream(gcode, std::ios::binary) << *text;
    const std::string cfg = r.at("cfg").get<std::string>();
    const auto m = machine::load_machine(kDir + cfg);
    const steppers::StepsReport rep = steppers::generate_steps_file(gcode, m, csv, steppers::StepFilter::klipper);
    const auto fl = first_last_from_csv(csv);
    std::remove(csv.c_str());
    const double bound_s = r.at("bound_us").get<double>() * 1e-6;
    const std::string key = r.at("case").get<std::string>();
    for (const auto& s : r.at("steppers")) {
      const std::string name = s.at("stepper").get<std::string>();
      std::size_t c = 0;
      while (c < rep.motors.size() && rep.motors[c].name != name) ++c;
      ASSERT_LT(c, rep.motors.size()) << key << " " << name;
      EXPECT_EQ(rep.stats[c].steps, s.at("klipper_steps").get<std::uint64_t>()) << key << " " << name;
      EXPECT_EQ(rep.stats[c].steps_positive, s.at("klipper_steps_positive").get<std::uint64_t>())
          << key << " " << name;
      if (rep.stats[c].steps == 0) continue;
      EXPECT_LE(std::abs(s.at("klipper_first_step_s").get<double>() - fl.at(name).first), bound_s)
          << key << " " << name;
      EXPECT_LE(std::abs(s.at("klipper_last_step_s").get<double>() - fl.at(name).second), bound_s)
          << key << " " << name;
    }
    ++compared;
  }
  std::remove(gcode.c_str());
  EXPECT_GE(compared, 2);
}

}  // namespace
}  // namespace amctl::bedmesh
