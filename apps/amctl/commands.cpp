#include "commands.hpp"

namespace amctl::cli {
void register_all(CLI::App& app) { register_thermal(app); }
}  // namespace amctl::cli
