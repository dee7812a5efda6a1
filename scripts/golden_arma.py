#!/usr/bin/env python3
"""Golden vectors for `thermcomp fit --model arma` (host-tools/tests/fit_arma.rs).

For each series it runs the same pipeline the Rust trainer runs, with
statsmodels as the reference:

1. Gaussian standardisation z = (y - mean) / std (sample std, ddof = 1).
2. `adfuller(z, regression="c", autolag="AIC")` with statsmodels' default
   maxlag; while the p-value is above ALPHA and d < 2, difference once more.
3. On the resulting w: `acf` / `pacf(method="ldb")` of the first lags,
   `yule_walker` (both methods) for orders 1..4, and the AIC of
   `ARIMA(w, order=(p, 0, q), trend="c").fit()` for every p, q in 0..=MAX,
   both from the default start (`aic_default`, `best_default_fit`) and the
   best of statsmodels' own optimiser from several starts (`aic`, `best`):
   the default start sometimes stops at a lower local maximum.

Writes host-tools/tests/data/arma_golden.json. Fixed seed: rerunning
reproduces the file byte for byte (same library versions).

    python3 scripts/golden_arma.py
"""

import json
import os
import sys
import warnings

import numpy as np
import scipy
import statsmodels
from statsmodels.regression.linear_model import yule_walker
from statsmodels.tsa.arima.model import ARIMA
from statsmodels.tsa.stattools import acf, adfuller, pacf

ALPHA = 0.05
MAX_P = 3
MAX_Q = 3
NLAGS = 10
SEED = 20240501

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
REAL_RUN = os.path.join(REPO, "..", "shared", "data", "fl_thermal", "run.csv")
OUT = os.path.join(REPO, "host-tools", "tests", "data", "arma_golden.json")


def arma_sample(rng, n, phi, theta, mean, sd, burn=500):
    """ARMA(p, q) by its recursion, burn-in discarded."""
    e = rng.normal(0.0, sd, n + burn)
    w = np.zeros(n + burn)
    for k in range(n + burn):
        acc = e[k]
        for i, a in enumerate(phi, 1):
            if k - i >= 0:
                acc += a * w[k - i]
        for j, b in enumerate(theta, 1):
            if k - j >= 0:
                acc += b * e[k - j]
        w[k] = acc
    return mean + w[burn:]


def real_slice():
    """ch5_um of the real run, first 24 h, every 4th row (60 s)."""
    data = np.genfromtxt(REAL_RUN, delimiter=",", names=True)
    t = data["t_s"]
    keep = (t < 86400.0) & (np.round(t / 15.0).astype(int) % 4 == 0)
    return data["ch5_um"][keep]


def adf_record(x):
    stat, p, used, nobs, crit, _ = adfuller(x, regression="c", autolag="AIC", result_object=False)
    return {
        "stat": float(stat),
        "pvalue": float(p),
        "usedlag": int(used),
        "nobs": int(nobs),
        "crit": {k: float(v) for k, v in crit.items()},
    }


def golden(name, y, note):
    y = np.asarray(y, dtype=float)
    mean = float(np.mean(y))
    std = float(np.std(y, ddof=1))
    z = (y - mean) / std
    steps = []
    w = z
    d = 0
    while True:
        rec = adf_record(w)
        rec["d"] = d
        steps.append(rec)
        if rec["pvalue"] <= ALPHA or d == 2:
            break
        w = np.diff(w)
        d += 1
    yw = {}
    for method in ("adjusted", "mle"):
        yw[method] = []
        for order in range(1, 5):
            rho, sigma = yule_walker(w, order=order, method=method, result_object=False)
            yw[method].append(
                {"order": order, "phi": [float(v) for v in rho], "sigma": float(sigma)}
            )
    table = []
    fitted = {}
    for p in range(MAX_P + 1):
        for q in range(MAX_Q + 1):
            model = ARIMA(w, order=(p, 0, q), trend="c")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = model.fit()
                # Multi-start: statsmodels' own optimiser from other points
                # (the mixed-model likelihood has local maxima; the default
                # start can stop at a lower one). The best llf is kept.
                best_res = res
                starts = [np.r_[np.mean(w), np.zeros(p + q), np.var(w)]]
                for pp, qq in ((p - 1, q), (p, q - 1), (p - 1, q - 1)):
                    if (pp, qq) in fitted:
                        b = fitted[(pp, qq)].params
                        ar = np.r_[b[1 : 1 + pp], np.zeros(p - pp)]
                        ma = np.r_[b[1 + pp : 1 + pp + qq], np.zeros(q - qq)]
                        starts.append(np.r_[b[0], ar, ma, b[-1]])
                for sp in starts:
                    try:
                        r2 = model.fit(start_params=sp)
                    except Exception:
                        continue
                    if np.isfinite(r2.llf) and r2.llf > best_res.llf:
                        best_res = r2
            fitted[(p, q)] = best_res
            par = best_res.params
            table.append(
                {
                    "p": p,
                    "q": q,
                    "aic_default": float(res.aic),
                    "llf_default": float(res.llf),
                    "aic": float(best_res.aic),
                    "llf": float(best_res.llf),
                    "mean": float(par[0]),
                    "phi": [float(v) for v in par[1 : 1 + p]],
                    "theta": [float(v) for v in par[1 + p : 1 + p + q]],
                    "sigma2": float(par[-1]),
                    "converged": bool(best_res.mle_retvals.get("converged", True)),
                }
            )
    best = min(table, key=lambda r: r["aic"])
    best_default = min(table, key=lambda r: r["aic_default"])
    srt = sorted(r["aic"] for r in table)
    return {
        "name": name,
        "note": note,
        "series": [float(v) for v in y],
        "mean": mean,
        "std": std,
        "adf": steps,
        "d": d,
        "acf": [float(v) for v in acf(w, nlags=NLAGS, fft=False)],
        "pacf_ldb": [float(v) for v in pacf(w, nlags=NLAGS, method="ldb")],
        "yule_walker": yw,
        "arima": table,
        "best": {"p": best["p"], "q": best["q"], "aic": best["aic"]},
        "best_default_fit": {
            "p": best_default["p"],
            "q": best_default["q"],
            "aic": best_default["aic_default"],
        },
        "aic_gap_to_second": float(srt[1] - srt[0]),
    }


def main():
    rng = np.random.default_rng(SEED)
    series = [
        golden(
            "ar2",
            arma_sample(rng, 600, [0.6, -0.3], [], 5.0, 2.0),
            "stationary AR(2), phi = (0.6, -0.3), mean 5, sd 2",
        ),
        golden(
            "arma11",
            arma_sample(rng, 800, [0.7], [0.4], -3.0, 1.0),
            "ARMA(1,1), phi = 0.7, theta = 0.4, mean -3",
        ),
        golden(
            "drift_walk",
            np.cumsum(0.2 + rng.normal(0.0, 1.0, 500)),
            "random walk with drift 0.2, unit steps",
        ),
        golden(
            "fl_thermal_ch5_60s",
            real_slice(),
            "../shared/data/fl_thermal/run.csv ch5_um, t < 86400 s, every 4th row (60 s)",
        ),
    ]
    out = {
        "generator": "scripts/golden_arma.py",
        "seed": SEED,
        "versions": {
            "python": sys.version.split()[0],
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "statsmodels": statsmodels.__version__,
        },
        "adf_alpha": ALPHA,
        "max_p": MAX_P,
        "max_q": MAX_Q,
        "series": series,
    }
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    for s in series:
        print(
            f"{s['name']}: d = {s['d']}, best (p, q) = ({s['best']['p']}, {s['best']['q']}) "
            f"[default fit() only: ({s['best_default_fit']['p']}, {s['best_default_fit']['q']})], "
            f"aic gap to second {s['aic_gap_to_second']:.3f}, adf {[round(a['stat'], 3) for a in s['adf']]}"
        )


if __name__ == "__main__":
    main()
