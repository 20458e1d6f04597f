// Seed 004, Table 2 (examples/04_shrink_geometry4.csv): the slicing model must reproduce the
// printed slicing errors to their 3 printed decimals, and the dimensional errors (printed to
// 2 decimals from unrounded measurements) to 0.01 mm.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/process/scale_map.hpp"
#include "amctl/process/slicing.hpp"

namespace pr = amctl::process;

namespace {
struct Table2 {
  std::vector<double> nominal, meas_r, meas_o, slice_r, slice_o, dim_r, dim_o, tot_r, tot_o;
};
Table2 table2() {
  const auto t = pr::CsvTable::read(std::string(AMCTL_SOURCE_DIR) +
                                    "/examples/04_shrink_geometry4.csv");
  Table2 d;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    d.nominal.push_back(t.number(r, t.require("nominal_mm")));
    d.meas_r.push_back(t.number(r, t.require("measured_remodelled_mm")));
    d.meas_o.push_back(t.number(r, t.require("measured_original_mm")));
    d.slice_r.push_back(t.number(r, t.require("slicing_error_remodelled_mm")));
    d.slice_o.push_back(t.number(r, t.require("slicing_error_original_mm")));
    d.dim_r.push_back(t.number(r, t.require("dimensional_error_remodelled_mm")));
    d.dim_o.push_back(t.number(r, t.require("dimensional_error_original_mm")));
    d.tot_r.push_back(t.number(r, t.require("total_error_remodelled_mm")));
    d.tot_o.push_back(t.number(r, t.require("total_error_original_mm")));
  }
  return d;
}
}  // namespace

TEST(Slicing, LayerCountsFollowThePlanePositionRule) {
  pr::SlicingModel m{0.2, 0.3, 0.5};
  EXPECT_EQ(m.layers_for(0.1), 0);   // below the first plane at 0.15
  EXPECT_EQ(m.layers_for(0.15), 1);
  EXPECT_EQ(m.layers_for(0.39), 1);  // second plane at 0.3 + 0.1 = 0.4
  EXPECT_EQ(m.layers_for(0.4), 2);
  // Planes of layers 2..5 at 0.4, 0.6, 0.8, 1.0: a 0.95 mm feature keeps 4 layers.
  EXPECT_NEAR(m.sliced_height(0.95), 0.3 + 3 * 0.2, 1e-12);
}

TEST(Slicing, WholeLayerRuleKeepsExactMultiples) {
  pr::SlicingModel m{0.254, 0.254, 1.0};
  EXPECT_EQ(m.layers_for(394 * 0.254), 394);
  EXPECT_EQ(m.layers_for(394 * 0.254 - 1e-6), 393);
}

TEST(Slicing, Table2RemodelledColumnIsReproduced) {
  const auto d = table2();
  const auto z = pr::parse_factor_spec("z=0.9902:10:1.0032")[2];
  const pr::SlicingModel m{0.254, 0.254, 1.0};
  const auto rows = pr::slicing_error_table(d.nominal, d.meas_r, z, pr::HeightScaling::dimension, m);
  // The loop below checks nothing if the table is empty: the seed's Table 2 has 22 heights.
  ASSERT_EQ(d.nominal.size(), 22u);
  ASSERT_EQ(rows.size(), d.nominal.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ASSERT_TRUE(rows[i].total_error_mm && rows[i].dimensional_error_mm) << "row " << i;
    EXPECT_NEAR(rows[i].slicing_error_mm, d.slice_r[i], 0.0005) << "row " << i;
    EXPECT_NEAR(*rows[i].total_error_mm, d.tot_r[i], 1e-9) << "row " << i;
    EXPECT_NEAR(*rows[i].dimensional_error_mm, d.dim_r[i], 0.0101) << "row " << i;
  }
}

TEST(Slicing, Table2OriginalColumnNeedsASlicePlaneNear57Percent) {
  const auto d = table2();
  pr::SlicingModel m{0.254, 0.254, 1.0};
  std::vector<long> layers;
  for (std::size_t i = 0; i < d.nominal.size(); ++i) {
    layers.push_back(std::lround((d.nominal[i] + d.slice_o[i]) / 0.254));
  }
  const auto iv = pr::fit_plane_fraction(m, d.nominal, layers);
  // Hand calculation: 7 mm kept 27 layers (27.559 layers tall): p > 0.559055;
  // 70 mm kept 276 layers (275.591 tall): p <= 0.590551.
  EXPECT_NEAR(iv.lo, 7.0 / 0.254 - 27, 1e-9);
  EXPECT_NEAR(iv.hi, 70.0 / 0.254 - 275, 1e-9);
  m.plane_fraction = 0.5 * (iv.lo + iv.hi);
  const auto rows = pr::slicing_error_table(d.nominal, d.meas_o, pr::AxisMap{},
                                            pr::HeightScaling::none, m);
  ASSERT_EQ(rows.size(), 22u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ASSERT_TRUE(rows[i].dimensional_error_mm) << "row " << i;
    EXPECT_NEAR(rows[i].slicing_error_mm, d.slice_o[i], 0.0005) << "row " << i;
    EXPECT_NEAR(*rows[i].dimensional_error_mm, d.dim_o[i], 0.0101) << "row " << i;
  }
  // Mid-layer sampling (p = 0.5) would have rounded 7 mm up to 28 layers.
  EXPECT_EQ((pr::SlicingModel{0.254, 0.254, 0.5}.layers_for(7.0)), 28);
}

TEST(Slicing, InconsistentLayerCountsAreRejected) {
  const pr::SlicingModel m{0.2, 0.2, 1.0};
  EXPECT_THROW((void)pr::fit_plane_fraction(m, {1.0, 1.0}, {5, 4}), amctl::Error);
  EXPECT_THROW((void)(pr::SlicingModel{0.2, 0.2, 0.0}.layers_for(1.0)), amctl::Error);
}

TEST(ScaleMap, PiecewiseMapIsContinuousMonotoneAndInvertible) {
  const auto z = pr::parse_factor_spec("z=0.9902:10:1.0032")[2];
  EXPECT_NEAR(z.map(10.0), 9.902, 1e-12);
  EXPECT_NEAR(z.map(15.0), 9.902 + 5 * 1.0032, 1e-12);
  EXPECT_NEAR(z.inverse(z.map(37.3)), 37.3, 1e-12);
  EXPECT_NEAR(z.inverse(z.map(3.1)), 3.1, 1e-12);
  EXPECT_NEAR(z.factor_for_size(10.0), 0.9902, 0);
  EXPECT_NEAR(z.factor_for_size(10.01), 1.0032, 0);
  EXPECT_THROW((void)pr::parse_factor_spec("z=1:10:1:5:1"), amctl::Error);
  EXPECT_THROW((void)pr::parse_factor_spec("z=-1"), amctl::Error);
  EXPECT_THROW((void)pr::parse_factor_spec("q=1"), amctl::Error);
  EXPECT_THROW((void)pr::parse_factor_spec("z=1:10"), amctl::Error);
}
