"""The real spindle run as the comparison scripts use it: its path, the
split (first 24 h calibrate, the rest held out), the channels and
temperatures, the run read into numpy, and `thermcomp fit`'s held-out
figures per channel with the wall time of all its processes."""
import csv
import json
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
RUN = ROOT.parent / "shared" / "data" / "fl_thermal" / "run.csv"
SPLIT_S = 86400.0
TARGETS = [f"ch{i}_um" for i in range(1, 6)]
TEMPS = [f"T{i}" for i in range(1, 17)]


def thermcomp_exe():
    """argv[1], or the release build."""
    return sys.argv[1] if len(sys.argv) > 1 else str(ROOT / "target" / "release" / "thermcomp")


def low_pass(u, tau, dt):
    """First-order low-pass of `u` (time constant `tau`, sample time `dt`),
    started in steady state: the recursion model-core's fbank runs."""
    p = np.exp(-dt / tau)
    out = np.empty_like(u)
    s = u[0]
    for k, v in enumerate(u):
        s = p * s + (1 - p) * v
        out[k] = s
    return out


def reduction(y, yhat):
    """CONTRACT.md's reduction_pct."""
    return (1.0 - np.mean(np.abs(y - yhat)) / np.mean(np.abs(y))) * 100.0


def load():
    """(data, column index, calibration mask, held-out mask, temperatures as
    changes from the first row)."""
    with open(RUN, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        data = np.array(list(reader), dtype=float)
    col = {n: i for i, n in enumerate(header)}
    t = data[:, col["t_s"]]
    x = data[:, [col[c] for c in TEMPS]]
    return data, col, t < SPLIT_S, t >= SPLIT_S, x - x[0]


def thermcomp_held_out(exe, extra):
    """The held-out figures (eval's JSON object) per target from `thermcomp
    fit ... extra`, one model per target, and the wall time of all of them."""
    t0 = time.perf_counter()
    out = {}
    for target in TARGETS:
        args = [exe, "fit", "--data", str(RUN), "--target", target,
                "--holdout-from-s", str(SPLIT_S), "--json"] + extra
        with tempfile.TemporaryDirectory() as tmp:
            one = json.loads(subprocess.run(args + ["--out", f"{tmp}/m.bin"], check=True,
                                            capture_output=True, text=True).stdout)
        out[target] = one["targets"][target]["holdout"]
    return out, time.perf_counter() - t0
