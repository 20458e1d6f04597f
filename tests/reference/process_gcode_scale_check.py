#!/usr/bin/env python3
"""Independent check of `amctl shrink apply --gcode` (issue 13): parses input and output G-code
and checks that every non-move line is byte-identical, every move keeps its non-numeric bytes,
every written X/Y/Z is the mapped input coordinate (within 5.1e-5 mm) and every E amount follows
the path-length and layer-height ratio (within 1.01e-5 mm). Shares no code with amctl.
Usage: process_gcode_scale_check.py IN OUT fx fy z1 zbreak z2   (factors x=fx,y=fy,z=z1:zbreak:z2,
default origin). Arcs are not handled (the unit tests check them by hand)."""
import math, re, sys

inp, outp = sys.argv[1], sys.argv[2]
fx, fy, z1, zb, z2 = map(float, sys.argv[3:8])

def gz(u):  # Z map about 0
    return z1 * u if u <= zb else z1 * zb + z2 * (u - zb)
def zslope(u):
    return z1 if u <= zb else z2

NUM = r'[-+]?(?:\d+\.?\d*|\.\d+)'
word_re = re.compile(r'([A-Za-z])\s*(' + NUM + r')?')

def split(line):
    code = line.split(';', 1)[0]
    code = re.sub(r'\([^)]*\)', '', code)
    toks = code.split()
    if not toks:
        return None, {}
    cmd = toks[0].upper()
    words = {}
    for m in word_re.finditer(code[code.upper().find(cmd) + len(cmd):]):
        if m.group(2) is not None:
            words[m.group(1).upper()] = float(m.group(2))
    return cmd, words

def skeleton(line):  # the line with the numbers of rewritten words blanked
    code, sep, comment = line.partition(';')
    return re.sub(r'([XYZEIJKRxyzeijkr])\s*' + NUM, r'\1#', code) + sep + comment

class State:
    def __init__(s):
        s.pos = [0.0] * 3; s.g = [0.0] * 4; s.absx = True; s.abse = True; s.unit = 1.0
    def feed(s, cmd, w):
        """Returns (start, end, de, present) for moves, else None."""
        if cmd in ('G90',): s.absx = True
        elif cmd == 'G91': s.absx = False
        elif cmd == 'M82': s.abse = True
        elif cmd == 'M83': s.abse = False
        elif cmd == 'G20': s.unit = 25.4
        elif cmd == 'G21': s.unit = 1.0
        elif cmd == 'G92':
            if not w: s.g = [0.0] * 4
            for i, l in enumerate('XYZE'):
                if l in w: s.g[i] = w[l] * s.unit
        elif cmd == 'G28':
            ax = [i for i, l in enumerate('XYZ') if l in line_letters] or [0, 1, 2]
            for i in ax: s.pos[i] = 0.0; s.g[i] = 0.0
        elif cmd in ('G0', 'G1', 'G00', 'G01'):
            start = list(s.pos); present = []
            for i, l in enumerate('XYZ'):
                if l in w:
                    v = w[l] * s.unit; present.append(i)
                    if s.absx: s.pos[i] += v - s.g[i]; s.g[i] = v
                    else: s.pos[i] += v; s.g[i] += v
            de = 0.0
            if 'E' in w:
                v = w['E'] * s.unit
                rel = (not s.absx) or (not s.abse)
                de = v if rel else v - s.g[3]
                s.g[3] = s.g[3] + v if rel else v
            return start, list(s.pos), de, present
        elif cmd == 'SET_KINEMATIC_POSITION':
            for i, l in enumerate('XYZ'):
                m = re.search(l + r'=(' + NUM + ')', skp_line.upper())
                if m: s.pos[i] = s.g[i] = float(m.group(1))
        elif cmd in ('G2', 'G3', 'G02', 'G03'):
            raise SystemExit('arcs not expected in these files')
        return None

with open(inp, 'rb') as f: A = f.read().split(b'\n')
with open(outp, 'rb') as f: B = f.read().split(b'\n')
assert len(A) == len(B), (len(A), len(B))

# Pass 1: the default origin, the XY centre of the extruding moves.
st = State(); lo = [math.inf] * 2; hi = [-math.inf] * 2
for raw in A:
    line = raw.decode('latin-1').rstrip('\r')
    cmd, w = split(line)
    line_letters = set(re.findall(r'[XYZ]', line.split(';')[0].upper()[3:])) if cmd == 'G28' else set()
    skp_line = line
    r = st.feed(cmd, w) if cmd else None
    if r and r[2] > 0 and (r[0][0] != r[1][0] or r[0][1] != r[1][1]):
        for i in range(2):
            lo[i] = min(lo[i], r[0][i], r[1][i]); hi[i] = max(hi[i], r[0][i], r[1][i])
ox, oy = 0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])
print(f'origin ({ox}, {oy}, 0)')
mp = [lambda x: ox + fx * (x - ox), lambda y: oy + fy * (y - oy), gz]

si, so = State(), State()
identical = changed = moves = extruding = 0
max_pos_err = max_e_err = 0.0
for n, (ra, rb) in enumerate(zip(A, B), 1):
    la, lb = ra.decode('latin-1'), rb.decode('latin-1')
    assert la.endswith('\r') == lb.endswith('\r'), n
    la, lb = la.rstrip('\r'), lb.rstrip('\r')
    cmd, wa = split(la)
    _, wb = split(lb)
    line_letters = set(re.findall(r'[XYZ]', la.split(';')[0].upper()[3:])) if cmd == 'G28' else set()
    skp_line = la
    ra_ = si.feed(cmd, wa) if cmd else None
    rb_ = so.feed(cmd, wb) if cmd else None
    if la.startswith(';Z:'):
        assert abs(float(lb[3:]) - gz(float(la[3:]))) < 6e-5, (n, la, lb)
        changed += la != lb
        continue
    if ra_ is None:
        assert la == lb, f'line {n} differs: {la!r} -> {lb!r}'
        identical += 1
        continue
    moves += 1
    assert skeleton(la) == skeleton(lb), f'line {n} structure: {la!r} -> {lb!r}'
    if la == lb: identical += 1
    else: changed += 1
    (s0, e0, de0, pres), (s1, e1, de1, _) = ra_, rb_
    for i in pres:  # every written coordinate is the mapped input coordinate
        err = abs(e1[i] - mp[i](e0[i]))
        max_pos_err = max(max_pos_err, err)
        assert err <= 5.1e-5, (n, 'XYZ'[i], la, lb, e1[i], mp[i](e0[i]))
    L = math.hypot(e0[0] - s0[0], e0[1] - s0[1])
    if de0 > 0 and L > 0:
        extruding += 1
        ns = [mp[i](s0[i]) for i in range(3)]; ne = [mp[i](e0[i]) for i in range(3)]
        ratio = math.hypot(ne[0] - ns[0], ne[1] - ns[1]) / L * zslope(0.5 * (s0[2] + e0[2]))
        expect = de0 * ratio
    else:
        expect = de0
    err = abs(de1 - expect)
    max_e_err = max(max_e_err, err)
    assert err <= 1.01e-5, (n, la, lb, de1, expect)
print(f'{len(A)} lines: {identical} identical, {changed} changed; {moves} moves, '
      f'{extruding} extruding; max |XYZ error| {max_pos_err:.2e} mm, max |dE error| {max_e_err:.2e} mm')
print('OK')
