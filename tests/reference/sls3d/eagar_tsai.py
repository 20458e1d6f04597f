#!/usr/bin/env python3
"""Quasi-steady temperature rise of a Gaussian surface source moving over a half-space
(Eagar & Tsai, "Temperature fields produced by traveling distributed heat sources", Welding
Journal 62 (12), 1983), evaluated with scipy as the independent reference of the 3D model's
moving-source case (docs/sls3d.md, section 4.3).

Source q(r) = 2 P / (pi W^2) exp(-2 r^2 / W^2) (W the 1/e^2 radius, sigma = W / 2), speed v
along +x, xi = x - v t, z the depth. Superposing instantaneous Gaussian releases on the
insulated half-space:

  T(xi, y, z) = P / (rho c) * int_0^inf  2 exp(-z^2 / (4 a t)) / sqrt(4 pi a t)
                * exp(-((xi + v t)^2 + y^2) / (2 sigma^2 + 4 a t)) / (2 pi (sigma^2 + 2 a t))  dt

integrated here in t with scipy.integrate.quad (the 1/sqrt(t) singularity by the algebraic
weight, not the substitution the C++ code uses). The peak on the track is found with
scipy.optimize.minimize_scalar.

Writes tests/reference/sls3d/eagar_tsai.json: for Peclet numbers v W / (2 a) = 1, 2, 5, 10, 20,
50 (PA12 of the SLS paper, P = 1 W, W = 0.1 mm): the peak rise and its position, and the rise
at probe points (xi, y, z) in units of W.

usage: eagar_tsai.py [OUT.json]
"""
import json
import math
import os
import sys

import numpy as np
from scipy import integrate, optimize

K, RHO, CP = 0.28, 1010.0, 1928.0
A = K / (RHO * CP)
P, W = 1.0, 1e-4
PROBES_W = [(-1.0, 0.0, 0.0), (0.0, 0.0, 0.5), (0.0, 1.0, 0.0), (-2.0, 0.5, 0.25), (1.0, 0.0, 0.0)]


def rise(v, xi, y, z):
    s2 = 0.25 * W * W

    def f(t):
        if t <= 0:
            return 0.0 if z != 0 else 2.0 / math.sqrt(4 * math.pi * A) * math.exp(
                -(xi * xi + y * y) / (2 * s2)) / (2 * math.pi * s2)
        return (2.0 * math.exp(-z * z / (4 * A * t)) / math.sqrt(4 * math.pi * A)
                * math.exp(-((xi + v * t) ** 2 + y * y) / (2 * s2 + 4 * A * t))
                / (2 * math.pi * (s2 + 2 * A * t)))

    # Weight 1/sqrt(t) handled by quad's algebraic weight on [0, t1], the tail plainly.
    t_scale = s2 / A + abs(xi) / v + 4 * A / v ** 2
    t1 = t_scale
    head, _ = integrate.quad(f, 0, t1, weight="alg", wvar=(-0.5, 0), limit=400, epsabs=0, epsrel=1e-12)
    tail = 0.0
    lo = t1
    while True:
        hi = lo * 4
        part, _ = integrate.quad(lambda t: f(t) / math.sqrt(t), lo, hi, limit=400, epsabs=0, epsrel=1e-12)
        tail += part
        if abs(part) < 1e-15 * abs(head + tail) or hi > 1e6 * t_scale:
            break
        lo = hi
    return P / (RHO * CP) * (head + tail)


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "eagar_tsai.json")
    rows = []
    for pe in [1, 2, 5, 10, 20, 50]:
        v = 2 * A * pe / W
        ell = A / v
        res = optimize.minimize_scalar(lambda x: -rise(v, x, 0, 0), bounds=(-(3 * W + 10 * ell), W),
                                       method="bounded", options={"xatol": 1e-10 * W})
        probes = [{"xi_w": p[0], "y_w": p[1], "z_w": p[2], "rise_k": rise(v, p[0] * W, p[1] * W, p[2] * W)}
                  for p in PROBES_W]
        rows.append({"peclet": pe, "speed_m_s": v, "peak_rise_k": -res.fun, "peak_xi_m": res.x, "probes": probes})
        print(f"Pe {pe:3d}: v {v * 1e3:8.4f} mm/s, peak {-res.fun:10.4f} K at {res.x / W:+.4f} W")
    doc = {"source": "tests/reference/sls3d/eagar_tsai.py", "material": {"conductivity_w_mk": K,
           "density_kg_m3": RHO, "specific_heat_j_kgk": CP}, "power_w": P, "beam_radius_m": W, "cases": rows}
    with open(out, "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


if __name__ == "__main__":
    main()
