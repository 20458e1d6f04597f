// amctl-sls3d: the process `amctl thermal sls3d` becomes (cmd_sls3d.cpp). Its own executable
// because the 3D engine (deal.II, Open MPI) must not share a process with the stub MPI
// functions of the sequential MUMPS that IPOPT brings into amctl (docs/sls3d.md, "Build and
// loading"). Same options, messages and exit codes as `amctl thermal sls3d`.
#include <exception>
#include <iostream>

#include <CLI/CLI.hpp>

#include "amctl/core/error.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"amctl thermal sls3d: the SLS powder bed in 3D", "amctl thermal sls3d"};
  amctl::cli::register_sls3d_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    std::cerr << "amctl: error: " << e.what() << "\n";
    return 2;
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
