#!/usr/bin/env bash
# The module graph as CMake sees it: every amctl_<module> library and the amctl_<module>
# libraries it links directly, one line per module, from `cmake --graphviz`. Used for
# docs/architecture.md; also checks that every edge points down the layer order below and
# exits 1 naming the edge if one does not.
#
#   scripts/module_graph.sh [BUILD_DIR]   an existing build tree (re-runs its configure step)
#   scripts/module_graph.sh --fresh       configures a scratch tree (CTest uses this)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build/release}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ "$build" = "--fresh" ]; then
  cmake -S "$root" -B "$work/build" -G Ninja -DAMCTL_BUILD_TESTS=OFF -DAMCTL_BUILD_BENCH=OFF \
        --graphviz="$work/g.dot" >/dev/null
else
  (cd "$work" && cmake --graphviz="$work/g.dot" "$build" >/dev/null)
fi
# Layers, lowest first: a module may link only modules in lower layers.
layers="core:0 numerics:1 control:1 gcode:1 kinematics:1 bedmesh:2 formats:2 machine:2 macro:2 plan:3 trajectory:4 dynamics:5 shaping:5
thermal:2 process:4 resonance:6 simulation:6 compensation:6 steppers:6
tuning:8 report:8 comparison:8 closedloop:7 sls3d:2"
/usr/bin/python3 - "$work/g.dot" "$layers" <<'PY'
import re, sys
dot, layers = open(sys.argv[1]).read(), dict(l.split(":") for l in sys.argv[2].split())
names = {}
for node, label in re.findall(r'"(node\d+)" \[ label = "amctl_(\w+)\\n', dot):
    names[node] = label
edges = {}
for a, b in re.findall(r'"(node\d+)" -> "(node\d+)"', dot):
    if a in names and b in names and names[a] != "amctl" and names[b] != "amctl":
        edges.setdefault(names[a], set()).add(names[b])
bad = []
order = sorted(names.values(), key=lambda m: (int(layers.get(m, 99)), m))
for m in order:
    if m == "amctl":
        continue
    deps = sorted(edges.get(m, ()), key=lambda d: (int(layers.get(d, 99)), d))
    print(f"{m:<14} -> {', '.join(deps) if deps else '(nothing)'}")
    for d in deps:
        if int(layers.get(d, 99)) >= int(layers.get(m, 99)):
            bad.append(f"{m} -> {d}")
if bad:
    print("edges that do not point down:", ", ".join(bad))
    sys.exit(1)
PY
