#!/usr/bin/python3
"""Where do seed 002's margins 3.3 (PI on G_1) and 0.78 (on G) come from?

Prints the margins 1/||C(1+GC)^-1||_inf of the paper's PI (kp = 0.3, Ti = 0.5) for
  (a) consistent SI units with the corrected residues (what amctl computes),
  (b) the paper's printed G_1 (eq. 12 with residue 2 l/k0 per l^2 s + (pi a)^2, i.e. 1/a^2 too big),
and the Theorem-2 figure eps_a - delta with delta from the printed expressions in several unit
choices. See docs/thermal.md, "The paper's 3.3 and 0.78".
Run: /usr/bin/python3 tests/reference/thermal_paper_numbers.py
"""
import numpy as np
from scipy.optimize import minimize_scalar

rho, cp, k0 = 1010.0, 1928.0, 0.28
a2_si = k0 / (rho * cp)          # m^2/s
a2_mm = a2_si * 1e6              # mm^2/s
kp, Ti = 0.3, 0.5


def C(s):
    return kp * (Ti * s + 1) / (Ti * s)


def margin(G):
    lw = np.linspace(-8, 10, 180001)
    m = np.abs(C(1j * 10 ** lw) / (1 + G(1j * 10 ** lw) * C(1j * 10 ** lw)))
    i = int(np.argmax(m))
    lo, hi = lw[max(i - 1, 0)], lw[min(i + 1, len(lw) - 1)]
    f = lambda x: -abs(C(1j * 10 ** x) / (1 + G(1j * 10 ** x) * C(1j * 10 ** x)))
    r = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
    return 1.0 / max(-r.fun, m[i], kp)


def G1_correct(l, a2):
    r = a2 / (k0 * l)
    return lambda s: r / s + 2 * r / (s + np.pi ** 2 * a2 / l ** 2)


def G1_printed(l, a2):
    return lambda s: a2 / (k0 * l * s) + (2 * l / k0) / (l * l * s + np.pi ** 2 * a2)


def G_exact(l, a2):
    a = np.sqrt(a2)
    return lambda s: a / (k0 * np.sqrt(s) * np.tanh(np.sqrt(s) * l / a))


tail1 = np.pi ** 2 / 6 - 1
print("1/kp (high-frequency ceiling of every margin) = %.6f" % (1 / kp))
for layers in [1, 5, 10]:
    l = layers * 1e-4
    print("l = %d layers = %.1f mm" % (layers, l * 1e3))
    print("  SI, corrected residues: margin G1 = %.6e  margin G = %.6e" %
          (margin(G1_correct(l, a2_si)), margin(G_exact(l, a2_si))))
    print("  SI, printed G_1 (12):   margin G1 = %.6f" % margin(G1_printed(l, a2_si)))
    d13_si = 2 * l / (k0 * np.pi ** 2 * a2_si) * tail1
    d13_mm = 2 * (l * 1e3) / (k0 * np.pi ** 2 * a2_mm) * tail1
    d5_mm = 2 * (l * 1e3) / (k0 * np.pi ** 2 * a2_mm)
    dtrue = 2 * l / (k0 * np.pi ** 2) * tail1
    print("  delta: true %.4e | printed (13) SI %.4e | (13) mm %.4f | sec.5 2l/(k0 (pi a)^2) mm %.4f"
          % (dtrue, d13_si, d13_mm, d5_mm))
    print("  3.3 - sec.5 delta (mm) = %.4f ; 3.3 - (13) mm = %.4f" % (3.3 - d5_mm, 3.3 - d13_mm))
