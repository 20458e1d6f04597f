// Filtered basis functions (docs/compensation.md, section 2).
#include "amctl/core/error.hpp"
#include "detail.hpp"

namespace amctl::compensation::detail {

void run_fbf(std::span<const plan::PlannedMove>, const CompensationOptions&, double, Grid&,
             CompensationResult&) {
  throw Error("--method fbf: not implemented yet");
}

}  // namespace amctl::compensation::detail
