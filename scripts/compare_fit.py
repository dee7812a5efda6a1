#!/usr/bin/env python3
"""thermcomp fit beside scikit-learn on the real FL_THERMAL run.

Same split as docs/fit.md (first 24 h calibrate, the rest held out), same
inputs (all 16 temperatures as changes from the run's first sample): MLR
(sklearn LinearRegression) and PCR (StandardScaler + PCA(2) +
LinearRegression) fitted by scikit-learn and by `thermcomp fit`, held-out
reduction % side by side, and the wall time of each. Exits non-zero if the
held-out figures disagree by more than 1e-6 percentage points (both are exact
least-squares answers in f64).

usage: scripts/compare_fit.py [path/to/thermcomp]
"""
import csv
import json
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np
import sklearn
from sklearn.decomposition import PCA
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

ROOT = pathlib.Path(__file__).resolve().parent.parent
RUN = ROOT.parent / "shared" / "data" / "fl_thermal" / "run.csv"
SPLIT_S = 86400.0
TARGETS = [f"ch{i}_um" for i in range(1, 6)]
TEMPS = [f"T{i}" for i in range(1, 17)]


def reduction(y, yhat):
    return (1.0 - np.mean(np.abs(y - yhat)) / np.mean(np.abs(y))) * 100.0


def main():
    exe = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target" / "release" / "thermcomp")
    with open(RUN, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        data = np.array(list(reader), dtype=float)
    col = {n: i for i, n in enumerate(header)}
    t = data[:, col["t_s"]]
    x = data[:, [col[c] for c in TEMPS]]
    x = x - x[0]
    cal, hold = t < SPLIT_S, t >= SPLIT_S
    failures = []
    print(f"{'model':5} {'target':7} {'thermcomp %':>12} {'sklearn %':>10} {'diff':>9}")
    timing = {}
    for kind, make in [("mlr", LinearRegression), ("pcr", lambda: make_pipeline(StandardScaler(), PCA(2), LinearRegression()))]:
        # A model has at most 4 outputs: one thermcomp model per target.
        t0 = time.perf_counter()
        ours = {"targets": {}}
        for target in TARGETS:
            args = [exe, "fit", "--data", str(RUN), "--target", target, "--model", kind,
                    "--holdout-from-s", str(SPLIT_S), "--json"]
            if kind == "pcr":
                args += ["--components", "2"]
            with tempfile.TemporaryDirectory() as tmp:
                one = json.loads(subprocess.run(args + ["--out", f"{tmp}/m.bin"], check=True,
                                                capture_output=True, text=True).stdout)
            ours["targets"].update(one["targets"])
        t_ours = time.perf_counter() - t0
        t0 = time.perf_counter()
        theirs = {}
        for target in TARGETS:
            y = data[:, col[target]]
            m = make().fit(x[cal], y[cal])
            theirs[target] = reduction(y[hold], m.predict(x[hold]))
        t_theirs = time.perf_counter() - t0
        timing[kind] = (t_ours, t_theirs)
        for target in TARGETS:
            a = ours["targets"][target]["holdout"]["reduction_pct"]
            b = theirs[target]
            flag = "" if abs(a - b) <= 1e-6 else "  <-- MISMATCH"
            print(f"{kind:5} {target:7} {a:12.4f} {b:10.4f} {abs(a - b):9.1e}{flag}")
            if flag:
                failures.append(f"{kind} {target}: {a} vs {b}")
    print()
    for kind, (a, b) in timing.items():
        print(f"{kind}: thermcomp fit (5 processes: CSV parse, fit, blob, scoring) {a*1e3:.0f} ms; "
              f"scikit-learn (fit + predict, data in memory) {b*1e3:.0f} ms; ratio {a / b:.2f}")
    print(f"numpy {np.__version__}, scikit-learn {sklearn.__version__}")
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("thermcomp and scikit-learn agree within 1e-6 percentage points")


if __name__ == "__main__":
    main()
