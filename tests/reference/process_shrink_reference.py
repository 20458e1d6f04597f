#!/usr/bin/python3
"""Independent reference values for tests/process/shrinkage_test.cpp (scipy, brute force).

Run: /usr/bin/python3 tests/reference/process_shrink_reference.py
"""
import numpy as np
from scipy import stats

# Seed 004, Table 1 (geometry 1): nominal and mean measured heights (mm).
nom = np.array([5.08, 10.16, 14.99, 20.06, 25.15, 29.97, 35.05, 40.13, 44.96, 50.04,
                55.12, 60.20, 65.02, 70.10, 74.93, 80.01, 85.09, 90.17, 94.99, 100.08])
mea = np.array([5.26, 10.51, 15.26, 20.35, 25.37, 30.25, 35.28, 40.38, 45.18, 50.21,
                55.32, 60.28, 65.17, 70.20, 75.06, 80.15, 85.15, 90.11, 95.00, 100.11])
printed_err = np.array([0.18, 0.34, 0.27, 0.29, 0.22, 0.28, 0.23, 0.25, 0.22, 0.17,
                        0.20, 0.08, 0.15, 0.10, 0.13, 0.14, 0.06, -0.06, 0.01, 0.03])
err = mea - nom
r = stats.linregress(nom, err)
t = stats.t.ppf(0.975, len(nom) - 2)
print("table1 slope %.15g intercept %.15g" % (r.slope, r.intercept))
print("table1 slope_se %.15g intercept_se %.15g r2 %.15g" % (r.stderr, r.intercept_stderr, r.rvalue**2))
print("table1 factor %.15g" % (1 / (1 + r.slope)))
print("table1 t975(18) %.15g" % t)
print("table1 factor_ci %.15g %.15g" % (1 / (1 + r.slope + t * r.stderr), 1 / (1 + r.slope - t * r.stderr)))
rp = stats.linregress(nom, printed_err)
print("table1 printed-error column: slope %.15g factor %.15g" % (rp.slope, 1 / (1 + rp.slope)))
above = nom > 10
ra = stats.linregress(nom[above], err[above])
print("table1 above 10 mm: slope %.15g factor %.15g" % (ra.slope, 1 / (1 + ra.slope)))

# Best two-range split by brute force over every cut, >= 3 points each.
best = None
for c in range(3, len(nom) - 2):
    sse = 0
    for sl in (slice(0, c), slice(c, None)):
        fit = stats.linregress(nom[sl], err[sl])
        res = err[sl] - (fit.slope * nom[sl] + fit.intercept)
        sse += (res**2).sum()
    if best is None or sse < best[0]:
        best = (sse, c)
print("table1 best split: cut before index %d (nominal %.2f), total sse %.15g" % (best[1], nom[best[1]], best[0]))

# Synthetic repeats: three readings per level with a known pattern, for the lack-of-fit test.
lv = np.array([2.0, 4.0, 6.0, 8.0, 10.0])
h = np.repeat(lv, 3)
dev = np.tile([-0.01, 0.0, 0.012], 5)
curv = np.repeat([0.0, 0.01, 0.015, 0.01, 0.0], 3)
e = -0.004 * h + 0.1 + dev + curv
rr = stats.linregress(h, e)
res = e - (rr.slope * h + rr.intercept)
sse = (res**2).sum()
means = np.array([e[h == v].mean() for v in lv])
ss_pe = sum(((e[h == v] - e[h == v].mean())**2).sum() for v in lv)
F = ((sse - ss_pe) / 3) / (ss_pe / 10)
print("repeats slope %.15g intercept %.15g slope_se %.15g" % (rr.slope, rr.intercept, rr.stderr))
print("repeats pure_error_sd %.15g lack_of_fit_p %.15g" % (np.sqrt(ss_pe / 10), stats.f.sf(F, 3, 10)))
rm = stats.linregress(lv, means)
print("repeats means slope %.15g slope_se %.15g" % (rm.slope, rm.stderr))
print("t quantiles: t(0.975,3) %.15g t(0.9,7.5) %.15g t(0.999,1) %.15g" %
      (stats.t.ppf(0.975, 3), stats.t.ppf(0.9, 7.5), stats.t.ppf(0.999, 1)))
print("betainc(2.5, 0.5, 0.3) %.15g" % __import__("scipy.special", fromlist=["betainc"]).betainc(2.5, 0.5, 0.3))
