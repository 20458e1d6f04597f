// Typed access to a printer.cfg's options with Klipper's checks (configfile.py ConfigWrapper).
#include "amctl/kinematics/klipper_config.hpp"

#include <cctype>
#include <charconv>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace amctl::kinematics {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

}  // namespace

bool KlipperSection::has(std::string_view key) const {
  return s_ != nullptr && s_->options.count(std::string(key)) != 0;
}

const ConfigValue* KlipperSection::raw(std::string_view key) const {
  if (s_ == nullptr) return nullptr;
  auto it = s_->options.find(std::string(key));
  return it == s_->options.end() ? nullptr : &it->second;
}

std::optional<double> KlipperSection::get_float(std::string_view key, const Limits& lim) const {
  const ConfigValue* v = raw(key);
  if (v == nullptr) return std::nullopt;
  const std::string_view text = trim(v->text);
  double x = 0.0;
  const char* first = text.data();
  if (!text.empty() && text.front() == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, text.data() + text.size(), x);
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size()) {
    throw Error(v->where, fmt::format("[{}] {}: expected a number, got '{}'", name_, key, text));
  }
  if (!std::isfinite(x)) {
    throw Error(v->where, fmt::format("[{}] {}: must be a finite number, got '{}'", name_, key, text));
  }
  check(v->where, key, x, lim);
  return x;
}

double KlipperSection::get_float(std::string_view key, double def, const Limits& lim) const {
  if (auto x = get_float(key, lim)) return *x;
  if (s_ != nullptr) {
    // Klipper's configfile.settings holds the defaults its modules read: the value as Python
    // prints a float (repr), for the macros that read it.
    std::string text = fmt::format("{}", def);
    if (text.find_first_of(".en") == std::string::npos) text += ".0";
    s_->defaults.emplace(std::string(key), std::move(text));
  }
  return def;
}

double KlipperSection::require_float(std::string_view key, const Limits& lim) const {
  if (auto x = get_float(key, lim)) return *x;
  throw missing(key);
}

std::optional<int> KlipperSection::get_int(std::string_view key, const Limits& lim) const {
  const ConfigValue* v = raw(key);
  if (v == nullptr) return std::nullopt;
  const std::string_view text = trim(v->text);
  long long x = 0;
  const char* first = text.data();
  if (!text.empty() && text.front() == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, text.data() + text.size(), x);
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size() || x > 1000000000 ||
      x < -1000000000) {
    throw Error(v->where, fmt::format("[{}] {}: expected an integer, got '{}'", name_, key, text));
  }
  check(v->where, key, static_cast<double>(x), lim);
  return static_cast<int>(x);
}

int KlipperSection::require_int(std::string_view key, const Limits& lim) const {
  if (auto x = get_int(key, lim)) return *x;
  throw missing(key);
}

std::string KlipperSection::get_choice(std::string_view key, std::string_view def,
                                       std::initializer_list<std::string_view> choices) const {
  const ConfigValue* v = raw(key);
  if (v == nullptr) return std::string(def);
  std::string t(trim(v->text));
  for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (std::string_view c : choices) {
    if (c == t) return t;
  }
  throw Error(v->where, fmt::format("[{}] {}: found '{}', expected one of {}", name_, key,
                                    trim(v->text), fmt::join(choices, ", ")));
}

std::string KlipperSection::require_text(std::string_view key) const {
  if (const ConfigValue* v = raw(key)) return std::string(trim(v->text));
  throw missing(key);
}

Error KlipperSection::missing(std::string_view key) const {
  return Error(s_ ? s_->where : fallback_,
               fmt::format("option '{}' in section [{}] must be specified", key, name_));
}

void KlipperSection::check(const SourceLocation& where, std::string_view key, double x,
                           const Limits& lim) const {
  auto fail = [&](std::string_view rule, double bound) {
    return Error(where, fmt::format("[{}] {}: must be {} {}, got {}", name_, key, rule, bound, x));
  };
  if (lim.minval && x < *lim.minval) throw fail("at least", *lim.minval);
  if (lim.maxval && x > *lim.maxval) throw fail("at most", *lim.maxval);
  if (lim.above && x <= *lim.above) throw fail("above", *lim.above);
  if (lim.below && x >= *lim.below) throw fail("below", *lim.below);
  if (lim.physical && x != 0.0 && !in_range(*lim.physical, x)) {
    throw Error(where, fmt::format("[{}] {}: must be {}, got {}", name_, key, describe(*lim.physical), x));
  }
}

KlipperSection KlipperConfig::section(std::string_view name) const {
  for (ConfigSection& s : sections_) {
    if (s.name == name) return KlipperSection(&s, std::string(name), file_);
  }
  return KlipperSection(nullptr, std::string(name), file_);
}

bool KlipperConfig::has(std::string_view name) const { return section(name).present(); }

SourceLocation KlipperConfig::printer_where() const { return section("printer").where(); }

}  // namespace amctl::kinematics
