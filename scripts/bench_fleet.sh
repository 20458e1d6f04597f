#!/usr/bin/env bash
# Throughput of fleet runs (python3 -m amctl.fleet, docs/python.md "Fleet runs"): runs per
# second in this process (one core, no Dask), on a local Dask cluster of 1 and 2 workers, for
# big files (the shared corpus benchies) and for many small ones (the Klipper reference files),
# with batch 1 and a batch that amortises the per-task overhead.
#
#   scripts/bench_fleet.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build/release}
export PYTHONPATH=$build/python
cd "$root"
corpus=../shared/corpus/gcode
big=("$corpus"/*.gcode)
small=(tests/reference/klipper/*.gcode examples/*.gcode examples/gcode/*.gcode)
py=$(mktemp --suffix=.py)
trap 'rm -f "$py"' EXIT
cat >"$py" <<'PY'
import sys, time
from amctl import fleet
n_big = int(sys.argv[1]); big = sys.argv[2:2 + n_big]; small = sys.argv[2 + n_big:]
machines = ["voron24", "prusa-mk3s", "ender3", "default"]
def rate(files, label, **kw):
    t0 = time.perf_counter()
    rows = fleet.run(files, machines, **kw)
    dt = time.perf_counter() - t0
    assert all(r["error"] is None for r in rows), [r["error"] for r in rows if r["error"]]
    print(f"{label:<44} {len(rows):4d} runs in {dt:6.2f} s = {len(rows) / dt:7.1f} runs/s")
for files, name in ((big * 5, "benchies x5"), (small * 20, "small files x20")):
    if not files:
        continue
    rate(files, f"{name}: this process (workers=0)", workers=0)
    rate(files, f"{name}: local cluster, 1 worker", workers=1)
    rate(files, f"{name}: local cluster, 2 workers", workers=2)
    rate(files, f"{name}: local cluster, 2 workers, batch 8", workers=2, batch=8)
PY
/usr/bin/python3 "$py" "${#big[@]}" "${big[@]}" "${small[@]}"
