// amctl command-line entry point. Each subcommand lives in its own cmd_*.cpp and is
// registered here; errors in user input end with exit code 2 and one message on stderr.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <regex>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "commands.hpp"

namespace {

// The option named `name` in the subcommand that was being parsed (or any parent).
const CLI::Option* find_option(const CLI::App& app, const std::string& name) {
  for (const CLI::App* sub : app.get_subcommands()) {
    if (const CLI::Option* o = find_option(*sub, name)) return o;
  }
  return app.get_option_no_throw(name);
}

std::string expected_value(const CLI::App& app, const std::string& name) {
  const CLI::Option* o = find_option(app, name);
  const std::string type = o ? o->get_type_name() : "";
  if (type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0) return "an integer";
  if (type.rfind("FLOAT", 0) == 0) return "a number";
  return "a value of type " + (type.empty() ? std::string("TEXT") : type);
}

// CLI11's messages in amctl's form for bad input: "WHERE: what was found, what was expected"
// with the flag as WHERE (a command line has no file and line).
std::string command_line_message(const CLI::App& app, const CLI::ParseError& e) {
  const std::string what = e.what();
  std::smatch m;
  if (std::regex_match(what, m, std::regex("Could not convert: (\\S+) = (.*)"))) {
    return m[1].str() + ": found '" + m[2].str() + "', expected " + expected_value(app, m[1]);
  }
  if (std::regex_match(what, m, std::regex("The following arguments? (?:was|were) not expected: (.*)"))) {
    return m[1].str() + ": unknown option or extra argument, expected the options and "
                        "arguments that --help lists";
  }
  if (std::regex_match(what, m, std::regex("(\\S+): (.*) not in (\\{.*\\})"))) {
    return m[1].str() + ": found '" + m[2].str() + "', expected one of " + m[3].str();
  }
  if (std::regex_match(what, m, std::regex("(\\S+) is required"))) {
    return m[1].str() + ": not given, expected this required " +
           (m[1].str().rfind("-", 0) == 0 ? "option" : "argument");
  }
  return what;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"amctl: plan, simulate and control 3D printers"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "amctl 0.1.0");
  amctl::cli::register_all(app);
  try {
    app.parse(argc, argv);
    // What went to standard output is checked too: a full disk or a closed pipe behind a
    // redirection is an error, not exit 0 with half a report.
    std::cout.flush();
    if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout)) {
      throw amctl::Error(fmt::format("standard output: writing failed: {}; expected room for the whole output",
                                     std::strerror(errno != 0 ? errno : EIO)));
    }
  } catch (const CLI::ParseError& e) {
    // --help and --version end here too, with exit code 0.
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    std::cerr << "amctl: error: " << command_line_message(app, e) << "\n"
              << "Run with --help for more information.\n";
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
