#!/usr/bin/env bash
# Installs the Debian 12 packages amctl needs, only those that are missing.
# Usage: scripts/install-deps.sh [--with-slicer] [--with-klipper]
set -euo pipefail

pkgs=(
  build-essential cmake ninja-build ccache pkg-config
  libeigen3-dev coinor-libipopt-dev libfftw3-dev
  libcli11-dev libfmt-dev libtomlplusplus-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  zlib1g-dev libzip-dev  # binary G-code (DEFLATE), sliced 3MF archives (src/formats)
  pybind11-dev python3-dev python3-numpy python3-scipy python3-distributed python3-pandas python3-pytest
  chromium  # the report page's test: headless screenshot (tests/report/page_screenshot_test.sh)
  # The 3D powder bed (src/sls3d, `amctl thermal sls3d`): deal.II 9.4 (its dev package brings
  # p4est, Trilinos and the MPI headers) and Open MPI's launcher for mpirun runs.
  libdeal.ii-dev openmpi-bin
)
# The real-slicer tests slice a model with Debian's prusa-slicer.
for arg in "$@"; do
  case "$arg" in
    --with-slicer) pkgs+=(prusa-slicer) ;;
    # Running Klipper's batch mode for the reference times (tests/reference/klipper/README.md)
    # and its Linux-process MCU build: klippy's Python modules.
    --with-klipper) pkgs+=(python3-greenlet python3-cffi python3-serial python3-jinja2) ;;
  esac
done

missing=()
for p in "${pkgs[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#pkgs[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  if command -v sudo >/dev/null; then SUDO=sudo; else
    echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1
  fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
