"""Argument checks shared by the modules: a wrong type is a TypeError naming the parameter
(before any C++ runs); values are range-checked by the library (amctl.Error)."""

import math
import numbers
import os
import sys

from ._amctl import Machine


def path(value, param):
    """str or os.PathLike -> str."""
    if isinstance(value, str):
        return value
    if isinstance(value, os.PathLike):
        p = os.fspath(value)
        return p if isinstance(p, str) else os.fsdecode(p)
    raise TypeError(f"{param} must be a str or os.PathLike, got {type(value).__name__}")


def optional_path(value, param):
    return "" if value is None else path(value, param)


def number(value, param, unit=""):
    """A real number (int or float, not bool) -> float. NaN, an infinity, a subnormal number
    (0 < |v| < 2.2e-308) or an int beyond a double is never a physical value or a count, for
    any parameter: amctl.Error naming the parameter, as the command line refuses it for every
    numeric flag. Each parameter's own range is checked by the library."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        what = f" [{unit}]" if unit else ""
        raise TypeError(f"{param} must be a number{what}, got {type(value).__name__}")
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    if not math.isfinite(v) or (v != 0.0 and abs(v) < sys.float_info.min):
        from ._errors import Error
        raise Error(f"{param}: found {value!r}, expected a finite number (and none closer to 0 than "
                    f"{sys.float_info.min:g})", detail=f"found {value!r}, expected a finite number")
    return v


def optional_number(value, param, unit=""):
    return None if value is None else number(value, param, unit)


def integer(value, param):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{param} must be an int, got {type(value).__name__}")
    return int(value)


def optional_integer(value, param):
    return None if value is None else integer(value, param)


def boolean(value, param):
    if not isinstance(value, (bool,)) and not (hasattr(value, "dtype") and value.dtype == bool):
        raise TypeError(f"{param} must be a bool, got {type(value).__name__}")
    return bool(value)


def text(value, param):
    if not isinstance(value, str):
        raise TypeError(f"{param} must be a str, got {type(value).__name__}")
    return value


def optional_text(value, param):
    return "" if value is None else text(value, param)


def machine(value, set_, param="machine"):
    """machine= (None, preset name, path or Machine) and set= -> a validated Machine."""
    if set_ is not None and not isinstance(set_, (dict, list, tuple)):
        raise TypeError(f"set must be a dict {{'section.key': value}} or None, got {type(set_).__name__}")
    if isinstance(value, Machine):
        return value.with_set(set_) if set_ else value
    if value is None or isinstance(value, (str, os.PathLike)):
        return Machine.load(None if value is None else path(value, param), set=set_)
    raise TypeError(f"{param} must be a preset name, a path or an amctl.Machine, got {type(value).__name__}")


def alias(value, name, cli_value, cli_name, default):
    """A parameter that may also be given by its command-line spelling (kp for kp_w_m2k):
    the one given, else the default; both given is an error."""
    if cli_value is not None:
        if value is not None:
            from ._errors import Error
            raise Error(f"give {name} or {cli_name} (the same parameter), not both")
        return cli_value
    return default if value is None else value
