#include <gtest/gtest.h>

#include "amctl/sls3d/studies.hpp"

namespace amctl::sls3d {
namespace {

TEST(Sls3dPlant, SlabFluxMatchesTheSeries) {
  SlabFluxOptions o;
  o.thickness_m = 1e-3;
  o.flux_w_m2 = 1000;
  o.times_s = {0.5, 2.0, 10.0};
  const SlabFluxResult r = run_slab_flux(o);
  for (std::size_t i = 0; i < o.times_s.size(); ++i) {
    std::printf("t %g fe %.9g series %.9g rel %.3e\n", o.times_s[i], r.top_rise_k[i], r.series_top_rise_k[i],
                r.top_rise_k[i] / r.series_top_rise_k[i] - 1);
    EXPECT_NEAR(r.top_rise_k[i], r.series_top_rise_k[i], 1e-3 * r.series_top_rise_k[i]);
  }
  std::printf("steps %d wall %g energy %g\n", r.steps, r.wall_s, r.energy_balance_rel_error);
  EXPECT_LT(r.energy_balance_rel_error, 1e-6);
}

}  // namespace
}  // namespace amctl::sls3d
