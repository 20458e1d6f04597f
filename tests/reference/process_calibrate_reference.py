#!/usr/bin/python3
"""Independent reference for tests/process/calibrate_test.cpp: scipy.optimize.least_squares
on the synthetic trapezoid-time model, relative residuals, log parameters; covariance
s^2 (J'J)^-1 in log space and standard errors p * se_log (delta method).

Run: /usr/bin/python3 tests/reference/process_calibrate_reference.py
"""
import numpy as np
from scipy.optimize import least_squares

FILES = [[2, 5, 10, 40], [1, 1, 1, 1, 1, 1, 80], [3, 30, 120], [0.5] * 20 + [15], [200, 4, 4]]
NOISE = [0.01, -0.02, 0.015, -0.005, 0.0]


def move_time(L, a, v):
    if L >= v * v / a:
        return L / v + v / a
    return 2 * np.sqrt(L / a)


def durations(a, v):
    return np.array([sum(move_time(L, a, v) for L in f) for f in FILES])


true = durations(2500.0, 120.0)
meas = true * (1 + np.array(NOISE))
print("noise-free durations", " ".join("%.15g" % t for t in true))


def res(lx):
    a, v = np.exp(lx)
    return (meas - durations(a, v)) / meas


sol = least_squares(res, np.log([1000.0, 60.0]), xtol=1e-15, ftol=1e-15, gtol=1e-15)
a, v = np.exp(sol.x)
J = sol.jac
n, p = J.shape
s2 = (sol.fun ** 2).sum() / (n - p)
cov = s2 * np.linalg.inv(J.T @ J)
se = np.exp(sol.x) * np.sqrt(np.diag(cov))
print("fit accel %.12g vmax %.12g" % (a, v))
print("se accel %.12g vmax %.12g" % tuple(se))
print("corr %.12g" % (cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1])))
