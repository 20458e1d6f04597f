// Shaper type names and their parameters: "mzv(n=4, t=0.9)", "ei(v_tol=0.1)", ...
#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "amctl/core/error.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::shaping {
namespace {

constexpr std::array<std::string_view, 8> kNames = {"zv",       "mzv",      "zvd",  "ei",
                                                    "2hump_ei", "3hump_ei", "zvdd", "zvddd"};
constexpr std::array<ShaperType, 8> kTypes = {
    ShaperType::zv,          ShaperType::mzv,           ShaperType::zvd,  ShaperType::ei,
    ShaperType::two_hump_ei, ShaperType::three_hump_ei, ShaperType::zvdd, ShaperType::zvddd};

constexpr int kMaxMzvImpulses = 64;

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string valid_names() {
  std::string out;
  for (std::string_view n : kNames) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

struct Arg {
  std::string key;  ///< empty for a positional argument
  std::string_view value;
};

[[noreturn]] void bad_parameter(std::string_view text, std::string_view why) {
  throw Error(fmt::format("type '{}': {}", text, why));
}

double parse_number(std::string_view text, const Arg& a) {
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(a.value.data(), a.value.data() + a.value.size(), v);
  if (a.value.empty() || ec != std::errc() || ptr != a.value.data() + a.value.size() ||
      !std::isfinite(v) || v < 0.0) {
    bad_parameter(text, fmt::format("parameter {} = '{}' is not a finite number >= 0",
                                    a.key.empty() ? "(positional)" : a.key, a.value));
  }
  return v;
}

int parse_int(std::string_view text, const Arg& a) {
  int v = 0;
  const auto [ptr, ec] = std::from_chars(a.value.data(), a.value.data() + a.value.size(), v);
  if (a.value.empty() || ec != std::errc() || ptr != a.value.data() + a.value.size()) {
    bad_parameter(text, fmt::format("parameter n = '{}' is not an integer", a.value));
  }
  return v;
}

std::vector<Arg> split_args(std::string_view text, std::string_view inner) {
  std::vector<Arg> args;
  inner = trim(inner);
  if (inner.empty()) return args;
  std::size_t named = 0;
  while (true) {
    const std::size_t comma = inner.find(',');
    const std::string_view item = trim(inner.substr(0, comma));
    Arg a;
    if (const std::size_t eq = item.find('='); eq != std::string_view::npos) {
      a.key = lower(trim(item.substr(0, eq)));
      a.value = trim(item.substr(eq + 1));
      ++named;
    } else {
      a.value = item;
    }
    args.push_back(a);
    if (comma == std::string_view::npos) break;
    inner.remove_prefix(comma + 1);
  }
  if (named != 0 && named != args.size()) {
    bad_parameter(text, "mixing named and positional parameters is not supported");
  }
  return args;
}

}  // namespace

std::span<const std::string_view> shaper_type_names() { return kNames; }

Firmware parse_firmware(std::string_view text) {
  const std::string t = lower(trim(text));
  if (t == "klipper") return Firmware::klipper;
  if (t == "marlin") return Firmware::marlin;
  throw Error(fmt::format("found '{}', expected klipper or marlin (whose shaper definitions)", text));
}

std::string_view to_string(Firmware firmware) {
  return firmware == Firmware::marlin ? "marlin" : "klipper";
}

std::vector<std::string_view> shaper_type_names(Firmware firmware) {
  if (firmware == Firmware::marlin) {
    // ft_motion/shaping.h, in Marlin's M493 C order (C1 .. C8).
    return {"zv", "zvd", "zvdd", "zvddd", "ei", "2hump_ei", "3hump_ei", "mzv"};
  }
  return {"zv", "mzv", "zvd", "ei", "2hump_ei", "3hump_ei"};
}

Firmware default_firmware(ShaperType type) {
  return type == ShaperType::zvdd || type == ShaperType::zvddd ? Firmware::marlin : Firmware::klipper;
}

ShaperSpec parse_shaper_spec(std::string_view text, Firmware firmware, double sample_rate_hz) {
  ShaperSpec spec = parse_shaper_spec(text);
  const auto names = shaper_type_names(firmware);
  const std::string name = lower(trim(trim(text).substr(0, trim(text).find('('))));
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    const Firmware other = firmware == Firmware::marlin ? Firmware::klipper : Firmware::marlin;
    throw Error(fmt::format("type '{}' is not a {} shaper: found '{}', expected one of {} ({} offers {})",
                            text, to_string(firmware), name, fmt::join(names, ", "), to_string(other),
                            fmt::join(shaper_type_names(other), ", ")));
  }
  if (firmware == Firmware::marlin && spec.type == ShaperType::mzv &&
      (spec.mzv_n != 3 || spec.mzv_t != 0.75)) {
    bad_parameter(text, "found parameters, expected none: Marlin's mzv takes no parameters (mzv(n, t) is "
                        "Klipper's generalisation)");
  }
  if (firmware == Firmware::klipper &&
      (spec.type == ShaperType::two_hump_ei || spec.type == ShaperType::three_hump_ei) &&
      spec.ei_v_tol != 0.05) {
    bad_parameter(text, "Klipper's multi-hump EI shapers are fitted for v_tol = 0.05 only "
                        "(Marlin's take v_tol)");
  }
  if (!(std::isfinite(sample_rate_hz) && sample_rate_hz >= 0.0)) {
    throw Error(fmt::format("sample_rate_hz must be a finite number >= 0 (0: exact times), got {}",
                            sample_rate_hz));
  }
  spec.firmware = firmware;
  spec.sample_rate_hz = firmware == Firmware::marlin ? sample_rate_hz : 0.0;
  return spec;
}

ShaperSpec parse_shaper_spec(std::string_view text) {
  const std::string_view t = trim(text);
  const std::size_t paren = t.find('(');
  const std::string name = lower(trim(t.substr(0, paren)));
  std::string_view inner;
  if (paren != std::string_view::npos) {
    if (t.back() != ')') bad_parameter(text, "expected ')' at the end");
    inner = t.substr(paren + 1, t.size() - paren - 2);
  }
  const auto it = std::find(kNames.begin(), kNames.end(), name);
  if (it == kNames.end()) {
    throw Error(fmt::format("type '{}' is not a known shaper; valid types: {} (mzv also as "
                            "mzv(n=N, t=T) or mzv(n=N, tau=TAU), ei as ei(v_tol=V))",
                            text, valid_names()));
  }
  ShaperSpec spec;
  spec.type = kTypes[static_cast<std::size_t>(it - kNames.begin())];
  spec.firmware = default_firmware(spec.type);
  const std::vector<Arg> args = split_args(text, inner);

  if (spec.type == ShaperType::mzv) {
    // Klipper's get_mzv_shaper(freq, damping, n=3, t=0.0, tau=0.0): positional in that order.
    static constexpr std::array<std::string_view, 3> kKeys = {"n", "t", "tau"};
    if (args.size() > kKeys.size()) bad_parameter(text, "mzv takes at most n, t and tau");
    int n = 3;
    double t_periods = 0.0;
    double tau = 0.0;
    for (std::size_t i = 0; i < args.size(); ++i) {
      const std::string key = args[i].key.empty() ? std::string(kKeys[i]) : args[i].key;
      if (key == "n") {
        n = parse_int(text, args[i]);
      } else if (key == "t") {
        t_periods = parse_number(text, args[i]);
      } else if (key == "tau") {
        tau = parse_number(text, args[i]);
      } else {
        bad_parameter(text, fmt::format("unknown mzv parameter '{}' (expected n, t or tau)", key));
      }
    }
    if (tau == 0.0 && t_periods == 0.0) {
      t_periods = 0.75;
    } else if (tau != 0.0) {
      // tau: the duration the impulse train tends to as n grows, in damped periods.
      t_periods = tau * (n - 1.0) / (n + 2.0 * tau - 2.0);
    }
    if (n < 3) bad_parameter(text, fmt::format("n = {} is too small, must be at least 3", n));
    // Klipper's motion code (kin_shaper.c) applies at most 10 impulses; its definitions have
    // no limit. amctl keeps a generous one so that a typo cannot ask for an n^2 system of 1e12.
    if (n > kMaxMzvImpulses) {
      bad_parameter(text, fmt::format("n = {} is too large, must be at most {}", n, kMaxMzvImpulses));
    }
    if (n <= 2.0 * t_periods + 1.0 + 1e-7) {
      bad_parameter(text, fmt::format("t = {:.6f} is too large for n = {}, must be less than {:.6f}",
                                      t_periods, n, 0.5 * (n - 1)));
    }
    spec.mzv_n = n;
    spec.mzv_t = t_periods;
    return spec;
  }
  if (spec.type == ShaperType::ei || spec.type == ShaperType::two_hump_ei ||
      spec.type == ShaperType::three_hump_ei) {
    // v_tol: Klipper's ei(v_tol=V); Marlin's M493 Q for its three EI types.
    if (args.size() > 1 || (args.size() == 1 && !args[0].key.empty() && args[0].key != "v_tol")) {
      bad_parameter(text, fmt::format("{} takes one parameter, v_tol", name));
    }
    if (!args.empty()) {
      spec.ei_v_tol = parse_number(text, args[0]);
      if (spec.ei_v_tol >= 1.0) bad_parameter(text, "v_tol must be below 1");
    }
    return spec;
  }
  if (!args.empty()) bad_parameter(text, fmt::format("{} takes no parameters", name));
  return spec;
}

std::string to_string(const ShaperSpec& spec) {
  const std::string_view name =
      kNames[static_cast<std::size_t>(std::find(kTypes.begin(), kTypes.end(), spec.type) -
                                      kTypes.begin())];
  if (spec.type == ShaperType::mzv && (spec.mzv_n != 3 || spec.mzv_t != 0.75)) {
    return fmt::format("mzv(n={}, t={})", spec.mzv_n, spec.mzv_t);
  }
  if ((spec.type == ShaperType::ei || spec.type == ShaperType::two_hump_ei ||
       spec.type == ShaperType::three_hump_ei) &&
      spec.ei_v_tol != 0.05) {
    return fmt::format("{}(v_tol={})", name, spec.ei_v_tol);
  }
  return std::string(name);
}

std::optional<double> klipper_max_damping_ratio(ShaperType type) {
  switch (type) {
    case ShaperType::zv:
    case ShaperType::mzv:
    case ShaperType::zvd: return 0.99;
    case ShaperType::ei: return 0.4;
    case ShaperType::two_hump_ei: return 0.3;
    case ShaperType::three_hump_ei: return 0.2;
    case ShaperType::zvdd:
    case ShaperType::zvddd: return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace amctl::shaping
