#include "commands.hpp"

namespace amctl::cli {
void register_all(CLI::App& app) { (void)app; }
}  // namespace amctl::cli
