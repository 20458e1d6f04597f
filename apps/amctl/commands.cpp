#include "commands.hpp"

namespace amctl::cli {
void register_all(CLI::App& app) {
  register_machine(app);
  register_dynamics(app);
}
}  // namespace amctl::cli
