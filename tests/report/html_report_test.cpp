// The page: self-contained (no URL in any src or href, a CSP that forbids every request),
// its JSON parses back and holds the estimate's totals; a file without moves still gets a
// page that says so; bad input is an amctl::Error with file:line:col.
#include "amctl/report/html_report.hpp"

#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/simulation/shaped_simulation.hpp"
#include "test_util.hpp"

namespace amctl::report {
namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The JSON between <script type="application/json" id="data"> and </script>.
Json embedded_json(const std::string& page) {
  const std::string open = "<script type=\"application/json\" id=\"data\">";
  const std::size_t a = page.find(open);
  EXPECT_NE(a, std::string::npos);
  const std::size_t b = page.find("</script>", a);
  EXPECT_NE(b, std::string::npos);
  return Json::parse(page.substr(a + open.size(), b - a - open.size()));
}

TEST(HtmlReport, PageIsSelfContainedAndItsJsonHoldsTheTotals) {
  const machine::Machine m = test::klipper();
  const std::string gcode = test::write_temp("poly.gcode", test::polygons(12, 20));
  const std::string out = ::testing::TempDir() + "/amctl_report_poly.html";
  const ReportResult r = write_report(gcode, m, out, ReportOptions{});
  const std::string page = read_all(out);
  EXPECT_EQ(r.bytes, page.size());
  EXPECT_EQ(page.find("http://"), std::string::npos);
  EXPECT_EQ(page.find("https://"), std::string::npos);
  // No src or href attribute that names any URL (none at all, in fact).
  EXPECT_FALSE(std::regex_search(page, std::regex(R"((src|href)\s*=\s*["']?[^"'\s>]*//)", std::regex::icase)));
  EXPECT_FALSE(std::regex_search(page, std::regex(R"(<(link|iframe|img|object|embed)\b)", std::regex::icase)));
  EXPECT_NE(page.find("<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
                      "script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data:\">"),
            std::string::npos);
  EXPECT_EQ(std::remove((out + ".part").c_str()), -1);  // no temporary left behind

  const Json d = embedded_json(page);
  const plan::EstimateReport e = plan::estimate_file(gcode, m);
  EXPECT_DOUBLE_EQ(d["estimate"]["total_time_s"].get<double>(), e.total_time_s);
  EXPECT_DOUBLE_EQ(d["estimate"]["filament_mm"].get<double>(), e.filament_mm);
  EXPECT_EQ(d["estimate"]["moves"].get<std::uint64_t>(), e.moves);
  EXPECT_EQ(d["estimate"]["layers"].size(), 12u);
  EXPECT_EQ(r.moves, e.moves);
  EXPECT_EQ(r.layers, 12u);
  EXPECT_FALSE(d["no_moves"].get<bool>());
  EXPECT_TRUE(d["quality"].is_null());
  // Speed buckets cover the print and no bucket is faster than the top speed.
  const Json& s = d["speed"];
  EXPECT_GE(s["bucket_s"].get<double>() * static_cast<double>(s["max_speed"].size()), e.total_time_s - 1e-9);
  EXPECT_LE(s["max_speed"].size(), 4096u);
  for (const auto& v : s["max_speed"]) EXPECT_LE(v.get<double>() / 10.0, e.max_speed_mm_s + 0.05);
  // Toolpath: 12 layers whose vertices add up to the count, decoded back to the polygon.
  const Json& tp = d["toolpath"];
  ASSERT_EQ(tp["layers"].size(), 12u);
  std::size_t n = 0;
  for (const auto& l : tp["layers"]) {
    n += l["dx"].size();
    EXPECT_EQ(l["dy"].size(), l["dx"].size());
    EXPECT_EQ(l["speed"].size(), l["dx"].size());
    EXPECT_EQ(l["kind"].size(), l["dx"].size());
  }
  EXPECT_EQ(n, tp["points"].get<std::size_t>());
  const Json& l1 = tp["layers"][1];
  long x = 0, y = 0;
  for (std::size_t i = 0; i < l1["dx"].size(); ++i) {
    x += l1["dx"][i].get<long>();
    y += l1["dy"][i].get<long>();
  }
  EXPECT_NEAR(x / 100.0, 120.0, 0.011);  // the polygon closes where it started
  EXPECT_NEAR(y / 100.0, 100.0, 0.011);
}

TEST(HtmlReport, JsonCannotCloseTheScriptElement) {
  Json d = {{"file", "</script><script>alert(1)</script>"}};
  const std::string page = render_html(d);
  const std::size_t a = page.find("id=\"data\">");
  const std::size_t b = page.find("</script>", a);
  EXPECT_EQ(Json::parse(page.substr(a + 10, b - a - 10))["file"], d["file"]);
}

TEST(HtmlReport, WithABeltModelTheToolpathCarriesContourErrors) {
  const machine::Machine m = test::klipper();
  const std::string gcode = test::write_temp("poly_sim.gcode", test::polygons(4, 8));
  ReportOptions o;
  o.belt = BeltModelOptions{30.0, 0.1};
  const Json d = report_data(gcode, m, o);
  ASSERT_FALSE(d["quality"].is_null());
  const double max_mm = d["quality"]["max_contour_error_mm"].get<double>();
  EXPECT_GT(max_mm, 0.0);
  long top_um = -1;
  for (const auto& l : d["toolpath"]["layers"]) {
    ASSERT_TRUE(l.contains("error_um"));
    for (const auto& e : l["error_um"]) top_um = std::max(top_um, e.get<long>());
  }
  // The largest per-segment error is the simulation's maximum (rounded to a micrometre).
  EXPECT_NEAR(static_cast<double>(top_um), max_mm * 1000.0, 1.0);
}

TEST(HtmlReport, TheMachinesInputShaperDrivesTheContourColouringAsInSimulate) {
  // The same shaped simulation `amctl simulate` runs: its figures, to the last bit, and the
  // page says which shaper it used; --no-shaper (machine_shaper = false) is the unshaped run.
  machine::Machine m = test::klipper();
  m.input_shaper.shaper_type_x = "mzv";
  m.input_shaper.shaper_type_y = "ei";
  m.input_shaper.shaper_freq_x_hz = 42.0;
  m.input_shaper.shaper_freq_y_hz = 36.0;
  const std::string gcode = test::write_temp("poly_shaped.gcode", test::polygons(3, 8));
  ReportOptions o;
  o.belt = BeltModelOptions{30.0, 0.1};
  const Json d = report_data(gcode, m, o);
  ASSERT_FALSE(d["quality"].is_null());
  const Json& sh = d["quality"]["shaper"];
  EXPECT_EQ(sh["x"]["type"], "mzv");
  EXPECT_EQ(sh["x"]["freq_hz"].get<double>(), 42.0);
  EXPECT_EQ(sh["x"]["firmware"], "klipper");
  EXPECT_EQ(sh["y"]["type"], "ei");
  EXPECT_EQ(sh["y"]["source"], "machine " + m.name);

  dynamics::PrintSimulationOptions po;
  po.simulation.sample_rate_hz = o.sample_rate_hz;
  po.metrics.keep_per_move = false;
  const auto belt = dynamics::AxisModel::belt(30.0, 0.1);
  const simulation::ShaperSettings settings = simulation::resolve_shapers({}, m, gcode);
  const simulation::ShapedPrintResult r = simulation::simulate_shaped_print(gcode, m, belt, belt, po, settings);
  EXPECT_EQ(d["quality"]["max_contour_error_mm"].get<double>(), r.shaped.report.max_contour_error_mm);
  EXPECT_EQ(d["quality"]["rms_contour_error_mm"].get<double>(), r.shaped.report.rms_contour_error_mm);
  EXPECT_NE(r.shaped.report.max_contour_error_mm, r.without.report.max_contour_error_mm);

  o.machine_shaper = false;
  const Json u = report_data(gcode, m, o);
  EXPECT_FALSE(u["quality"].contains("shaper"));
  EXPECT_EQ(u["quality"]["max_contour_error_mm"].get<double>(), r.without.report.max_contour_error_mm);
  // The page shows the shaper card.
  EXPECT_NE(render_html(d).find("Input shaper"), std::string::npos);
}

TEST(HtmlReport, AnAccelerometerRecordAddsKlippersCalibrationAndTheShaperCurves) {
  // A Klipper PSD CSV with one resonance (f0 = 42 Hz, zeta = 0.08: |H|^2 of a second-order
  // system, the same on x and y): the section holds what resonance::calibrate_file says, the
  // PSD up to 200 Hz, a remaining-vibration curve per fitted shaper that is ~0 at its own
  // frequency (ZV-family shapers cancel their design mode exactly; EI leaves its tolerance)
  // and psd_xyz times the recommended shaper's curve.
  std::string csv = "freq,psd_x,psd_y,psd_z,psd_xyz\n";
  for (int i = 0; i <= 600; ++i) {
    const double f = 1.0 + 0.5 * i, r = f / 42.0;
    const double h = 1.0 / ((1 - r * r) * (1 - r * r) + (2 * 0.08 * r) * (2 * 0.08 * r));
    csv += std::to_string(f) + "," + std::to_string(h) + "," + std::to_string(h) + ",0.001," +
           std::to_string(2 * h + 0.001) + "\n";
  }
  const std::string psd = test::write_temp("psd.csv", csv);
  const std::string gcode = test::write_temp("poly_accel.gcode", test::polygons(2, 6));
  ReportOptions o;
  o.accel_path = psd;
  const Json d = report_data(gcode, test::klipper(), o);
  ASSERT_FALSE(d["accel"].is_null());
  const Json& a = d["accel"];
  const Json& p = a["plot"];
  const std::size_t n = p["freq_hz"].size();
  ASSERT_GT(n, 300u);
  EXPECT_LE(p["freq_hz"].back().get<double>(), 200.0);
  EXPECT_EQ(p["psd_xyz"].size(), n);
  ASSERT_EQ(p["curves"].size(), a["klipper"]["shapers"].size());
  const std::string rec = a["klipper"]["recommended"]["name"];
  for (const auto& c : p["curves"]) {
    ASSERT_EQ(c["remaining"].size(), n);
    if (c["name"] == "zv" || c["name"] == "mzv") {
      // At the grid point nearest its frequency the curve is far below its value elsewhere.
      const double fc = c["freq_hz"];
      std::size_t k = 0;
      for (std::size_t i = 0; i < n; ++i) {
        if (std::abs(p["freq_hz"][i].get<double>() - fc) < std::abs(p["freq_hz"][k].get<double>() - fc)) k = i;
      }
      EXPECT_LT(c["remaining"][k].get<double>(), 0.05) << c["name"];
    }
    if (c["name"] == rec) {
      for (std::size_t i = 0; i < n; i += 37) {
        EXPECT_NEAR(p["after_recommended"][i].get<double>(),
                    p["psd_xyz"][i].get<double>() * c["remaining"][i].get<double>(),
                    1e-12 * (1 + p["psd_xyz"][i].get<double>()));
      }
    }
  }
  // A bad record is an error naming it, and no page.
  o.accel_path = test::write_temp("bad_psd.csv", "freq,psd_x\n1,2\n");
  EXPECT_THROW((void)report_data(gcode, test::klipper(), o), Error);
}

TEST(HtmlReport, AThermalRunAddsTheHeaterLoopWithBoundedTraces) {
  const std::string gcode = test::write_temp("poly_thermal.gcode", test::polygons(2, 6));
  ReportOptions o;
  o.thermal = "hotend";
  const Json d = report_data(gcode, test::klipper(), o);
  ASSERT_FALSE(d["thermal"].is_null());
  const Json& t = d["thermal"];
  EXPECT_EQ(t["target_c"].get<double>(), 210.0);
  ASSERT_EQ(t["traces"].size(), t["runs"].size());
  ASSERT_GE(t["traces"].size(), 2u);  // the tuned PID and the MPC at least
  for (const auto& r : t["traces"]) {
    const std::size_t n = r["t_s"].size();
    ASSERT_GT(n, 100u);
    EXPECT_LE(n, 1500u);
    EXPECT_EQ(r["measured_c"].size(), n);
    EXPECT_EQ(r["duty"].size(), n);
    // Every controller holds the set point before the fan step at 180 s (within 2 K).
    std::size_t k = 0;
    while (k + 1 < n && r["t_s"][k + 1].get<double>() < 175.0) ++k;
    EXPECT_NEAR(r["measured_c"][k].get<double>(), 210.0, 2.0) << r["controller"];
    for (const auto& u : r["duty"]) {
      EXPECT_GE(u.get<double>(), 0.0);
      EXPECT_LE(u.get<double>(), 1.0);
    }
  }
  o.thermal = "chamber";
  EXPECT_THROW((void)report_data(gcode, test::klipper(), o), Error);
}

TEST(HtmlReport, FileWithoutMovesStillGetsAPageThatSaysSo) {
  const std::string gcode = test::write_temp("nomoves.gcode", "; nothing here\nM104 S200\nG90\n");
  const std::string out = ::testing::TempDir() + "/amctl_report_nomoves.html";
  ReportOptions o;
  o.belt = BeltModelOptions{40.0, 0.1};  // and no simulation error for want of moves
  const ReportResult r = write_report(gcode, test::klipper(), out, o);
  EXPECT_EQ(r.moves, 0u);
  const Json d = embedded_json(read_all(out));
  EXPECT_TRUE(d["no_moves"].get<bool>());
  EXPECT_TRUE(d["quality"].is_null());
  EXPECT_NE(read_all(out).find("This file has no moves"), std::string::npos);
}

TEST(HtmlReport, BadInputNamesFileLineAndColumnAndWritesNothing) {
  const std::string gcode = test::write_temp("bad.gcode", "G90\nG1 X10 Y10 F3000\nG1 X1.2.3\n");
  const std::string out = ::testing::TempDir() + "/amctl_report_bad.html";
  std::remove(out.c_str());
  try {
    (void)write_report(gcode, test::klipper(), out, ReportOptions{});
    FAIL() << "expected amctl::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.gcode:3:"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::ifstream(out).good());
}

}  // namespace
}  // namespace amctl::report
