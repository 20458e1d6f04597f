#!/usr/bin/env python3
"""Klipper's own calibration of several records at once and of its PSD files, at full double
precision, for tests/resonance/klipper_files_test.cpp (README.md, "Several files and Klipper's
PSD files", has the commands).

    PYTHONPATH=<matplotlib stub> /usr/bin/python3 klipper_calibrate_files.py KLIPPER_TREE OUT.json \
        NAME=FILE[+FILE...][:normalized] ...

Each NAME=... is one case: the files are read with Klipper's calibrate_shaper.parse_log (a raw
record, a PSD file, a several-record PSD file) and joined as calibrate_shaper.py joins them
(CalibrationData.add_data), then ShaperCalibrate(printer=None).find_best_shaper(data, scv=5.)
with every other argument at its default. ":normalized" reads a PSD file as already
normalised (what the Klipper that wrote an older calibration_data_*.csv did; parse_log of
October 2025 and later normalises it a second time, since it looks for ",shapers:").
Nothing of Klipper is written out but the numbers.
"""
import importlib
import json
import os
import sys


def main(argv):
    tree, out = argv[0], argv[1]
    sys.path.insert(0, os.path.join(tree, "scripts"))
    sys.path.insert(0, os.path.join(tree, "klippy"))
    calibrate_shaper = importlib.import_module("calibrate_shaper")
    shaper_calibrate = importlib.import_module("extras.shaper_calibrate")
    import numpy as np
    cases = {}
    for spec in argv[2:]:
        name, files = spec.split("=", 1)
        normalized = files.endswith(":normalized")
        files = files[:-len(":normalized")] if normalized else files
        datas = []
        for f in files.split("+"):
            if normalized:
                data = np.genfromtxt(f, dtype=np.float64, skip_header=1, comments="#",
                                     delimiter=",", filling_values=0.)
                d = shaper_calibrate.CalibrationData(
                    name=f, freq_bins=data[:, 0], psd_sum=data[:, 4], psd_x=data[:, 1],
                    psd_y=data[:, 2], psd_z=data[:, 3])
                d.set_numpy(np)
                d._normalized = True  # as written: normalise no further
                datas.append(d)
            else:
                datas.append(calibrate_shaper.parse_log(f))
        joined = datas[0]
        for d in datas[1:]:
            joined.add_data(d)
        helper = shaper_calibrate.ShaperCalibrate(printer=None)
        best, shapers = helper.find_best_shaper(joined, scv=5., logger=None)
        cases[name] = {
            "files": files.split("+"),
            "normalized_as_written": normalized,
            "records": [d.name for d in joined.get_datasets()],
            "recommended": {"name": best.name, "freq_hz": float(best.freq)},
            "shapers": [{"name": s.name, "freq_hz": float(s.freq), "vibrations": float(s.vibrs),
                         "smoothing": float(s.smoothing), "score": float(s.score),
                         "max_accel_mm_s2": float(s.max_accel)} for s in shapers],
        }
    with open(out, "w") as f:
        json.dump(cases, f, indent=1)
        f.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
