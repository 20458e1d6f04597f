// amctl command-line entry point. Each subcommand lives in its own cmd_*.cpp and is
// registered here; errors in user input end with exit code 2 and one message on stderr.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <exception>
#include <iostream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/run_inputs.hpp"
#include "commands.hpp"

namespace {

// Levenshtein distance (insertions, deletions, substitutions), for did-you-mean.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// The closest of `names` to `word` when it is close enough to be a typo (a third of the word,
// at least 2 edits, or a prefix of a name), "" otherwise.
std::string closest(const std::string& word, const std::vector<std::string>& names) {
  std::string best;
  std::size_t best_d = std::string::npos;
  for (const std::string& n : names) {
    const std::size_t d = n.rfind(word, 0) == 0 && word.size() >= 3 ? 1 : edit_distance(word, n);
    if (d < best_d) {
      best_d = d;
      best = n;
    }
  }
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
  return best_d <= limit ? best : std::string();
}

std::vector<const CLI::App*> subcommands_of(const CLI::App& app) {
  return app.get_subcommands([](const CLI::App*) { return true; });
}

std::string command_path(const CLI::App& app) {
  std::string path = app.get_name();
  for (const CLI::App* p = app.get_parent(); p; p = p->get_parent()) path = p->get_name() + " " + path;
  return path;
}

// A misspelt subcommand ("amctl estimat ...", "amctl resonance calibrat ..."): the word where a
// subcommand was expected, with the closest one. Empty when the command line names its
// subcommands correctly (or stops before them: --help, --version, nothing).
std::string unknown_subcommand(const CLI::App& app, int argc, char** argv) {
  const CLI::App* current = &app;
  for (int i = 1; i < argc; ++i) {
    const std::string token = argv[i];
    const auto subs = subcommands_of(*current);
    if (subs.empty()) return "";
    if (token.empty() || token[0] == '-') return "";  // an option of this level (--help, --version)
    const CLI::App* next = nullptr;
    std::vector<std::string> names;
    for (const CLI::App* s : subs) {
      names.push_back(s->get_name());
      if (s->check_name(token)) next = s;
    }
    if (!next) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      const std::string guess = closest(token, names);
      return token + ": found an unknown command, expected a command of " + command_path(*current) +
             " (" + list + ")" + (guess.empty() ? std::string() : "; did you mean '" + guess + "'?");
    }
    current = next;
  }
  return "";
}

// The deepest subcommand the command line selected.
const CLI::App* active_subcommand(const CLI::App& app) {
  for (const CLI::App* sub : app.get_subcommands()) return active_subcommand(*sub);
  return &app;
}

// "--machin" -> "--machine": the long and short names of the options of `app` and its parents.
std::string option_suggestion(const CLI::App& app, const std::string& flag) {
  std::vector<std::string> names;
  for (const CLI::App* a = &app; a; a = a->get_parent()) {
    for (const CLI::Option* o : a->get_options()) {
      for (const std::string& l : o->get_lnames()) names.push_back("--" + l);
    }
  }
  return closest(flag, names);
}


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
    // Name the first option that looks misspelt, with the closest one the command has.
    const CLI::App* sub = active_subcommand(app);
    std::string word;
    std::istringstream in(m[1].str());
    for (std::string w; in >> w;) {
      if (w.rfind("--", 0) == 0) {
        const std::string flag = w.substr(0, w.find('='));
        const std::string guess = option_suggestion(*sub, flag);
        return flag + ": found an unknown option of '" + command_path(*sub) +
               "', expected one that --help lists" +
               (guess.empty() ? std::string() : "; did you mean '" + guess + "'?");
      }
    }
    return m[1].str() + ": unknown option or extra argument, expected the options and "
                        "arguments that --help lists";
  }
  if (std::regex_match(what, m, std::regex("(\\S+): (.*) not in (\\{.*\\})"))) {
    return m[1].str() + ": found '" + m[2].str() + "', expected one of " + m[3].str();
  }
  if (what == "A subcommand is required") {
    const CLI::App* sub = active_subcommand(app);
    std::string list;
    for (const CLI::App* c : subcommands_of(*sub)) list += (list.empty() ? "" : ", ") + c->get_name();
    return command_path(*sub) + ": found no command, expected one of " + list + " (--help describes them)";
  }
  if (std::regex_match(what, m, std::regex("(\\S+) is required"))) {
    return m[1].str() + ": not given, expected this required " +
           (m[1].str().rfind("-", 0) == 0 ? "option" : "argument");
  }
  return what;
}

}  // namespace

int main(int argc, char** argv) {
  // One run of one command: no file it reads (G-code, machine, includes, records) may be
  // replaced by one of its outputs.
  amctl::protect_inputs_of_this_run();
  CLI::App app{"amctl: plan, simulate and control 3D printers", "amctl"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "amctl 0.1.0");
  amctl::cli::register_all(app);
  if (const std::string bad = unknown_subcommand(app, argc, argv); !bad.empty()) {
    std::cerr << "amctl: error: " << bad << "\nRun with --help for more information.\n";
    return 2;
  }
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
