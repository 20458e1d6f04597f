#pragma once
// The limits a G-code file sets (M201, M203, M204, M205, M566, SET_VELOCITY_LIMIT): what the
// planner does with them (FileLimits) and what it saw (FileLimitsReport).
//
// Firmware obeys the file: Klipper's M204 S and SET_VELOCITY_LIMIT ACCEL replace max_accel
// until the next one, Marlin's M201/M203/M204/M205 replace its limits. So a what-if on the
// machine (`--set printer.max_accel=1000`) changes little on a file that sets its own
// accelerations. `keep` is the firmware's behaviour (the default); `ignore` plans the file
// on the machine's limits alone; `cap` applies the file's values but never above the
// machine's (a file may lower a limit, not raise it).
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace amctl::plan {

enum class FileLimits : std::uint8_t {
  keep,    ///< apply the file's limits as the firmware does
  ignore,  ///< the machine's limits throughout; the file's limits commands are read, not applied
  cap,     ///< apply them, each value at most the machine's (minimum_cruise_ratio at least)
};

[[nodiscard]] std::string_view to_string(FileLimits f);
/// "keep", "ignore" or "cap"; nullopt otherwise.
[[nodiscard]] std::optional<FileLimits> parse_file_limits(std::string_view text);

/// The values one parameter of one limits command took in the file.
struct FileLimitValues {
  std::string command;     ///< "M204", "SET_VELOCITY_LIMIT", ...
  std::string parameter;   ///< "S", "P", "ACCEL", "VELOCITY", ...
  std::string unit;        ///< "mm/s^2", "mm/s", "mm", "mm/min", "us", "" (a ratio)
  std::uint64_t count = 0;       ///< lines giving this parameter
  std::uint64_t first_line = 0;
  double min = 0.0, max = 0.0;   ///< as written in the file
  /// The distinct values, ascending: the first kMaxDistinct seen (more_values when there
  /// were more).
  std::vector<double> values;
  bool more_values = false;
  static constexpr std::size_t kMaxDistinct = 8;
};

/// One limits command of the file: how many lines gave it.
struct FileLimitCommand {
  std::string command;           ///< "M204", "SET_VELOCITY_LIMIT", ...
  std::uint64_t lines = 0;
  std::uint64_t first_line = 0;
  bool firmware_acts = true;     ///< false: the modelled firmware ignores it (another firmware's)
};

/// What the file's limits commands were and what the planner did with them.
struct FileLimitsReport {
  FileLimits policy = FileLimits::keep;
  /// Limits commands the modelled firmware acts on (Klipper: M204, SET_VELOCITY_LIMIT;
  /// Marlin / RepRapFirmware: M201, M203, M204, M205, M566).
  std::uint64_t commands = 0;
  /// Limits commands of another firmware, which the modelled one ignores whatever the policy
  /// (M201/M203/M205 on Klipper, SET_VELOCITY_LIMIT on Marlin).
  std::uint64_t other_firmware_commands = 0;
  std::uint64_t capped = 0;   ///< cap: commands with a value lowered to the machine's
  std::uint64_t ignored = 0;  ///< ignore: commands not applied
  /// Per command, in order of first appearance (commands of both kinds).
  std::vector<FileLimitCommand> by_command;
  /// Per command and parameter, in order of first appearance (commands of both kinds).
  std::vector<FileLimitValues> values;
};

/// The report in words, one line per command ("852 M204 lines: S 2000-8000 mm/s^2 (2000, 3000,
/// 5000, 8000)") and one on the policy ("kept, as the firmware does; ..."); empty when the
/// file sets no limits.
[[nodiscard]] std::vector<std::string> describe_file_limits(const FileLimitsReport& r);

}  // namespace amctl::plan
