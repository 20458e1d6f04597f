#!/usr/bin/python3
"""Independent reference values for tests/plan/scurve_test.cpp (jerk-limited S-curve moves).

Each ramp is described only by its jerk schedule (+j for tj, 0 for ta, -j for tj, with
tj = min(a/j, sqrt(dv/j)) and ta = max(dv/a - a/j, 0)); distances come from integrating
s''' = jerk numerically with scipy's solve_ivp (RK45, tight tolerances), never from the closed
forms used in amctl. The cruise peak of a move vs -> vp -> ve in distance D is then found with
brentq on the integrated distance.

Run: /usr/bin/python3 tests/reference/scurve_reference.py
"""
import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq


def ramp_schedule(v0, v1, a, j):
    dv = abs(v1 - v0)
    sg = 1.0 if v1 >= v0 else -1.0
    tj = min(a / j, np.sqrt(dv / j))
    ta = max(dv / a - a / j, 0.0)
    return [(tj, sg * j), (ta, 0.0), (tj, -sg * j)]


def integrate(schedule, v0):
    """Integrates (s, v, acc) through piecewise-constant jerk; returns final state and time."""
    y = np.array([0.0, v0, 0.0])
    t = 0.0
    for dur, jerk in schedule:
        if dur <= 0:
            continue
        sol = solve_ivp(lambda _t, z: [z[1], z[2], jerk], (0.0, dur), y, method="RK45",
                        rtol=1e-12, atol=1e-14)
        y = sol.y[:, -1]
        t += dur
    return y, t


def ramp_distance(v0, v1, a, j):
    y, _ = integrate(ramp_schedule(v0, v1, a, j), v0)
    return y[0]


def peak(vs, ve, D, a, j, vmax):
    f = lambda vp: ramp_distance(vs, vp, a, j) + ramp_distance(vp, ve, a, j) - D
    lo = max(vs, ve)
    if f(vmax) <= 0:
        return vmax
    return brentq(f, lo, vmax, xtol=1e-13, rtol=1e-14)


def move_time(vs, vp, ve, D, a, j):
    _, t1 = integrate(ramp_schedule(vs, vp, a, j), vs)
    _, t2 = integrate(ramp_schedule(vp, ve, a, j), vp)
    d = ramp_distance(vs, vp, a, j) + ramp_distance(vp, ve, a, j)
    return t1 + t2 + (D - d) / vp


cases = [
    # vs, ve, D, a, j, vmax
    (3.0, 60.0, 2.0, 3000.0, 2e5, 1000.0),    # two-phase up, mixed
    (40.0, 0.0, 1.0, 3000.0, 2e5, 1000.0),    # short, two-phase both
    (0.0, 10.0, 80.0, 3000.0, 2e5, 1000.0),   # long, three-phase both
]
for vs, ve, D, a, j, vmax in cases:
    vp = peak(vs, ve, D, a, j, vmax)
    print(f"vs={vs} ve={ve} D={D} a={a} j={j}: peak {vp:.12f} mm/s, move time {move_time(vs, vp, ve, D, a, j):.12f} s")
# Rest to rest, 100 mm at 100 mm/s, a = 5000, j = 1e6 (cruise reached): time by integration.
vp = peak(0.0, 0.0, 100.0, 5000.0, 1e6, 100.0)
print(f"rest-rest 100 mm: peak {vp:.12f}, time {move_time(0.0, vp, 0.0, 100.0, 5000.0, 1e6):.12f} s")
