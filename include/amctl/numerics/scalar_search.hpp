#pragma once
// Golden-section search for the minimum of a unimodal function on an interval.
//
// Each step keeps the part of the bracket [a, b] that holds the lower of the two interior
// points c = b - g (b - a), d = a + g (b - a), g = (sqrt 5 - 1) / 2, and reuses the other one:
// one new evaluation per step, the bracket shrinking by g. docs/numerics.md.
#include <cmath>
#include <cstddef>
#include <limits>

namespace amctl::numerics {

/// (sqrt 5 - 1) / 2, the golden section's ratio.
inline constexpr double kGoldenRatioConjugate = 0.6180339887498949;

/// When the search stops: after max_steps steps, or once b - a <= width, whichever first.
struct GoldenSectionStop {
  std::size_t max_steps = std::numeric_limits<std::size_t>::max();
  double width = 0.0;
};

/// The final bracket; the minimum of a unimodal function lies in [a, b].
struct GoldenSectionBracket {
  double a = 0.0;
  double b = 0.0;
  std::size_t evaluations = 0;
  [[nodiscard]] double midpoint() const { return 0.5 * (a + b); }
};

/// Golden-section search of f (double -> double) on [a, b]. Of two equal interior values the
/// right part [c, b] is kept. Callers that want the best value seen record it in f.
template <class F>
GoldenSectionBracket golden_section_minimize(F&& f, double a, double b, const GoldenSectionStop& stop) {
  constexpr double g = kGoldenRatioConjugate;
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = f(c), fd = f(d);
  std::size_t evaluations = 2;
  for (std::size_t step = 0; step < stop.max_steps && b - a > stop.width; ++step) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = f(d);
    }
    ++evaluations;
  }
  return {a, b, evaluations};
}

}  // namespace amctl::numerics
