#!/usr/bin/env python3
"""Runs `amctl estimate` on every case of Klipper's own regression suite (test/klippy/*.test).

    /usr/bin/python3 scripts/klipper_test_suite.py KLIPPER_DIR [AMCTL] [--markdown OUT.md] [--json]

A .test file names a printer config (CONFIG, several for several cases), G-code lines or a
GCODE file, and SHOULD_FAIL when Klipper must refuse it (Klipper's scripts/test_klippy.py
reads the same format; this script only reads it). Each case's G-code goes through
`amctl estimate GCODE --machine CFG --json` and is classed as:

  ok          exit 0, a print time;
  stops       exit 0 with a range_error: amctl says Klipper stops at "Move out of range";
  refused     exit 2, the first line of stderr is the reason (unsupported kinematics, ...);
  crash       any other exit status, a signal, or no answer within the time limit.

A SHOULD_FAIL case passes when amctl refuses it for Klipper's reason (the suite's only one,
out_of_bounds.test, is a move out of range). Exit status: 1 if any case crashed or a
SHOULD_FAIL case was accepted, else 0. Nothing of Klipper is copied; its files are read in place.
"""
import collections
import json
import os
import re
import subprocess
import sys
import tempfile

TIMEOUT_S = 120


def parse_test(path):
    """The cases of one .test file: (config, gcode text, should_fail), in Klipper's order."""
    base = os.path.dirname(path)
    config = gcode_file = None
    should_fail = multi = False
    gcode = []
    cases = []

    def add(cfg):
        if gcode_file is not None:
            with open(gcode_file, errors="replace") as f:
                text = f.read()
        else:
            text = "\n".join(gcode + [""])
        cases.append((cfg, text, should_fail))

    with open(path, errors="replace") as f:
        for line in f:
            line = line.split("#", 1)[0]
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "CONFIG":
                # Several CONFIG lines: each config runs the G-code read so far (test_klippy.py).
                if config is not None and not multi:
                    multi = True
                    add(config)
                config = os.path.join(base, parts[1])
                if multi:
                    add(config)
            elif parts[0] == "DICTIONARY":
                pass
            elif parts[0] == "GCODE":
                gcode_file = os.path.join(base, parts[1])
            elif parts[0] == "SHOULD_FAIL":
                should_fail = True
            else:
                gcode.append(line.strip())
    if not multi and config is not None:
        add(config)
    return cases


def classify(amctl, cfg, text, tmp):
    gcode = os.path.join(tmp, "case.gcode")
    with open(gcode, "w") as f:
        f.write(text)
    try:
        p = subprocess.run([amctl, "estimate", gcode, "--machine", cfg, "--json"],
                           capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return "crash", f"no answer within {TIMEOUT_S} s"
    if p.returncode == 0:
        try:
            report = json.loads(p.stdout)
        except json.JSONDecodeError:
            return "crash", "exit 0 without a JSON report"
        if report.get("range_error"):
            e = report["range_error"]
            return "stops", f"move out of range (line {e['line']}, axis {e['axis']})"
        return "ok", f"{report['total_time_s']:.3f} s"
    if p.returncode == 2:
        first = (p.stderr.strip().splitlines() or ["(no message)"])[0]
        return "refused", first
    return "crash", f"exit status {p.returncode}: {p.stderr.strip()[:200]}"


def reason_class(message):
    """A refusal message without its file name and position, for counting."""
    m = re.sub(r"^amctl: error: ", "", message)
    m = re.sub(r"^\S+?(:\d+)+: ", "", m)  # FILE:LINE:COL
    m = re.sub(r"'[^']*\.cfg'", "'FILE'", m)
    return m


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    markdown = None
    if "--markdown" in sys.argv:
        markdown = sys.argv[sys.argv.index("--markdown") + 1]
        args.remove(markdown)
    if not args:
        sys.exit(__doc__)
    klipper = args[0]
    amctl = args[1] if len(args) > 1 else os.path.join(os.path.dirname(__file__), "..", "build",
                                                         "release", "apps", "amctl", "amctl")
    tests_dir = os.path.join(klipper, "test", "klippy")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in sorted(os.listdir(tests_dir)):
            if not name.endswith(".test"):
                continue
            for cfg, text, should_fail in parse_test(os.path.join(tests_dir, name)):
                outcome, detail = classify(amctl, cfg, text, tmp)
                ok = outcome != "crash"
                if should_fail:
                    ok = outcome == "stops" or (outcome == "refused" and "out of range" in detail)
                rows.append({"test": name, "config": os.path.relpath(cfg, klipper),
                             "should_fail": should_fail, "outcome": outcome, "detail": detail,
                             "pass": ok})
    counts = collections.Counter(r["outcome"] for r in rows)
    reasons = collections.Counter(reason_class(r["detail"]) for r in rows if r["outcome"] == "refused")
    bad = [r for r in rows if not r["pass"]]
    if "--json" in sys.argv:
        json.dump({"cases": rows, "counts": counts, "refusal_reasons": reasons}, sys.stdout, indent=1)
        print()
    else:
        for r in rows:
            flag = "" if r["pass"] else "  <-- FAIL"
            sf = " (SHOULD_FAIL)" if r["should_fail"] else ""
            print(f"{r['test']:32} {r['config']:58} {r['outcome']:8} {r['detail']}{sf}{flag}")
        print(f"\n{len(rows)} cases: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
        for reason, n in reasons.most_common():
            print(f"  {n:4}  {reason}")
        disagree = [r for r in rows if r["outcome"] == "stops" and not r["should_fail"]]
        if disagree:
            print(f"{len(disagree)} cases Klipper runs but amctl says would stop (commands amctl "
                  "does not model):")
            for r in disagree:
                print(f"  {r['test']} ({r['config']}): {r['detail']}")
    if markdown:
        with open(markdown, "w") as f:
            f.write("| test | config | outcome | detail |\n|---|---|---|---|\n")
            for r in rows:
                sf = " (SHOULD_FAIL)" if r["should_fail"] else ""
                f.write(f"| {r['test']} | {r['config']} | {r['outcome']} | {r['detail']}{sf} |\n")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
