#pragma once
#include <CLI/CLI.hpp>

namespace amctl::cli {
// One register function per subcommand family, defined in cmd_<family>.cpp. Each adds its
// subcommand(s) to `app` with a callback that does the work (callbacks run inside app.parse,
// so amctl::Error thrown there reaches main's handler).
void register_all(CLI::App& app);
void register_thermal(CLI::App& app);
}  // namespace amctl::cli
