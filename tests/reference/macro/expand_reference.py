#!/usr/bin/python3
"""Writes print_expanded.gcode: print.gcode with every macro call replaced by the lines the
real Jinja2 renders for it (Klipper's environment, gcode_macro.py), recursively, renamed
built-ins written back under their own name (M99109 -> M109). amctl's estimate of print.gcode
with printer.cfg must equal its estimate of print_expanded.gcode with printer_base.cfg (no
macros): tests/plan/macro_estimate_test.cpp and python/tests/test_macros.py. Independent of
amctl's evaluator; the printer state each macro reads is written out below by hand (the file
is small enough to follow). Rerun after editing the macros or the print:

    /usr/bin/python3 tests/reference/macro/expand_reference.py
"""
import configparser
import os
import re
import shlex

import jinja2

HERE = os.path.dirname(os.path.abspath(__file__))


class Coord(tuple):
    x = property(lambda s: s[0])
    y = property(lambda s: s[1])
    z = property(lambda s: s[2])
    e = property(lambda s: s[3])


def read_macros():
    cp = configparser.RawConfigParser(strict=False, inline_comment_prefixes=(';', '#'))
    with open(os.path.join(HERE, "macros.cfg")) as f:
        cp.read_string(f.read())
    macros = {}
    for sec in cp.sections():
        if not sec.startswith("gcode_macro "):
            continue
        name = sec.split()[1]
        variables = {k[len("variable_"):]: eval(v, {})  # literal values only
                     for k, v in cp.items(sec) if k.startswith("variable_")}
        macros[name.upper()] = {"section": sec, "gcode": cp.get(sec, "gcode"),
                                "rename": cp.get(sec, "rename_existing", fallback=None),
                                "variables": variables}
    return macros


def main():
    macros = read_macros()
    renamed = {m["rename"]: n for n, m in macros.items() if m["rename"]}
    env = jinja2.Environment('{%', '%}', '{', '}')
    # The state each call sees, followed by hand through print.gcode: PRINT_START at the start
    # (nothing homed, at 0,0,0), PRINT_END after the last move (X30 Y30 Z0.6).
    state = {"PRINT_START": Coord((0.0, 0.0, 0.0, 0.0)), "PRINT_END": Coord((30.0, 30.0, 0.6, 0.0))}

    def printer(position):
        p = {"toolhead": {"position": position, "homed_axes": "",
                          "axis_minimum": Coord((0.0, 0.0, -2.0, 0.0)),
                          "axis_maximum": Coord((120.0, 120.0, 120.0, 0.0)),
                          "max_velocity": 500.0, "max_accel": 10000.0}}
        for n, m in macros.items():
            p[m["section"]] = dict(m["variables"])
        return p

    def expand(line, position, out):
        word = line.split()[0].upper() if line.split() else ""
        if word in renamed:
            out.append(re.sub(r"^\s*\S+", renamed[word], line))
            return
        if word not in macros:
            out.append(line)
            return
        m = macros[word]
        raw = line.strip()[len(word):].strip()
        if re.match(r"^[A-Z]\d", word):  # a G/M name: letter words, upper-cased
            parts = re.split(r"([A-Z_]+|[A-Z*])", line.split(";")[0].strip().upper())
            params = {parts[i]: parts[i + 1].strip() for i in range(1, len(parts), 2)}
        else:
            params = {k.upper(): v for k, v in (w.split("=", 1) for w in shlex.split(raw))}
        ctx = dict(m["variables"])
        ctx.update(printer=printer(position), params=params, rawparams=raw)
        text = env.from_string(m["gcode"]).render(ctx)
        for sub in text.split("\n"):
            if sub.strip().upper().startswith("SET_GCODE_VARIABLE"):
                continue  # changes a variable no later call of this print reads
            expand(sub.strip(), position, out)

    out = []
    with open(os.path.join(HERE, "print.gcode")) as f:
        for line in f.read().splitlines():
            word = line.split()[0].upper() if line.split() else ""
            expand(line, state.get(word), out)
    with open(os.path.join(HERE, "print_expanded.gcode"), "w") as f:
        f.write("; print.gcode with its macros expanded by Jinja2 (expand_reference.py)\n")
        f.write("\n".join(l for l in out if l.strip()) + "\n")


if __name__ == "__main__":
    main()
