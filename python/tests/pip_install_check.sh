#!/bin/sh
# `pip install --no-build-isolation .` into a fresh venv made from Debian's Python (with its
# system packages: numpy, setuptools, wheel), without a package index, reusing the CMake build
# directory; then the installed package, imported from elsewhere, estimates a bundled print
# exactly as the CLI of that build does. Leaves nothing in the source tree.
#   usage: pip_install_check.sh SOURCE_DIR BUILD_DIR
set -eu
src=$1
build=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
before=$(cd "$src" && git status --porcelain --ignored 2>/dev/null | grep -v '^!! build/' || true)
AMCTL_BUILD_DIR="$build" "$work/venv/bin/pip" install --quiet --no-build-isolation --no-index \
  --no-cache-dir "$src"
after=$(cd "$src" && git status --porcelain --ignored 2>/dev/null | grep -v '^!! build/' || true)
if [ "$before" != "$after" ]; then
  echo "pip install left files in the source tree:"; echo "$after"; exit 1
fi
cd "$work"
py_time=$("$work/venv/bin/python" -c "
import amctl, os
assert os.path.dirname(amctl.__file__).startswith('$work'), amctl.__file__
print(repr(amctl.estimate('$src/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode',
                          machine='$src/configs/klipper-voron-v0.cfg')['total_time_s']))")
cli_time=$("$build/apps/amctl/amctl" estimate "$src/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode" \
  --machine "$src/configs/klipper-voron-v0.cfg" --json |
  /usr/bin/python3 -c "import json, sys; print(repr(json.load(sys.stdin)['total_time_s']))")
echo "installed package: $py_time s, CLI: $cli_time s"
[ "$py_time" = "$cli_time" ]
