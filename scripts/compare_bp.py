#!/usr/bin/env python3
"""thermcomp fit --model bp/gabp beside scikit-learn's MLPRegressor on the real FL_THERMAL run.

Same split as docs/fit.md (first 24 h calibrate, the rest held out), same inputs
(all 16 temperatures as changes from the run's first sample), same net: one
hidden layer of 10 tanh neurons (thermcomp bp's default), linear output, inputs
and targets min-max scaled to [-1, 1] over the calibration rows. scikit-learn
trains with L-BFGS (max_iter 200, alpha 0: no penalty, random_state 1) on all
calibration rows; thermcomp trains with Levenberg-Marquardt and early stopping
on validation blocks (and gabp with a GA first). Held-out reduction % and RMSE
side by side, one model per channel, and the wall time of each.

Different optimisers from different starts land in different local minima of
a nonlinear fit, so the figures are reported, not compared against a
tolerance: this exits non-zero only if thermcomp fails or a figure is not finite.

usage: scripts/compare_bp.py [path/to/thermcomp]
"""
import math
import sys
import time
import warnings

import numpy as np
import sklearn
from sklearn.exceptions import ConvergenceWarning
from sklearn.neural_network import MLPRegressor

from realrun import TARGETS, load, reduction, thermcomp_exe, thermcomp_held_out

HIDDEN = 10


def rmse(y, yhat):
    return float(np.sqrt(np.mean((y - yhat) ** 2)))


def scale(v, lo, hi):
    span = np.where(hi > lo, hi - lo, 1.0)
    return 2.0 * (v - lo) / span - 1.0


def main():
    exe = thermcomp_exe()
    data, col, cal, hold, x = load()
    x_lo, x_hi = x[cal].min(axis=0), x[cal].max(axis=0)
    xs = scale(x, x_lo, x_hi)
    results = {}
    timing = {}
    for kind in ["bp", "gabp"]:
        held_out, timing[kind] = thermcomp_held_out(exe, ["--model", kind])
        results[kind] = {t: (h["reduction_pct"], h["rmse_um"]) for t, h in held_out.items()}
    t0 = time.perf_counter()
    results["sklearn"] = {}
    iters = {}
    for target in TARGETS:
        y = data[:, col[target]]
        y_lo, y_hi = y[cal].min(), y[cal].max()
        ys = scale(y, y_lo, y_hi)
        m = MLPRegressor(hidden_layer_sizes=(HIDDEN,), activation="tanh", solver="lbfgs",
                         alpha=0.0, max_iter=200, random_state=1)
        with warnings.catch_warnings():
            # L-BFGS stopping at max_iter is reported below, not warned about.
            warnings.simplefilter("ignore", ConvergenceWarning)
            m.fit(xs[cal], ys[cal])
        iters[target] = m.n_iter_
        yhat = (m.predict(xs[hold]) + 1.0) * (y_hi - y_lo) / 2.0 + y_lo
        results["sklearn"][target] = (reduction(y[hold], yhat), rmse(y[hold], yhat))
    timing["sklearn"] = time.perf_counter() - t0
    bad = []
    print(f"{'target':7} | {'bp red %':>9} {'rmse um':>8} | {'gabp red %':>10} {'rmse um':>8} | "
          f"{'sklearn red %':>13} {'rmse um':>8}")
    for target in TARGETS:
        cells = []
        for kind in ["bp", "gabp", "sklearn"]:
            red, err = results[kind][target]
            if not (math.isfinite(red) and math.isfinite(err)):
                bad.append(f"{kind} {target}: {red}, {err}")
            cells.append((red, err))
        print(f"{target:7} | {cells[0][0]:9.2f} {cells[0][1]:8.3f} | {cells[1][0]:10.2f} {cells[1][1]:8.3f} | "
              f"{cells[2][0]:13.2f} {cells[2][1]:8.3f}")
    print()
    for kind in ["bp", "gabp"]:
        print(f"{kind}: thermcomp fit (5 processes: CSV parse, fit, blob, scoring) {timing[kind]:.2f} s; "
              f"ratio to scikit-learn {timing[kind] / timing['sklearn']:.2f}")
    print(f"scikit-learn MLPRegressor lbfgs fit + predict (data in memory) {timing['sklearn']:.2f} s; "
          f"L-BFGS iterations per channel {[iters[t] for t in TARGETS]} (cap 200)")
    print(f"numpy {np.__version__}, scikit-learn {sklearn.__version__}")
    if bad:
        print("FAILED: non-finite figures:\n  " + "\n  ".join(bad))
        sys.exit(1)
    print("all figures finite (accuracy differences are reported, not judged: different optimisers)")


if __name__ == "__main__":
    main()
