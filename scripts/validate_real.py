#!/usr/bin/env python3
"""`thermcomp fit --model auto` on the real FL_THERMAL run beside honest
references, under two protocols, written to docs/validation-auto.md.

Protocols (every choice is made on the calibration rows only; the scored
rows are touched once, by the final prediction):
  24h      calibrate on t < 86400 s (1250/2500/3750 rpm), score the rest
           (5000, 3500 rpm and the staircase): reduction % (CONTRACT.md).
  authors  the FL_THERMAL authors' split: rows [0, 60 %) calibrate,
           rows [60 %, 80 %) scored: mean absolute error, um.

Methods:
  auto       thermcomp fit --model auto, then thermcomp predict --interval
             (also: coverage of the 95 % band on the scored rows)
  arx        thermcomp fit --model arx (the previous default)
  ridge      numpy ridge on temperature changes, temperatures low-pass
             filtered at 15 and 60 min and spindle speed low-pass filtered
             at 30 and 120 min, penalty by 6-fold contiguous-block CV on
             the calibration rows (one fixed feature recipe, chosen a
             priori: the "new user with numpy" baseline)
  gp         scikit-learn GaussianProcessRegressor (isotropic RBF + white
             noise on standardised features, normalised target, marginal
             likelihood maximised) on the same features, fitted on every 4th
             calibration row (O(n^3))

usage: scripts/validate_real.py [path/to/thermcomp] [--no-gp]   (~3-6 min)
"""
import json
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import realrun  # noqa: E402
from realrun import RUN, TARGETS, TEMPS, ROOT  # noqa: E402

DT = 15.0
OUT = ROOT / "docs" / "validation-auto.md"


def read_run():
    import csv
    with open(RUN, newline="") as f:
        r = csv.reader(f)
        header = next(r)
        data = np.array(list(r), dtype=float)
    return data, {n: i for i, n in enumerate(header)}


def low_pass(u, tau):
    return realrun.low_pass(u, tau, DT)


def features(data, col, temps=TEMPS):
    """The ridge's features: changes of `temps`, those through 15 and 60 min
    filters, and speed (krpm) through 30 and 120 min filters."""
    x = data[:, [col[c] for c in temps]]
    x = x - x[0]
    cols = [x]
    for tau in (900.0, 3600.0):
        cols.append(np.column_stack([low_pass(x[:, j], tau) for j in range(x.shape[1])]))
    s = data[:, col["speed_rpm"]] / 1000.0
    cols.append(np.column_stack([low_pass(s, tau) for tau in (1800.0, 7200.0)]))
    return np.column_stack(cols)


def ridge_cv(x, y, folds=6, forward=False):
    """Ridge on standardised `x`, penalty by `folds` contiguous blocks: each
    scored by the fit on all others, pooled squared error (default), or with
    `forward` each from the second scored by the fit on the blocks before it,
    geometric mean of the blocks' mse (thermcomp auto's criterion)."""
    lams = 10.0 ** np.arange(-6, 1.01, 0.5)
    n = len(y)
    edges = np.linspace(0, n, folds + 1).astype(int)

    def fit(xt, yt, lam):
        mu, sd = xt.mean(0), xt.std(0)
        sd[sd == 0] = 1
        z = (xt - mu) / sd
        w = np.linalg.solve(z.T @ z + lam * len(yt) * np.eye(z.shape[1]), z.T @ (yt - yt.mean()))
        return lambda xn: ((xn - mu) / sd) @ w + yt.mean()

    def cv(lam):
        e = 0.0
        for i in range(folds):
            m = np.ones(n, bool)
            m[edges[i]:edges[i + 1]] = False
            e += np.sum((fit(x[m], y[m], lam)(x[~m]) - y[~m]) ** 2)
        return e

    def cv_forward(lam):
        mse = [np.mean((fit(x[:edges[i]], y[:edges[i]], lam)(x[edges[i]:edges[i + 1]])
                        - y[edges[i]:edges[i + 1]]) ** 2) for i in range(1, folds)]
        return np.mean(np.log(mse))
    best = min(lams, key=cv_forward if forward else cv)
    return fit(x, y, best)


def gp_fit(x, y):
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, WhiteKernel, ConstantKernel
    mu, sd = x.mean(0), x.std(0)
    sd[sd == 0] = 1
    z = (x - mu) / sd
    k = ConstantKernel(1.0) * RBF(length_scale=5.0) + WhiteKernel(0.1)
    gp = GaussianProcessRegressor(k, normalize_y=True, n_restarts_optimizer=0, random_state=0)
    gp.fit(z[::4], y[::4])
    return lambda xn: gp.predict((xn - mu) / sd)


def thermcomp_fit_predict(exe, model, target, holdout_from_s, extra=(), run=RUN):
    """Fit on rows of `run` before holdout_from_s, predict every row:
    (pred, lo, hi, json, seconds)."""
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        fit = subprocess.run([exe, "fit", "--data", str(run), "--target", target, "--model", model,
                              "--holdout-from-s", str(holdout_from_s), "--out", f"{tmp}/m.bin",
                              "--json", *extra], check=True, capture_output=True, text=True)
        secs = time.perf_counter() - t0
        args = [exe, "predict", "--model", f"{tmp}/m.bin", "--data", str(run),
                "--out", f"{tmp}/p.csv"]
        if model == "auto":
            args.append("--interval")
        subprocess.run(args, check=True, capture_output=True, text=True)
        import csv
        with open(f"{tmp}/p.csv", newline="") as f:
            r = csv.DictReader(f)
            rows = list(r)
    def col(name):
        return np.array([float(v[name]) if v.get(name) not in (None, "") else np.nan for v in rows])
    pred = col(f"{target}_pred")
    lo = col(f"{target}_lo95") if model == "auto" else None
    hi = col(f"{target}_hi95") if model == "auto" else None
    return pred, lo, hi, json.loads(fit.stdout), secs


def protocols(t):
    """Per protocol: (calibration mask, scored mask, --holdout-from-s)."""
    n = len(t)
    i = np.arange(n)
    return {"24h": (t < 86400.0, t >= 86400.0, 86400.0),
            "authors": (i < int(0.6 * n), (i >= int(0.6 * n)) & (i < int(0.8 * n)),
                        float(t[int(0.6 * n)]))}


def reduction(y, yh):
    return (1 - np.mean(np.abs(y - yh)) / np.mean(np.abs(y))) * 100


def main():
    exe = next((a for a in sys.argv[1:] if not a.startswith("--")),
               str(ROOT / "target" / "release" / "thermcomp"))
    with_gp = "--no-gp" not in sys.argv
    data, col = read_run()
    x = features(data, col)
    protos = protocols(data[:, col["t_s"]])
    methods = ["auto", "arx", "ridge"] + (["gp"] if with_gp else [])
    res = {p: {m: {} for m in methods} for p in protos}
    cover = {p: {} for p in protos}
    width = {p: {} for p in protos}
    secs = {}
    for p, (cal, hold, split) in protos.items():
        for target in TARGETS:
            y = data[:, col[target]]
            for m in methods:
                print(f"{p} {target} {m}", file=sys.stderr, flush=True)
                if m in ("auto", "arx"):
                    pred, lo, hi, _, s = thermcomp_fit_predict(exe, m, target, split)
                    if m == "auto":
                        secs[(p, target)] = s
                        inside = (y[hold] >= lo[hold]) & (y[hold] <= hi[hold])
                        cover[p][target] = 100 * np.mean(inside)
                        width[p][target] = np.mean(hi[hold] - lo[hold]) / 2
                elif m == "ridge":
                    pred = ridge_cv(x[cal], y[cal])(x)
                else:
                    pred = gp_fit(x[cal], y[cal])(x)
                yy, yh = y[hold], pred[hold]
                res[p][m][target] = (reduction(yy, yh), np.mean(np.abs(yy - yh)))
    write(res, cover, width, secs, methods)


def write(res, cover, width, secs, methods):
    lines = ["# `fit --model auto` on the real run, beside numpy and scikit-learn", "",
             "Generated by `scripts/validate_real.py` (FL_THERMAL, 46.3 h at 15 s; every choice",
             "on calibration rows only; the scored rows touched once). See the script's docstring",
             "for the protocols and the reference methods.", "",
             "Honesty note: `auto`'s design choices (the fold scheme, ensemble size, sensor",
             "elimination off, the candidate filter sets) were judged on calibration rows only",
             "(`scripts/auto_dev_split.sh`, docs/fit.md). The scored rows of both protocols were",
             "nevertheless looked at during development (the issue quotes figures on them, and",
             "earlier versions of `auto` were run on them: with leave-one-block-out folds they",
             "gave 24 h 85.1 / 90.3 / 87.3 / 90.0 / 92.3 % and authors' split 1.18 / 1.16 / 4.07 /",
             "5.43 / 2.00 um; with the pooled-error criterion before 2026-11-27, 24 h 88.80 /",
             "85.50 / 86.33 / 83.27 / 87.50 %, mean 86.28, and authors' split 1.29 / 1.22 / 2.30 /",
             "2.13 / 2.43 um), so these are not figures on data never seen. The criterion that",
             "replaced it (the geometric mean of the per-fold errors) was chosen on the",
             "development split alone (docs/fit.md, \"The CV criterion\") and then run here once.",
             "The `gp` row is an isotropic-RBF Gaussian process on the ridge's",
             "features, a weak reference: the issue quotes 88.9 % mean on the 24 h protocol",
             "for a Gaussian process on such features, and we do not reproduce it. A linear +",
             "RBF kernel does no better (`scripts/gp_linear_rbf.py`, run once on 2026-11-27:",
             "76.9 / 84.6 / 47.8 / 41.9 / 25.4 %, mean 55.3).", ""]
    for p, title, key, unit in [("24h", "24 h protocol: held-out reduction %", 0, "%"),
                                ("authors", "Authors' split: mean absolute error, um", 1, "um")]:
        lines += [f"## {title}", "", "| method | " + " | ".join(TARGETS) + " | mean |",
                  "|---|" + "---:|" * (len(TARGETS) + 1)]
        for m in methods:
            v = [res[p][m][t][key] for t in TARGETS]
            lines.append(f"| {m} | " + " | ".join(f"{a:.2f}" for a in v) + f" | {np.mean(v):.2f} |")
        lines += ["", f"95 % band of `auto` (`predict --interval`) on the scored rows: coverage %"
                  " and mean half-width um:", "",
                  "| | " + " | ".join(TARGETS) + " |", "|---|" + "---:|" * len(TARGETS),
                  "| coverage % | " + " | ".join(f"{cover[p][t]:.1f}" for t in TARGETS) + " |",
                  "| half-width um | " + " | ".join(f"{width[p][t]:.2f}" for t in TARGETS) + " |",
                  "| fit seconds | " + " | ".join(f"{secs[(p, t)]:.1f}" for t in TARGETS) + " |", ""]
    OUT.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
