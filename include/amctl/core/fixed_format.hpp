#pragma once
// Fast decimal output of doubles for large CSV files (the compensation command, one row per
// sample): fixed point, rounded half away from zero at `decimals` places, trailing zeros and
// a trailing point dropped, never an exponent. About 10x faster than a "{:.12g}" format.
#include <string>

namespace amctl {

/// Appends `v` to `out` with at most `decimals` (0..9) decimals: 0.25 -> "0.25", 10.0 ->
/// "10", -1e-12 -> "0" (no negative zero). Values beyond 9e9 in magnitude, NaN and
/// infinities are written by std::to_chars (shortest fixed form; "nan", "inf", "-inf").
void append_fixed(std::string& out, double v, int decimals);

}  // namespace amctl
