#!/usr/bin/env python3
"""A slab under the PI of the 1D design, the independent reference of the 3D model's
slab-pi case (docs/sls3d.md).

Slab 0 <= z <= L of PA12 (k, rho, c of the SLS paper), insulated at z = 0, flux U(t) into the
top z = L, initially at rest (rise 0). The controller is the continuous PI
C(s) = kp (Ti s + 1) / (Ti s) on e = S - y, y = T(L, t):

    U = kp (e + I / Ti),   dI/dt = e,   I(0) = 0,

no saturation. Solved by the method of lines (second-order finite differences on N + 1 nodes,
the flux condition through a ghost node) with scipy's BDF integrator at rtol 1e-11, so the
values below carry neither the 3D model's elements nor its sampled controller.

Writes tests/reference/sls3d/slab_pi.json: the top rise and U at the given times for the
cases listed in CASES.

usage: slab_pi.py [OUT.json]
"""
import json
import os
import sys

import numpy as np
from scipy import integrate, sparse

K, RHO, CP = 0.28, 1010.0, 1928.0
A = K / (RHO * CP)
# (thickness m, set point rise K, kp W/(m^2 K), Ti s, times s)
CASES = [
    (1e-4, 10.0, 0.3, 0.5, [10.0, 30.0, 60.0]),
    (1e-3, 10.0, 0.3, 0.5, [10.0, 30.0, 60.0]),
    (1e-3, 5.0, 30.0, 2.0, [1.0, 5.0, 20.0]),
]
N = 400


def solve(L, S, kp, ti, times):
    h = L / N
    main = -2.0 * np.ones(N + 1)
    off = np.ones(N)
    lap = sparse.diags([off, main, off], [-1, 0, 1], format="lil")
    lap[0, 1] = 2.0          # insulated: ghost T_-1 = T_1
    lap[N, N - 1] = 2.0      # flux: ghost T_N+1 = T_N-1 + 2 h U / k
    lap = (A / h**2) * lap.tocsr()
    src = np.zeros(N + 1)
    src[N] = 2.0 * A / (h * K)   # multiplies U

    def rhs(_t, s):
        T, I = s[:-1], s[-1]
        e = S - T[N]
        U = kp * (e + I / ti)
        d = lap @ T + src * U
        return np.append(d, e)

    def jac(_t, _s):
        J = sparse.lil_matrix((N + 2, N + 2))
        J[: N + 1, : N + 1] = lap
        J[N, N] += -src[N] * kp
        J[N, N + 1] = src[N] * kp / ti
        J[N + 1, N] = -1.0
        return J.tocsc()

    sol = integrate.solve_ivp(rhs, (0.0, max(times)), np.zeros(N + 2), method="BDF", t_eval=times,
                              rtol=1e-11, atol=1e-13, jac=jac)
    assert sol.success, sol.message
    y = sol.y[N]
    u = kp * ((S - y) + sol.y[N + 1] / ti)
    return y.tolist(), u.tolist()


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "slab_pi.json")
    rows = []
    for L, S, kp, ti, times in CASES:
        y, u = solve(L, S, kp, ti, times)
        rows.append({"thickness_mm": L * 1e3, "setpoint_rise_k": S, "kp_w_m2k": kp, "ti_s": ti,
                     "times_s": times, "top_rise_k": y, "flux_w_m2": u})
    doc = {"source": "tests/reference/sls3d/slab_pi.py",
           "material": {"conductivity_w_mk": K, "density_kg_m3": RHO, "specific_heat_j_kgk": CP},
           "nodes": N + 1, "cases": rows}
    with open(out, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
