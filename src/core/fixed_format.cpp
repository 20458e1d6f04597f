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
  // Drop trailing zeros of the fraction.
  int d = decimals;
  while (d > 0 && n % 10 == 0) {
    n /= 10;
    --d;
  }
  // The digits of n, two at a time from a table (right-aligned in digits[]).
  static constexpr char kPairs[] =
      "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
      "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
      "8081828384858687888990919293949596979899";
  char digits[24];
  char* const dend = digits + sizeof digits;
  char* q = dend;
  while (n >= 100) {
    const std::size_t i = static_cast<std::size_t>(n % 100) * 2;
    n /= 100;
    *--q = kPairs[i + 1];
    *--q = kPairs[i];
  }
  if (n >= 10) {
    const std::size_t i = static_cast<std::size_t>(n) * 2;
    *--q = kPairs[i + 1];
    *--q = kPairs[i];
  } else {
    *--q = static_cast<char>('0' + n);
  }
  const int count = static_cast<int>(dend - q);
  if (v < 0) out.push_back('-');
  if (count > d) {  // integer part, then the fraction
    out.append(q, dend - d);
    if (d > 0) {
      out.push_back('.');
      out.append(dend - d, dend);
    }
  } else {  // 0.000ddd
    out.append("0.");
    out.append(static_cast<std::size_t>(d - count), '0');
    out.append(q, dend);
  }
}

}  // namespace amctl
