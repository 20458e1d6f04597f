// amctl command-line entry point. Each subcommand lives in its own cmd_*.cpp and is
// registered here; errors in user input end with exit code 2 and one message on stderr.
#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>

#include "amctl/core/error.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"amctl: plan, simulate and control 3D printers"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "amctl 0.1.0");
  amctl::cli::register_all(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const amctl::Error& e) {
    std::cerr << "amctl: error: " << e.what() << "\n";
    return 2;
  } catch (const amctl::InternalError& e) {
    std::cerr << "amctl: " << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "amctl: error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
