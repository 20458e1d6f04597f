#pragma once
// A JSON document read from a file that remembers where each value starts, so that checks
// made after parsing (a missing key, a factor that is not a number) name file:line like the
// CSV and G-code readers do. nlohmann::json itself keeps no positions.
#include <cstdint>
#include <map>
#include <string>
#include <string_view>

#include "amctl/core/error.hpp"
#include "amctl/core/json.hpp"

namespace amctl::process {

class JsonFile {
 public:
  /// Reads and parses a file; amctl::Error "file:line:col: not valid JSON: ..." otherwise.
  static JsonFile read(const std::string& path);
  /// Parses `text`; `name` is used in messages.
  static JsonFile parse(std::string_view text, std::string name);

  [[nodiscard]] const Json& root() const { return root_; }
  [[nodiscard]] const std::string& name() const { return name_; }
  /// Where the value at `pointer` (a JSON pointer such as "/axes/1/factor") is: the line of
  /// its key, or of its first token inside an array; the file alone if unknown.
  [[nodiscard]] SourceLocation where(const std::string& pointer) const;
  /// Throws amctl::Error at where(pointer).
  [[noreturn]] void fail(const std::string& pointer, const std::string& message) const;
  /// The value at `pointer` as a finite number; fails naming the key otherwise.
  [[nodiscard]] double number(const std::string& pointer) const;

 private:
  std::string name_;
  Json root_;
  std::map<std::string, std::uint64_t> line_of_;  // JSON pointer -> 1-based line
};

}  // namespace amctl::process
