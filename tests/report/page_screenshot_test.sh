#!/usr/bin/env bash
# The report as a person sees it: headless Chromium opens the page of a real print, takes a
# screenshot, and check_page_screenshot.py looks for drawn plots, a script that ran to its
# end and a console without blocked requests or errors. The page's Content-Security-Policy
# (default-src 'none') would block any request, and its tag is asserted here.
# Exit 77 (CTest: skipped) when Chromium is not installed. Three browser runs of at most 18 s
# each stay inside CTest's 60 s.
#   page_screenshot_test.sh AMCTL SOURCE_DIR
set -euo pipefail
amctl=$1
src=$2
# AMCTL_CHROMIUM picks another browser binary (set it empty to see the skip).
chromium=${AMCTL_CHROMIUM-$(command -v chromium || true)}
if [[ -z "$chromium" ]]; then
  echo "chromium not installed (Debian: apt-get install chromium): skipped"
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$amctl" report "$src/examples/gcode/boxboss_prusaslicer-2.5_klipper.gcode" \
  --machine "$src/configs/klipper-voron-v0.cfg" -o "$work/report.html"
grep -q "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data:\">" "$work/report.html" \
  || { echo "FAIL: no Content-Security-Policy tag"; exit 1; }
flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run
       --disable-background-networking --disable-component-update --disable-sync
       --enable-logging=stderr --v=0 --window-size=1280,2000)
timeout 18 "$chromium" "${flags[@]}" --user-data-dir="$(mktemp -d -p "$work")" \
  --screenshot="$work/out.png" "file://$work/report.html" 2>"$work/log.txt" >/dev/null
timeout 18 "$chromium" "${flags[@]}" --user-data-dir="$(mktemp -d -p "$work")" \
  --dump-dom "file://$work/report.html" 2>>"$work/log.txt" >"$work/dom.html"
# Zoomed in on 30 s of the 13 min print: the band is drawn again from the buckets under it.
timeout 18 "$chromium" "${flags[@]}" --user-data-dir="$(mktemp -d -p "$work")" \
  --screenshot="$work/zoomed.png" "file://$work/report.html#t=300-330" 2>>"$work/log.txt" >/dev/null
[[ -s "$work/out.png" ]] || { echo "FAIL: no screenshot"; cat "$work/log.txt"; exit 1; }
if [[ -n "${AMCTL_KEEP_SCREENSHOT:-}" ]]; then
  cp "$work/out.png" "$AMCTL_KEEP_SCREENSHOT"
  cp "$work/zoomed.png" "${AMCTL_KEEP_SCREENSHOT%.png}_zoomed.png"
fi
/usr/bin/python3 "$src/tests/report/check_page_screenshot.py" "$work/out.png" "$work/log.txt" "$work/dom.html" \
  "$work/zoomed.png"
