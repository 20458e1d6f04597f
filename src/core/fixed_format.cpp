#include "amctl/core/fixed_format.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>

namespace amctl {

void append_fixed(std::string& out, double v, int decimals) {
  static constexpr double kPow10[] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9};
  if (decimals < 0) decimals = 0;
  if (decimals > 9) decimals = 9;
  if (!std::isfinite(v) || std::abs(v) >= 9e9) {
    char buf[400];  // the shortest fixed form of any double fits (DBL_MAX has 309 digits)
    const auto res = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed);
    out.append(buf, res.ptr);
    return;
  }
  // |v| 10^d < 9e18: the scaled value fits an int64.
  const double scaled = std::round(std::abs(v) * kPow10[decimals]);
  std::uint64_t n = static_cast<std::uint64_t>(scaled);
  if (n == 0) {
    out.push_back('0');
    return;
  }
  char buf[32];
  char* end = buf + sizeof buf;
  char* p = end;
  int d = decimals;
  // Drop trailing zeros of the fraction.
  while (d > 0 && n % 10 == 0) {
    n /= 10;
    --d;
  }
  for (int i = 0; i < d; ++i) {
    *--p = static_cast<char>('0' + n % 10);
    n /= 10;
  }
  if (d > 0) *--p = '.';
  do {
    *--p = static_cast<char>('0' + n % 10);
    n /= 10;
  } while (n != 0);
  if (v < 0) *--p = '-';
  out.append(p, end);
}

}  // namespace amctl
