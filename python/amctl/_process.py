"""Process planning: shrinkage compensation and the empirical build time (docs/process.md)."""

import numbers

from . import _amctl
from . import _args


def shrink_fit(csv_path, *, axis=None, average=False, ranges=1, breaks_mm=None, min_points=3,
               confidence=0.95, breaks=None):
    """Fits the measured error E = A h + B and the shrinkage factor C = 1/(1+A) per axis.

    The dict of ``amctl shrink fit FILE --json`` (``process::fit_shrinkage_file`` +
    ``shrink_model_json``): for one axis {"axis", "factor", "slope", "intercept_mm", ...},
    for several {"axes": [...]}, with confidence intervals; the file
    ``amctl shrink apply --factors`` reads.

    Args:
        csv_path: CSV with header nominal_mm,measured_mm[,axis,...] (lengths in mm).
        axis: fit only 'X', 'Y' or 'Z' (None: every axis in the file).
        average: fit the mean error at each nominal value (the process-planning study's
            procedure) instead of every repeated measurement.
        ranges: number of ranges (int >= 1) with breakpoints found from the data, or "auto"
            (1..3 chosen by the Bayesian information criterion).
        breaks_mm: breakpoints [mm], strictly increasing (replaces ranges).
        min_points: minimum points per automatically found range.
        confidence: two-sided confidence level of the intervals (0..1).
        breaks: the command line's spelling of breaks_mm.
    """
    breaks_mm = _args.alias(breaks_mm, "breaks_mm", breaks, "breaks", None)
    p = _args.path(csv_path, "csv_path")
    a = None
    if axis is not None:
        a = _args.text(axis, "axis").upper()
        if a not in ("X", "Y", "Z"):
            from ._errors import Error
            raise Error(f"axis must be X, Y or Z, got '{axis}'")
    if ranges == "auto":
        n = 0
    else:
        if isinstance(ranges, bool) or not isinstance(ranges, numbers.Integral):
            raise TypeError(f"ranges must be an int >= 1 or 'auto', got {type(ranges).__name__}")
        n = int(ranges)
        if n < 1:
            from ._errors import Error
            raise Error(f"ranges must be a whole number >= 1 or 'auto', got {n}")
    breaks = []
    if breaks_mm is not None:
        if not isinstance(breaks_mm, (list, tuple)) and not hasattr(breaks_mm, "__array__"):
            raise TypeError(f"breaks_mm must be a list of numbers [mm], got {type(breaks_mm).__name__}")
        breaks = [_args.number(b, f"breaks_mm[{i}]", "mm") for i, b in enumerate(breaks_mm)]
    return _amctl._shrink_fit(p, a, _args.boolean(average, "average"), n, breaks,
                              _args.integer(min_points, "min_points"),
                              _args.number(confidence, "confidence"))


def estimate_empirical(path, *, params=None):
    """The process-planning study's empirical build-time model: scanned path lengths over
    average speeds.

    The dict of ``amctl estimate FILE --mode empirical --json``
    (``process::estimate_empirical``): ``total_time_s`` [s] and its parts, the scanned
    lengths [mm] and the parameters used.

    Args:
        path: G-code file.
        params: parameter file (JSON of ``calibrate-time --mode empirical --save``); None:
            the study's FDM 2000 speeds (uncalibrated for your printer).
    """
    return _amctl._estimate_empirical(_args.path(path, "path"), _args.optional_path(params, "params"))
