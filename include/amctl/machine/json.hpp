#pragma once
// The machine description as JSON: the same section/key names as the TOML file, plus an
// "effective" object with the limits Klipper derives, and the key table. Used by
// `amctl machine show --json` / `keys --json` and by the bindings.
#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"

namespace amctl::machine {

/// Every field of `m`, plus "effective" (the limits Klipper derives from them).
[[nodiscard]] Json to_json(const Machine& m);

/// The key table of schema(): {"keys": [{section, key, type, unit, description}, ...]}.
[[nodiscard]] Json schema_json();

}  // namespace amctl::machine
