// The recommendation from a modal model (docs/resonance.md, "Recommendation from the model"):
// on a 40 Hz, zeta 0.05 mode the simulated optimum sits at the mode, removes most of the
// contour error, respects the smoothing budget, and a tight budget moves it up.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/shaper.hpp"
#include "amctl/tuning/recommend.hpp"

namespace amctl::tuning {
namespace {

const Candidate& of_type(const Recommendation& r, const std::string& name) {
  for (const Candidate& c : r.per_type) {
    if (c.name == name) return c;
  }
  throw Error("no candidate " + name);
}

void expect_within_budget(const Recommendation& r) {
  for (const Candidate& c : r.per_type) {
    EXPECT_LE(c.smoothing_mm, r.max_smoothing_mm + 1e-9) << c.name << " at " << c.freq_hz;
    // the reported smoothing is Klipper's measure at the budget's accel and scv
    const double s = shaping::smoothing_mm(shaping::make_shaper(c.name, c.freq_hz, 0.1),
                                           r.smoothing_accel_mm_s2, r.scv_mm_s);
    EXPECT_NEAR(c.smoothing_mm, s, 1e-12);
  }
  for (const Candidate& c : r.evaluated) {
    EXPECT_LE(c.smoothing_mm, r.max_smoothing_mm + 1e-9) << c.name << " at " << c.freq_hz;
  }
}

TEST(Recommend, FortyHertzModeDefaultBudget) {
  const machine::Machine m = machine::load_machine("default");
  const ModalModel model{40.0, 0.05};
  const Recommendation r = recommend(model, m, {}, klipper_pick_for_model(model));
  EXPECT_EQ(r.smoothing_accel_mm_s2, m.max_accel_mm_s2);
  EXPECT_EQ(r.max_smoothing_mm, 0.12);
  EXPECT_TRUE(r.best.name == "zv" || r.best.name == "mzv") << r.best.name;
  // ZV: the optimum of the largest contour error lies a few percent above the mode (the
  // shaper's corner rounding pulls it up; the RMS error is lowest at the mode itself).
  const Candidate& zv = of_type(r, "zv");
  EXPECT_NEAR(zv.freq_hz, 40.0, 0.06 * 40.0);
  EXPECT_GE(zv.freq_hz, 40.0);
  // most of the contour error is gone
  EXPECT_LT(r.best.contour_error_mm * 5.0, r.unshaped.contour_error_mm);
  EXPECT_LT(r.best.rms_contour_error_mm * 5.0, r.unshaped.rms_contour_error_mm);
  // the best is the best per type, and no worse than Klipper's pick simulated the same way
  for (const Candidate& c : r.per_type) EXPECT_LE(r.best.contour_error_mm, c.contour_error_mm);
  ASSERT_TRUE(r.klipper.has_value());
  EXPECT_LE(r.best.contour_error_mm, r.klipper->contour_error_mm);
  expect_within_budget(r);
  EXPECT_EQ(r.evaluations, r.evaluated.size());
  EXPECT_EQ(r.evaluations, 5u * (12u + 2u + 12u));
}

TEST(Recommend, TightBudgetForcesHigherFrequency) {
  const machine::Machine m = machine::load_machine("default");
  RecommendOptions loose, tight;
  loose.shapers = tight.shapers = {"zv", "mzv"};
  tight.max_smoothing_mm = 0.05;
  const Recommendation a = recommend({40.0, 0.05}, m, loose);
  const Recommendation b = recommend({40.0, 0.05}, m, tight);
  expect_within_budget(a);
  expect_within_budget(b);
  for (const std::string name : {"zv", "mzv"}) {
    EXPECT_GT(of_type(b, name).freq_hz, of_type(a, name).freq_hz * 1.1) << name;
    // the budget is binding: the pick sits at the budget's limit
    EXPECT_NEAR(of_type(b, name).smoothing_mm, 0.05, 1e-3) << name;
  }
  EXPECT_GT(b.best.contour_error_mm, a.best.contour_error_mm);
}

TEST(Recommend, BudgetFarAboveTheModeSkipsTypes) {
  const machine::Machine m = machine::load_machine("default");
  RecommendOptions o;
  o.shapers = {"zv", "3hump_ei"};
  o.max_smoothing_mm = 0.005;
  const Recommendation r = recommend({40.0, 0.05}, m, o);
  ASSERT_EQ(r.per_type.size(), 1u);
  EXPECT_EQ(r.best.name, "zv");
  EXPECT_EQ(r.skipped, std::vector<std::string>{"3hump_ei"});
  EXPECT_GE(r.sample_rate_hz, 8.0 * r.best.freq_hz);
  expect_within_budget(r);
  o.max_smoothing_mm = 1e-4;
  try {
    (void)recommend({40.0, 0.05}, m, o);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--max-smoothing-mm"), std::string::npos) << e.what();
  }
}

TEST(Recommend, MinFrequencyForSmoothing) {
  const double f = min_frequency_for_smoothing("mzv", 0.1, 3000.0, 5.0, 0.12);
  EXPECT_NEAR(shaping::smoothing_mm(shaping::make_shaper("mzv", f, 0.1), 3000.0, 5.0), 0.12, 1e-5);
  EXPECT_LE(shaping::smoothing_mm(shaping::make_shaper("mzv", f, 0.1), 3000.0, 5.0), 0.12);
}

TEST(Recommend, Deterministic) {
  const machine::Machine m = machine::load_machine("ender3");
  RecommendOptions o;
  o.shapers = {"zv"};
  const Recommendation a = recommend({42.9, 0.24}, m, o);
  const Recommendation b = recommend({42.9, 0.24}, m, o);
  EXPECT_EQ(a.best.freq_hz, b.best.freq_hz);
  EXPECT_EQ(a.best.contour_error_mm, b.best.contour_error_mm);
  EXPECT_EQ(to_json(a)["model_recommendation"], to_json(b)["model_recommendation"]);
}

TEST(Recommend, RejectsBadInputNamingTheParameter) {
  const machine::Machine m = machine::load_machine("default");
  auto expect_error = [&](const ModalModel& model, double budget, const std::string& name) {
    RecommendOptions o;
    o.max_smoothing_mm = budget;
    try {
      (void)recommend(model, m, o);
      ADD_FAILURE() << "no error for " << name;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  expect_error({0.0, 0.1}, 0.12, "--natural-frequency-hz");
  expect_error({std::nan(""), 0.1}, 0.12, "--natural-frequency-hz");
  expect_error({40.0, 1.0}, 0.12, "--damping-ratio");
  expect_error({40.0, -0.1}, 0.12, "--damping-ratio");
  expect_error({40.0, 0.1}, 0.0, "--max-smoothing-mm");
  EXPECT_THROW((void)klipper_pick_for_model({40.0, 0.1}, -1.0), Error);
}

}  // namespace
}  // namespace amctl::tuning
