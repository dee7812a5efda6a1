#!/usr/bin/env python3
"""Writes the example model and run shipped in examples/ (run once by hand;
its outputs are committed).

The model: multiple linear regression of the displacement channels ch1, ch3
and ch5 of the real FL_THERMAL spindle run (shared/data/fl_thermal) on all 16
temperatures as changes from the run's first sample, calibrated by least
squares (numpy.linalg.lstsq, SVD) on the first 24 h. This is the "naive MLR"
reference the trainer must beat (issue 3); it is here so that `thermcomp
eval` has a model and a held-out run to work on before `thermcomp fit` exists.

The change-from-first-sample form is folded into the intercept,
y = a0 + sum a_i (T_i - T_i(0)) = (a0 - sum a_i T_i(0)) + sum a_i T_i, so the
spec uses absolute temperatures and works on an excerpt that starts mid-run.

The run: the held-out part (t >= 24 h), every 4th row (60 s), values
unchanged.
"""
import csv
import pathlib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
SRC = ROOT.parent / "shared" / "data" / "fl_thermal" / "run.csv"
SPLIT_S = 24 * 3600
TEMPS = [f"T{i}" for i in range(1, 17)]
TARGETS = ["ch1_um", "ch3_um", "ch5_um"]


def main():
    with open(SRC, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [r for r in reader]
    data = np.array(rows, dtype=float)
    col = {name: i for i, name in enumerate(header)}
    t = data[:, col["t_s"]]
    temps = data[:, [col[c] for c in TEMPS]]
    calib = t < SPLIT_S
    x = temps - temps[0]
    design = np.column_stack([np.ones(calib.sum()), x[calib]])
    lines = [
        "# Naive MLR reference on the FL_THERMAL spindle run (scripts/example_mlr.py):",
        "# each channel on all 16 temperatures as changes from the run's first sample,",
        "# least squares (numpy.linalg.lstsq) on the first 24 h; the first-sample",
        "# references are folded into the intercept, so inputs are absolute temperatures.",
        'kind = "linear"',
    ]
    for target in TARGETS:
        y = data[calib, col[target]]
        coef, *_ = np.linalg.lstsq(design, y, rcond=None)
        intercept = coef[0] - float(np.dot(coef[1:], temps[0]))
        terms = ", ".join(f"{c} = {float(v)!r}" for c, v in zip(TEMPS, coef[1:]))
        lines += ["", "[[linear]]", f'output = "{target}"', f"intercept = {float(intercept)!r}", f"coef = {{ {terms} }}"]
    (ROOT / "examples" / "fl_thermal_mlr16.toml").write_text("\n".join(lines) + "\n")
    held = [r for r in rows if float(r[col["t_s"]]) >= SPLIT_S][::4]
    with open(ROOT / "examples" / "fl_thermal_holdout_60s.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(held)
    print(f"wrote examples/fl_thermal_mlr16.toml and examples/fl_thermal_holdout_60s.csv ({len(held)} rows)")


if __name__ == "__main__":
    main()
