"""amctl: plan, simulate and control 3D printers from Python (docs/python.md).

The same functions as the ``amctl`` command line, with the same names and the same results:

    import amctl
    m = amctl.Machine.load("voron24", set={"printer.max_accel": 5000})
    report = amctl.estimate("part.gcode", machine=m)      # = amctl estimate --json
    moves = amctl.plan("part.gcode", machine=m)           # = amctl plan (numpy structured array)
    q = amctl.simulate("part.gcode", machine=m, natural_frequency_hz=40, damping_ratio=0.1)

Units are in the names: mm, s, mm/s, mm/s^2 for motion; SI (K, W, J, m) for thermal.
Bad input raises amctl.Error (with file, line, column); a wrong type raises TypeError naming
the parameter.
"""

from ._errors import Error, InternalError
from ._amctl import AxisModel, Machine, MOVE_DTYPE, __version__
from ._planning import estimate, gcode_inputs, iter_plan, plan
from ._dynamics import simulate
from ._thermal import bed, hotend, sls_build, sls_margins
from ._sls3d import sls3d
from ._process import estimate_empirical, shrink_fit
from ._shaping import (compare, compensate, report, resonance_calibrate, shaper_show, steps,
                       stepper_simulate, stepper_sweep)
from ._jobs import (calibrate_time, compare_profiles, resonance_recommend, resonance_test_gcode,
                    shrink_apply, shrink_slicing, sweep, write_m73)

__all__ = [
    "Error", "InternalError", "Machine", "AxisModel", "MOVE_DTYPE",
    "estimate", "plan", "iter_plan", "simulate", "gcode_inputs",
    "sls_margins", "sls_build", "hotend", "bed",
    "shrink_fit", "estimate_empirical",
    "shaper_show", "resonance_calibrate", "report", "steps", "stepper_simulate", "stepper_sweep", "compensate", "compare",
    "write_m73", "compare_profiles", "calibrate_time", "shrink_slicing", "shrink_apply",
    "resonance_recommend", "resonance_test_gcode", "sweep",
    "sls3d",
]
