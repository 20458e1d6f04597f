#!/usr/bin/python3
"""Independent reference values for tests/thermal/powder_bed_tf_test.cpp and robust_margin_test.cpp.

Uses numpy/scipy only (no amctl code): G(s) = a cosh(sqrt(s) l/a)/(k0 sqrt(s) sinh(sqrt(s) l/a))
evaluated with numpy's complex cosh/sinh at moderate |s|, residues by contour integration,
the PI margins by a dense grid + scipy bounded scalar maximisation, and the closed-loop poles of
the G_1 loop from numpy.roots of the characteristic polynomial.
Run: /usr/bin/python3 tests/reference/thermal_powder_bed_tf.py
"""
import numpy as np
from scipy.optimize import minimize_scalar

rho, cp, k0 = 1010.0, 1928.0, 0.28
a2 = k0 / (rho * cp)
a = np.sqrt(a2)


def G(s, l):
    rs = np.sqrt(complex(s))
    return a * np.cosh(rs * l / a) / (k0 * rs * np.sinh(rs * l / a))


def residue(p, l, rad):
    # (1/2 pi j) contour integral of G around p, radius rad, trapezoid rule (spectral).
    th = np.linspace(0, 2 * np.pi, 4097)[:-1]
    z = p + rad * np.exp(1j * th)
    vals = np.array([G(zz, l) for zz in z]) * rad * np.exp(1j * th)
    return np.mean(vals).real


l = 1e-4
print("a2 = %.12e" % a2)
for s in [1.0 + 0j, 1j * 10.0, -50.0 + 30j, 1e3j, 5e3 + 2e3j]:
    g = G(s, l)
    print("G(%s) = %.12e %+.12ej" % (s, g.real, g.imag))
p1 = -(np.pi * a / l) ** 2
print("p1 = %.12e" % p1)
print("res0 = %.12e" % residue(0.0, l, 1.0))
print("res1 = %.12e" % residue(p1, l, 5.0))
print("res3 = %.12e" % residue(9 * p1, l, 5.0))
# zero z0: |G| tiny there
z0 = -(0.5 * np.pi * a / l) ** 2
print("|G(z0)| = %.3e" % abs(G(z0, l)))

kp, Ti = 0.3, 0.5


def C(s):
    return kp * (Ti * s + 1) / (Ti * s)


def G1(s, l):
    r = a2 / (k0 * l)
    return r / s + 2 * r / (s + (np.pi * a / l) ** 2)


def peak(fun):
    lw = np.linspace(-6, 8, 140001)
    m = np.array([abs(fun(1j * 10 ** x)) for x in lw])
    i = int(np.argmax(m))
    res = minimize_scalar(lambda x: -abs(fun(1j * 10 ** x)), bounds=(lw[max(i - 1, 0)], lw[min(i + 1, len(lw) - 1)]),
                          method="bounded", options={"xatol": 1e-12})
    return max(-res.fun, m[i], kp), 10 ** res.x


def G_tanh(s, l):
    # Same function through numpy's complex tanh, which saturates instead of overflowing
    # (the cosh/sinh quotient above overflows beyond |sqrt(s) l/a| ~ 710).
    rs = np.sqrt(complex(s))
    return a / (k0 * rs * np.tanh(rs * l / a))


for l in [1e-4, 5e-4, 1e-3]:
    pk1, w1 = peak(lambda s: C(s) / (1 + G1(s, l) * C(s)))
    pk, w = peak(lambda s: C(s) / (1 + G_tanh(s, l) * C(s)))
    print("l=%g margin_G1 = %.10e (w=%.6e) margin_G = %.10e (w=%.6e)" % (l, 1 / pk1, w1, 1 / pk, w))

# closed-loop poles of the G_1 loop: Ti s^2 (s + p) + kp (Ti s + 1) (r (s + p) + 2 r s) = 0
l = 1e-4
r = a2 / (k0 * l)
p = (np.pi * a / l) ** 2
poly = np.polyadd(Ti * np.array([1.0, p, 0.0, 0.0]), kp * np.polymul([Ti, 1.0], [3 * r, r * p]))
roots = np.roots(poly)
print("G1 loop poles:", roots, "max Re = %.12e" % roots.real.max())
