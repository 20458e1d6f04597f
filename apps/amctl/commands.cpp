#include "commands.hpp"

namespace amctl::cli {
void register_all(CLI::App& app) {
  register_estimate(app);
  register_plan(app);
  register_report(app);
  register_dynamics(app);
  register_compensate(app);
  register_compare(app);
  register_thermal(app);
  register_process(app);
  register_machine(app);
  register_shaper(app);
  register_resonance(app);
  register_steps(app);
  register_stepper(app);
}
}  // namespace amctl::cli
