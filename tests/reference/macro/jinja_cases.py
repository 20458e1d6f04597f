#!/usr/bin/python3
"""Renders each template of jinja_cases.json with the real Jinja2 in Klipper's environment
(klippy/extras/gcode_macro.py: jinja2.Environment('{%', '%}', '{', '}')) and writes the
expected outputs to jinja_expected.json, which tests/macro/template_test.cpp compares with
amctl's evaluator. Rerun after editing the cases:

    /usr/bin/python3 tests/reference/macro/jinja_cases.py

Needs python3-jinja2 (Debian 12: 3.1.2). A case whose render raises is expected to fail in
amctl too ("error": true)."""
import json
import os

import jinja2

HERE = os.path.dirname(os.path.abspath(__file__))


class Coord(tuple):
    """Klipper's gcode.Coord: a tuple with .x .y .z .e."""
    x = property(lambda s: s[0])
    y = property(lambda s: s[1])
    z = property(lambda s: s[2])
    e = property(lambda s: s[3])


def context(case):
    ctx = dict(case.get("variables", {}))
    printer = case.get("printer", {})
    for obj in printer.values():
        for k, v in list(obj.items()):
            if k in ("position", "gcode_position", "axis_minimum", "axis_maximum"):
                obj[k] = Coord(v)
    ctx["printer"] = printer
    ctx["params"] = case.get("params", {})
    ctx["rawparams"] = case.get("rawparams", "")
    ctx["action_respond_info"] = lambda msg: ""

    def raise_error(msg):
        raise RuntimeError(msg)
    ctx["action_raise_error"] = raise_error
    return ctx


def main():
    env = jinja2.Environment('{%', '%}', '{', '}')
    with open(os.path.join(HERE, "jinja_cases.json")) as f:
        cases = json.load(f)
    out = []
    for case in cases:
        try:
            text = str(env.from_string(case["template"]).render(context(case)))
            out.append({"name": case["name"], "output": text, "error": False})
        except Exception as e:  # noqa: BLE001 - any Jinja error is an expected failure
            out.append({"name": case["name"], "output": type(e).__name__ + ": " + str(e),
                        "error": True})
    with open(os.path.join(HERE, "jinja_expected.json"), "w") as f:
        json.dump(out, f, indent=1, sort_keys=True)
        f.write("\n")


if __name__ == "__main__":
    main()
