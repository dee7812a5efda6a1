#!/usr/bin/env python3
"""thermcomp fit beside scikit-learn on the real FL_THERMAL run.

Same split as docs/fit.md (first 24 h calibrate, the rest held out), same
inputs (all 16 temperatures as changes from the run's first sample): MLR
(sklearn LinearRegression) and PCR (StandardScaler + PCA(2) +
LinearRegression) fitted by scikit-learn and by `thermcomp fit`, and an ARX
(na = 2, nb = 2, nk = 0 on T1, T4, T5, T8, T11: fixed orders and no ridge penalty,
so no search)
by numpy least squares and by `thermcomp fit --model arx`, simulated free from
the run start as the hub runs it; held-out reduction % side by side, and the
wall time of each. Exits non-zero if the held-out figures disagree by more
than 1e-6 percentage points for MLR/PCR (exact least squares in f64) or 1e-3
for ARX (a recursion over 11,115 samples amplifies rounding of different but
equivalent solvers).

usage: scripts/compare_fit.py [path/to/thermcomp]
"""
import sys
import time

import numpy as np
import sklearn
from sklearn.decomposition import PCA
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from realrun import TARGETS, load, reduction, thermcomp_exe, thermcomp_held_out


def held_out_reduction(exe, extra):
    """Held-out reduction % per target from `thermcomp fit ... extra` and the wall time."""
    out, seconds = thermcomp_held_out(exe, extra)
    return {t: h["reduction_pct"] for t, h in out.items()}, seconds


def main():
    exe = thermcomp_exe()
    data, col, cal, hold, x = load()
    failures = []
    print(f"{'model':5} {'target':7} {'thermcomp %':>12} {'sklearn %':>10} {'diff':>9}")
    timing = {}
    for kind, make in [("mlr", LinearRegression), ("pcr", lambda: make_pipeline(StandardScaler(), PCA(2), LinearRegression()))]:
        ours, t_ours = held_out_reduction(exe, ["--model", kind] + (["--components", "2"] if kind == "pcr" else []))
        t0 = time.perf_counter()
        theirs = {}
        for target in TARGETS:
            y = data[:, col[target]]
            m = make().fit(x[cal], y[cal])
            theirs[target] = reduction(y[hold], m.predict(x[hold]))
        t_theirs = time.perf_counter() - t0
        timing[kind] = (t_ours, t_theirs)
        for target in TARGETS:
            a = ours[target]
            b = theirs[target]
            flag = "" if abs(a - b) <= 1e-6 else "  <-- MISMATCH"
            print(f"{kind:5} {target:7} {a:12.4f} {b:10.4f} {abs(a - b):9.1e}{flag}")
            if flag:
                failures.append(f"{kind} {target}: {a} vs {b}")
    # ARX: A(q) y = sum_i B_i(q) u_i, fixed orders, least squares on the
    # calibration samples, then free-run simulation over the whole run.
    arx_inputs = ["T1", "T4", "T5", "T8", "T11"]
    na, nb = 2, 2
    u = data[:, [col[c] for c in arx_inputs]]
    u = u - u[0]
    ours, t_ours = held_out_reduction(exe, ["--inputs", ",".join(arx_inputs), "--model", "arx", "--na", f"{na}..{na}",
                                            "--nb", f"{nb}..{nb}", "--nk", "0..0", "--ridge", "0"])
    t0 = time.perf_counter()
    theirs = {}
    n_cal = int(cal.sum())
    lag = max(na, nb - 1)
    for target in TARGETS:
        y = data[:, col[target]]
        rows = []
        for k in range(lag, n_cal):
            rows.append(np.concatenate([-y[k - na:k][::-1]] + [u[k - nb + 1:k + 1, i][::-1] for i in range(len(arx_inputs))]))
        theta, *_ = np.linalg.lstsq(np.array(rows), y[lag:n_cal], rcond=None)
        a, b = theta[:na], theta[na:].reshape(len(arx_inputs), nb)
        sim = np.zeros_like(y)
        for k in range(len(y)):
            acc = 0.0
            for j in range(1, na + 1):
                acc -= a[j - 1] * (sim[k - j] if k >= j else 0.0)
            for i in range(len(arx_inputs)):
                for j in range(nb):
                    acc += b[i, j] * (u[k - j, i] if k >= j else 0.0)
            sim[k] = acc
        theirs[target] = reduction(y[hold], sim[hold])
    t_theirs = time.perf_counter() - t0
    timing["arx"] = (t_ours, t_theirs)
    for target in TARGETS:
        a = ours[target]
        b = theirs[target]
        flag = "" if abs(a - b) <= 1e-3 else "  <-- MISMATCH"
        print(f"{'arx':5} {target:7} {a:12.4f} {b:10.4f} {abs(a - b):9.1e}{flag}")
        if flag:
            failures.append(f"arx {target}: {a} vs {b}")
    print()
    for kind, (a, b) in timing.items():
        tool = "numpy lstsq + a Python simulation loop" if kind == "arx" else "scikit-learn fit + predict"
        print(f"{kind}: thermcomp fit (5 processes: CSV parse, fit, blob, scoring) {a*1e3:.0f} ms; "
              f"{tool} (data in memory) {b*1e3:.0f} ms; ratio {a / b:.2f}")
    print(f"numpy {np.__version__}, scikit-learn {sklearn.__version__}")
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("thermcomp agrees with scikit-learn (mlr, pcr) within 1e-6 and numpy (arx) within 1e-3 percentage points")


if __name__ == "__main__":
    main()
