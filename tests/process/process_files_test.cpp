// The process module's file formats and studies that used to live in the CLI: the shrink
// model file (round trip, errors naming file:line), the printed-size prediction (values
// computed by hand below), the empirical parameter file, and the JSON reader's locations.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "amctl/core/error.hpp"
#include "amctl/process/json_file.hpp"
#include "amctl/process/shrink_apply.hpp"
#include "amctl/process/shrink_model.hpp"
#include "amctl/process/time_study.hpp"

namespace pr = amctl::process;

namespace {

amctl::Error expect_error(auto&& fn) {
  try {
    fn();
  } catch (const amctl::Error& e) {
    return e;
  }
  ADD_FAILURE() << "expected amctl::Error";
  return amctl::Error("none");
}

pr::RangeFit range(double factor, double upper_mm) {
  pr::RangeFit r;
  r.factor = factor;
  r.upper_mm = upper_mm;
  r.line.slope = 1.0 / factor - 1.0;
  r.line.n = 5;
  return r;
}

}  // namespace

TEST(ShrinkModel, RoundTripKeepsFactorsAndBreaksOfEveryAxis) {
  const double inf = std::numeric_limits<double>::infinity();
  pr::AxisShrinkFit x;
  x.axis = 'X';
  x.ranges = {range(1.00827, inf)};
  pr::AxisShrinkFit z;
  z.axis = 'Z';
  z.ranges = {range(0.9902, 10.0), range(1.0032, 25.0), range(1.0011, inf)};
  const auto j = pr::shrink_model_json({x, z}, "parts.csv", true);
  EXPECT_EQ(j["fitted"], "means");
  EXPECT_EQ(j["axes"][1]["factors_spec"], "z=0.990200:10:1.003200:25:1.001100");
  EXPECT_TRUE(j["axes"][0]["upper_mm"].is_null());  // +inf is written as null
  const auto maps = pr::parse_shrink_model(j.dump(2), "model.json");
  EXPECT_EQ(maps[0].factors(), std::vector<double>{1.00827});
  EXPECT_TRUE(maps[0].breaks_mm().empty());
  EXPECT_TRUE(maps[1].is_identity());  // Y not in the file: factor 1
  EXPECT_EQ(maps[2].factors(), (std::vector<double>{0.9902, 1.0032, 1.0011}));
  EXPECT_EQ(maps[2].breaks_mm(), (std::vector<double>{10.0, 25.0}));

  // One axis is written without the "axes" list.
  const auto one = pr::shrink_model_json({z}, "parts.csv", false);
  EXPECT_FALSE(one.contains("axes"));
  EXPECT_EQ(one["fitted"], "measurements");
  EXPECT_EQ(pr::parse_shrink_model(one.dump(2), "z.json")[2].breaks_mm(),
            (std::vector<double>{10.0, 25.0}));
}

TEST(ShrinkModel, MalformedFilesNameFileAndLine) {
  // Syntax: line 3, where the parser stops.
  auto e = expect_error([] { (void)pr::parse_shrink_model("{\n \"axis\": \"Z\",\n \"factor\": ]\n}", "m.json"); });
  EXPECT_EQ(e.where().file, "m.json");
  EXPECT_EQ(e.where().line, 3u) << e.what();
  EXPECT_NE(std::string(e.what()).find("not valid JSON"), std::string::npos) << e.what();

  // A factor that is not a number: the line of its key.
  e = expect_error([] {
    (void)pr::parse_shrink_model("{\n \"axes\": [\n  {\"axis\": \"X\", \"factor\": 1.01},\n"
                                 "  {\"axis\": \"Y\",\n   \"factor\": \"big\"}\n ]\n}\n",
                                 "m.json");
  });
  EXPECT_EQ(e.where().line, 5u) << e.what();
  EXPECT_NE(std::string(e.what()).find("'factor' must be a finite number"), std::string::npos)
      << e.what();

  // An unknown axis: the line of "axis".
  e = expect_error([] { (void)pr::parse_shrink_model("{\"factor\": 1.0,\n\"axis\": \"W\"}", "m.json"); });
  EXPECT_EQ(e.where().line, 2u) << e.what();

  // A range without its upper bound (not the last one): the line of that range.
  e = expect_error([] {
    (void)pr::parse_shrink_model("{\"axis\": \"Z\", \"ranges\": [\n{\"factor\": 0.99},\n"
                                 "{\"factor\": 1.01}]}",
                                 "m.json");
  });
  EXPECT_EQ(e.where().line, 2u) << e.what();
  EXPECT_NE(std::string(e.what()).find("upper_mm"), std::string::npos) << e.what();

  // A factor the map refuses (<= 0): the line of the axis object.
  e = expect_error([] { (void)pr::parse_shrink_model("\n\n{\"axis\": \"Z\", \"factor\": -1}", "m.json"); });
  EXPECT_EQ(e.where().line, 3u) << e.what();

  // A truncated file.
  e = expect_error([] { (void)pr::parse_shrink_model("{\"axis\": \"Z\",\n\"factor\": 1.0", "t.json"); });
  EXPECT_EQ(e.where().line, 2u) << e.what();
}

TEST(ShrinkModel, FactorsArgumentIsAFileOrAnInlineSpec) {
  const auto maps = pr::load_factor_maps("x=1.5,z=0.99:10:1.02");
  EXPECT_EQ(maps[0].factors(), std::vector<double>{1.5});
  EXPECT_EQ(maps[2].breaks_mm(), std::vector<double>{10.0});
  const auto e = expect_error([] { (void)pr::load_factor_maps("/nonexistent/model.json"); });
  EXPECT_NE(std::string(e.what()).find("/nonexistent/model.json"), std::string::npos) << e.what();
}

TEST(PrintedSize, PredictionIsTheCompensatedPartThroughTheInverseMap) {
  // X: 1.01 about 5; Z: 1.01 up to 10 mm, 1.02 above, about 0.
  pr::ScaleMap map;
  map.axes = pr::parse_factor_spec("x=1.01,z=1.01:10:1.02");
  map.origin_mm = {5, 0, 0};
  const std::array<double, 3> nmin{0, 0, 0}, nmax{10, 4, 19.9};
  const std::array<double, 3> cmin{map.apply(nmin)}, cmax{map.apply(nmax)};
  pr::SlicingModel layers{0.2, 0.2, 0.5};
  const auto p = pr::predict_printed_size(map, nmin, nmax, cmin, cmax, layers);
  // X: 5 -/+ 5.05 -> 10.1 wide; back through the inverse: 10.
  EXPECT_NEAR(p.compensated_mm[0], 10.1, 1e-12);
  EXPECT_NEAR(p.predicted_mm[0], 10.0, 1e-12);
  EXPECT_NEAR(p.compensated_mm[1], 4.0, 1e-12);
  // Z: 10 * 1.01 + 9.9 * 1.02 = 20.198.
  EXPECT_NEAR(p.compensated_mm[2], 20.198, 1e-12);
  EXPECT_NEAR(p.predicted_mm[2], 19.9, 1e-12);
  // Mid-layer planes at 0.1, 0.3, ..., 0.2 k - 0.1 <= 20.198: k = 101 layers, 20.2 mm built.
  // 20.2 = 10.1 + 1.02 (u - 10) -> u = 10 + 10.1 / 1.02 = 19.9019608...
  ASSERT_TRUE(p.sliced_z.has_value());
  EXPECT_EQ(p.sliced_z->layers, 101);
  EXPECT_NEAR(p.sliced_z->sliced_height_mm, 20.2, 1e-9);
  EXPECT_NEAR(p.sliced_z->nominal_height_mm, 19.9, 1e-12);
  EXPECT_NEAR(p.sliced_z->predicted_printed_height_mm, 10.0 + 10.1 / 1.02, 1e-9);
  EXPECT_NEAR(p.sliced_z->error_mm, 10.1 / 1.02 - 9.9, 1e-9);
  EXPECT_FALSE(pr::predict_printed_size(map, nmin, nmax, cmin, cmax, std::nullopt).sliced_z);
}

TEST(EmpiricalParams, RoundTripAndDefaults) {
  auto m = pr::EmpiricalTimeModel::fdm2000_seed();
  m.raster_speed_mm_s = 50;
  m.link_widths_mm = {0.4, 0.6};
  m.link_speeds_mm_s = {20, 30};
  m.wipe_s = 0.25;
  pr::ScanOptions so;
  so.link_length_widths = 4;
  so.filament_diameter_mm = 2.85;
  const auto p = pr::parse_empirical_params(pr::empirical_params_json(m, so).dump(2), "p.json");
  EXPECT_EQ(p.model.raster_speed_mm_s, 50);
  EXPECT_EQ(p.model.link_speeds_mm_s, (std::vector<double>{20, 30}));
  EXPECT_EQ(p.model.wipe_s, 0.25);
  EXPECT_EQ(p.scan.link_widths_mm, (std::vector<double>{0.4, 0.6}));  // follows the model
  EXPECT_EQ(p.scan.link_length_widths, 4);
  EXPECT_EQ(p.scan.filament_diameter_mm, 2.85);
  // Wrapped in "model" (calibrate-time's JSON), keys left out keep the seed's values.
  const auto q = pr::parse_empirical_params("{\"rms_s\": 1, \"model\": {\"fixed_s\": 12}}", "c.json");
  EXPECT_EQ(q.model.fixed_s, 12);
  EXPECT_EQ(q.model.raster_speed_mm_s, pr::EmpiricalTimeModel::fdm2000_seed().raster_speed_mm_s);
  EXPECT_EQ(pr::read_empirical_params("").model.travel_speed_mm_s,
            pr::EmpiricalTimeModel::fdm2000_seed().travel_speed_mm_s);
}

TEST(EmpiricalParams, MalformedFilesNameFileAndLine) {
  auto e = expect_error([] {
    (void)pr::parse_empirical_params("{\n\"raster_speed_mm_s\": 50,\n\"travel_speed_mm_s\": \"x\"\n}",
                                     "p.json");
  });
  EXPECT_EQ(e.where().file, "p.json");
  EXPECT_EQ(e.where().line, 3u) << e.what();
  e = expect_error([] {
    (void)pr::parse_empirical_params("{\"link_speeds_mm_s\": [\n 10,\n null]}", "p.json");
  });
  EXPECT_EQ(e.where().line, 3u) << e.what();
  // Values the model refuses (a negative speed) name the object.
  e = expect_error([] { (void)pr::parse_empirical_params("\n{\"raster_speed_mm_s\": -1}", "p.json"); });
  EXPECT_EQ(e.where().line, 2u) << e.what();
}

TEST(JsonFile, NumbersBeyondADoubleAreErrorsWithTheirLine) {
  // Found by fuzz_process_json: nlohmann's out_of_range (number overflow) escaped as a foreign
  // exception; amctl printed it without a file or line, and a library caller got no
  // amctl::Error at all.
  for (const char* text : {"{\n\"link_speeds_mm_s\": [1e30920]\n}", "{\n\"link_speeds_mm_s\": [-1e400\n]}"}) {
    const auto e = expect_error([&] { (void)pr::parse_empirical_params(text, "p.json"); });
    EXPECT_EQ(e.where().file, "p.json");
    EXPECT_EQ(e.where().line, 2u) << e.what();
    EXPECT_NE(std::string(e.what()).find("expected a number within the range of a double"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(expect_error([] { (void)pr::parse_shrink_model("{\"axis\": \"Z\", \"factor\": 1e999}", "m.json"); })
                .where()
                .line,
            1u);
}

TEST(JsonFile, EveryValueHasTheLineItStartsOn) {
  const auto f = pr::JsonFile::parse("{\n \"a\": 1,\n \"b\": [\n  2,\n  {\"c\": 3}\n ],\n \"d/e\": 4\n}",
                                     "f.json");
  EXPECT_EQ(f.where("/a").line, 2u);
  EXPECT_EQ(f.where("/b").line, 3u);
  EXPECT_EQ(f.where("/b/0").line, 4u);
  EXPECT_EQ(f.where("/b/1").line, 5u);
  EXPECT_EQ(f.where("/b/1/c").line, 5u);
  EXPECT_EQ(f.where("/d~1e").line, 7u);
  EXPECT_EQ(f.where("/b/1/missing").line, 5u);  // the nearest enclosing value
  EXPECT_EQ(f.number("/b/1/c"), 3.0);
}
