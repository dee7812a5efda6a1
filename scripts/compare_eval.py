#!/usr/bin/env python3
"""thermcomp beside numpy: the same linear model evaluated both ways.

Runs `thermcomp predict` and `thermcomp eval --json` on the example spec and
held-out run in examples/, recomputes the predictions and every metric of
CONTRACT.md section 1 with numpy from the spec's coefficients, and checks
that they agree (1e-9 relative: both are f64; the tolerance covers summation
order). Prints a side-by-side table with the wall-time ratio and exits
non-zero on any disagreement.

usage: scripts/compare_eval.py [path/to/thermcomp]
"""
import csv
import json
import pathlib
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
SPEC = ROOT / "examples" / "fl_thermal_mlr16.toml"
RUN = ROOT / "examples" / "fl_thermal_holdout_60s.csv"
RTOL = 1e-9


def numpy_metrics(y, yhat):
    r = y - yhat
    return {
        "n": len(y),
        "rmse_um": float(np.sqrt(np.mean(r**2))),
        "fit_pct": float((1 - np.linalg.norm(r) / np.linalg.norm(y - y.mean())) * 100),
        "r2": float(1 - np.sum(r**2) / np.sum((y - y.mean()) ** 2)),
        "eta_pct": float((1 - np.linalg.norm(r) / np.linalg.norm(y)) * 100),
        "max_abs_um": float(np.max(np.abs(r))),
        "mean_abs_um": float(np.mean(np.abs(r))),
        "dpk_um": float(abs(r.max()) + abs(r.min())),
        "reduction_pct": float((1 - np.mean(np.abs(r)) / np.mean(np.abs(y))) * 100),
    }


def main():
    exe = sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target" / "release" / "thermcomp")
    spec = tomllib.loads(SPEC.read_text())
    with open(RUN, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        data = np.array([r for r in reader], dtype=float)
    col = {n: i for i, n in enumerate(header)}

    t0 = time.perf_counter()
    ours = json.loads(subprocess.run(
        [exe, "eval", "--spec", str(SPEC), "--data", str(RUN), "--json"],
        check=True, capture_output=True, text=True).stdout)
    t_ours = time.perf_counter() - t0

    t0 = time.perf_counter()
    reference = {}
    predictions = {}
    for eq in spec["linear"]:
        names = list(eq["coef"])
        coef = np.array([eq["coef"][n] for n in names])
        yhat = eq["intercept"] + data[:, [col[n] for n in names]] @ coef
        predictions[eq["output"]] = yhat
        reference[eq["output"]] = numpy_metrics(data[:, col[eq["output"]]], yhat)
    t_numpy = time.perf_counter() - t0

    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "pred.csv"
        subprocess.run([exe, "predict", "--spec", str(SPEC), "--data", str(RUN), "--out", str(out)],
                       check=True, capture_output=True)
        with open(out, newline="") as f:
            rows = list(csv.DictReader(f))

    failures = []
    for output, yhat in predictions.items():
        got = np.array([float(r[f"{output}_pred"]) for r in rows])
        worst = float(np.max(np.abs(got - yhat) / (np.abs(yhat) + 1e-12)))
        if worst > RTOL:
            failures.append(f"predict {output}: worst relative difference {worst:.2e}")

    print(f"{'target':8} {'metric':14} {'thermcomp':>14} {'numpy':>14} {'rel.diff':>10}")
    for output, ref in reference.items():
        for key, want in ref.items():
            have = ours[output][key]
            diff = abs(have - want) / max(abs(want), 1e-300)
            flag = "" if diff <= RTOL else "  <-- MISMATCH"
            print(f"{output:8} {key:14} {have:14.6f} {want:14.6f} {diff:10.1e}{flag}")
            if flag:
                failures.append(f"{output}.{key}: {have} vs {want}")
    print(f"\nwall time: thermcomp eval (process, CSV parse, model, metrics) {t_ours*1e3:.1f} ms; "
          f"numpy (in-process, data already parsed) {t_numpy*1e3:.1f} ms; "
          f"ratio {t_ours / t_numpy:.1f}")
    print(f"numpy {np.__version__}")
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("thermcomp and numpy agree within", RTOL)


if __name__ == "__main__":
    main()
