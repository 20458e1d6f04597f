#!/usr/bin/python3
"""Independent reference values for tests/dynamics and tests/trajectory (scipy/numpy).

Run:  /usr/bin/python3 tests/reference/dynamics_reference.py
The printed numbers are hard-coded in the C++ tests that name this script.
"""
import numpy as np
from scipy.signal import cont2discrete
from scipy.integrate import solve_ivp, quad

np.set_printoptions(precision=17)

# 1. ZOH discretisation of seed 000 (3.12), one axis, w = 100 rad/s, z = 0.5, h = 0.005 s.
w, z, h = 100.0, 0.5, 0.005
A = np.array([[0, 1], [-w * w, -2 * z * w]])
B = np.array([[0, 0], [w * w, 2 * z * w]])
Ad, Bd, *_ = cont2discrete((A, B, np.eye(2), np.zeros((2, 2))), h, method="zoh")
print("zoh Phi", repr(Ad.ravel()))
print("zoh Gamma", repr(Bd.ravel()))

# 2. Seed base case: 10 mm X then 10 mm Y, full stop, a = 5000, v = 100 (trapezoid).
#    Simulate 3.11 with solve_ivp (DOP853, tight tolerances) and print x, y at a few times.
a, v, D = 5000.0, 100.0, 10.0
ta = v / a
tc = (D - v * v / a) / v
T = 2 * ta + tc


def s_of(t):
    """path distance and speed inside one move (trapezoid)."""
    if t <= 0:
        return 0.0, 0.0
    if t < ta:
        return 0.5 * a * t * t, a * t
    if t < ta + tc:
        return 0.5 * a * ta * ta + v * (t - ta), v
    if t < T:
        r = T - t
        return D - 0.5 * a * r * r, a * r
    return D, 0.0


def base(t):
    if t < T:
        s, sv = s_of(t)
        return s, 0.0, sv, 0.0
    s, sv = s_of(t - T)
    return D, s, 0.0, sv


def rhs(t, x):
    xb, yb, vxb, vyb = base(t)
    return [x[1], -2 * z * w * (x[1] - vxb) - w * w * (x[0] - xb),
            x[3], -2 * z * w * (x[3] - vyb) - w * w * (x[2] - yb)]


tq = [0.01, 0.05, 0.12, 0.125, 0.2, 0.24, 0.3]
sol = solve_ivp(rhs, (0, 0.3), [0, 0, 0, 0], method="DOP853", rtol=1e-12, atol=1e-14,
                t_eval=tq, max_step=1e-3)
for t, x, y in zip(sol.t, sol.y[0], sol.y[2]):
    print(f"seed base t={t:.3f} x={x:.12f} y={y:.12f}")

# 3. scurve7 ramp distance by quadrature: v0 = 10, v1 = 110, a = 5000, j = 1e6
#    (dv = 100 >= a^2/j = 25: full seven-segment ramp).
v0, v1, am, jm = 10.0, 110.0, 5000.0, 1.0e6
tj = am / jm
tca = (v1 - v0) / am - tj


def vel(t):
    if t < tj:
        return v0 + 0.5 * jm * t * t
    if t < tj + tca:
        return v0 + 0.5 * jm * tj * tj + am * (t - tj)
    r = 2 * tj + tca - t
    return v1 - 0.5 * jm * r * r


Tr = 2 * tj + tca
d, _ = quad(vel, 0, Tr, points=[tj, tj + tca], epsabs=1e-14, epsrel=1e-14)
print(f"scurve full ramp T={Tr:.15f} d={d:.15f}")
# Reduced ramp: dv = 16 < 25.
v1r = 26.0
tjr = np.sqrt((v1r - v0) / jm)


def velr(t):
    if t < tjr:
        return v0 + 0.5 * jm * t * t
    r = 2 * tjr - t
    return v1r - 0.5 * jm * r * r


dr, _ = quad(velr, 0, 2 * tjr, points=[tjr], epsabs=1e-14, epsrel=1e-14)
print(f"scurve reduced ramp T={2 * tjr:.15f} d={dr:.15f} peak_a={jm * tjr:.12f}")

# 4. Seed base case: largest overshoot of x past the corner (x = 10) after the corner.
sol2 = solve_ivp(rhs, (0, 0.4), [0, 0, 0, 0], method="DOP853", rtol=1e-12, atol=1e-14,
                 dense_output=True, max_step=1e-3)
tt = np.linspace(0.12, 0.4, 280001)
xs = sol2.sol(tt)[0]
print(f"seed base max overshoot past x=10: {xs.max() - 10:.9f} at t={tt[xs.argmax()]:.6f}")
