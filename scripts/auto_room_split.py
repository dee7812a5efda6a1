#!/usr/bin/env python3
"""The "room moves" protocol on the thermal twin: calibrate on runs held at a
constant room temperature, score on runs where the room temperature moves.

This is the protocol of issue 12's second real machine (calibrated on
constant-temperature runs, scored on runs with a moving room, displacements
zeroed at each run start), rebuilt on simulated runs so that the design of
`fit --model auto` can be judged on it without that machine's data:

  calibration  three runs of `simulate` without effects, each at its own
               constant room temperature (18, 20, 23 C: the machine file's
               ambient_c and coolant_c), profiles steps / spectrum / steps
  scored       two runs with the `ambient` effect (day-night swing, drift,
               door openings), profiles steps / spectrum

Every run is 8 h at 40 s, and every *_um column is zeroed at its run's first
row (as the real machine's logger does). Scored figure: rmse um over the two
scored runs, for `auto`, for a numpy ridge with one fixed feature recipe
(temperature changes raw and low-pass filtered at 15 and 60 min, penalty by
leave-one-run-out CV: the "new user with numpy" baseline), and for numpy
least squares on the raw temperature changes alone (`ols`: no filter, no
penalty, no intercept; the plainest model there is), and the same on the
temperatures `auto` kept (`ols*`: without the inputs it left out because
they did not move in calibration, so that the rule is not what separates
the two). Inputs: the
temperature columns only (`--inputs T1..Tn`), as that machine's criterion.
Also: the band's coverage and mean half-width on the scored runs, the share
of scored samples the hub flags as extrapolating, and the rmse on the second
scored run before and after `thermcomp refit` of the auto blob on the first
(seed 002's self-adaptive update, what a user does after such a day), and
the refitted blob's band coverage there (`rcover`: refit carries the band).

`--rooms 20,20,20` holds every calibration room at one level (the protocol
where the runs start alike, docs/fit.md "When the room moves").

usage: scripts/auto_room_split.py [path/to/thermcomp] [--seed S] [--rooms A,B,C] [-- fit options]
"""
import csv
import json
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import realrun  # noqa: E402

ROOT = realrun.ROOT
TARGETS = ["dx_um", "dy_um", "dz_um"]
DT = 40.0
# model-core's EXTRAPOLATION_FLAG_AT: the hub's "extrapolating" bit.
EXTRAPOLATION_FLAG_AT = 0.1


def simulate(exe, tmp, name, profile, seed, room_c=None, effects=""):
    machine = []
    if room_c is not None:
        toml = subprocess.run([exe, "simulate", "--print-machine"], check=True,
                              capture_output=True, text=True).stdout
        toml = toml.replace("ambient_c = 20.0", f"ambient_c = {room_c}")
        toml = toml.replace("coolant_c = 20.0", f"coolant_c = {room_c}")
        path = f"{tmp}/{name}.toml"
        pathlib.Path(path).write_text(toml)
        machine = ["--machine", path]
    out = f"{tmp}/{name}.csv"
    subprocess.run([exe, "simulate", "--out", out, "--hours", "8", "--dt-s", str(int(DT)),
                    "--profile", profile, "--seed", str(seed), "--effects", effects, *machine],
                   check=True, capture_output=True, text=True)
    zero_displacements(out)
    return out


def zero_displacements(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    head, body = rows[0], rows[1:]
    for j, name in enumerate(head):
        if name.endswith("_um"):
            first = float(body[0][j])
            for r in body:
                r[j] = f"{float(r[j]) - first:.4f}"
    with open(path, "w", newline="") as f:
        csv.writer(f).writerows([head] + body)


def read(path):
    with open(path, newline="") as f:
        r = csv.reader(f)
        head = next(r)
        data = np.array(list(r), dtype=float)
    return data, {n: i for i, n in enumerate(head)}


def read_predictions(path):
    with open(path, newline="") as f:
        r = csv.reader(f)
        head = next(r)
        rows = [[float(v) if v else np.nan for v in row[1:]] for row in r]
    return np.array(rows), {n: i for i, n in enumerate(head[1:])}


def low_pass(u, tau):
    return realrun.low_pass(u, tau, DT)


def features(data, col, temps):
    x = data[:, [col[c] for c in temps]]
    x = x - x[0]
    cols = [x] + [np.column_stack([low_pass(x[:, j], tau) for j in range(x.shape[1])])
                  for tau in (900.0, 3600.0)]
    return np.column_stack(cols)


def ridge_loro(xs, ys, intercept=False):
    """Ridge on standardised columns, penalty by leave-one-run-out; without
    intercept (change features, the default) or with one (absolute
    features: columns and target centred on their means)."""
    lams = 10.0 ** np.arange(-6, 1.01, 0.5)

    def fit(x, y, lam):
        mu = x.mean(0) if intercept else np.zeros(x.shape[1])
        y0 = y.mean() if intercept else 0.0
        sd = x.std(0)
        sd[sd == 0] = 1
        z = (x - mu) / sd
        w = np.linalg.solve(z.T @ z + lam * len(y) * np.eye(z.shape[1]), z.T @ (y - y0))
        return lambda xn: ((xn - mu) / sd) @ w + y0

    def cv(lam):
        e = 0.0
        for i in range(len(xs)):
            x = np.vstack([a for j, a in enumerate(xs) if j != i])
            y = np.concatenate([a for j, a in enumerate(ys) if j != i])
            e += np.sum((fit(x, y, lam)(xs[i]) - ys[i]) ** 2)
        return e
    return fit(np.vstack(xs), np.concatenate(ys), min(lams, key=cv))


def ols_changes(xs, ys):
    """Least squares on the raw temperature changes, no intercept, no
    penalty: the plainest model a user can fit (thermcomp's `mlr` in its
    default change form is this with an intercept)."""
    w = np.linalg.lstsq(np.vstack(xs), np.concatenate(ys), rcond=None)[0]
    return lambda xn: xn @ w


def ols_error(cal_d, test_d, col, temps, t):
    """Errors on the scored runs of `ols_changes` on `temps`."""
    raw = [features(d, col, temps)[:, :len(temps)] for d in cal_d]
    ols = ols_changes(raw, [d[:, col[t]] for d in cal_d])
    return np.concatenate([ols(features(d, col, temps)[:, :len(temps)]) - d[:, col[t]]
                           for d in test_d])


def rmse(e):
    return float(np.sqrt(np.mean(np.square(e))))


def run(exe, *args):
    return subprocess.run([exe, *args], check=True, capture_output=True, text=True).stdout


def data_args(paths):
    return [a for p in paths for a in ("--data", p)]


def make_runs(exe, tmp, seed, rooms=(18.0, 20.0, 23.0)):
    s = 10 * seed
    cal = [simulate(exe, tmp, f"cal{i}", profile, s + 1 + i, room)
           for i, (profile, room) in enumerate(zip(("steps", "spectrum", "steps"), rooms))]
    test = [simulate(exe, tmp, "room1", "steps", s + 4, effects="ambient"),
            simulate(exe, tmp, "room2", "spectrum", s + 5, effects="ambient")]
    return cal, test


def coverage(y, lo, hi):
    """Share of the rows with a band whose value lies inside it, % (rows
    without a band are left out, as `--report` counts)."""
    has = np.isfinite(lo) & np.isfinite(hi)
    return 100.0 * np.mean((y[has] >= lo[has]) & (y[has] <= hi[has]))


def refit_on_room1(exe, tmp, model, test):
    """rmse on room2 of the blob `model` before and after `refit` on room1
    (the user's move after a day whose room moved: seed 002's self-adaptive
    update), and the refitted blob's band coverage on room2, %."""
    run(exe, "refit", "--model", model, "--data", test[0], "--out", f"{tmp}/r.bin")
    before = json.loads(run(exe, "eval", "--model", model, "--data", test[1], "--json"))
    after = json.loads(run(exe, "eval", "--model", f"{tmp}/r.bin", "--data", test[1], "--json"))
    run(exe, "predict", "--model", f"{tmp}/r.bin", "--interval", "--data", test[1],
        "--out", f"{tmp}/rp.csv")
    pred, pcol = read_predictions(f"{tmp}/rp.csv")
    y, col = read(test[1])
    cover = {}
    for t in TARGETS:
        if f"{t}_lo95" not in pcol:
            cover[t] = float("nan")
            continue
        lo, hi = pred[:, pcol[f"{t}_lo95"]], pred[:, pcol[f"{t}_hi95"]]
        cover[t] = coverage(y[:, col[t]], lo, hi)
    return {t: (before[t]["rmse_um"], after[t]["rmse_um"], cover[t]) for t in TARGETS}


def option(args, name, default):
    """The value after `name` in `args` (removed with it), else `default`."""
    if name not in args:
        return default
    at = args.index(name)
    value = args[at + 1]
    del args[at:at + 2]
    return value


def main():
    args = sys.argv[1:]
    extra = []
    if "--" in args:
        extra = args[args.index("--") + 1:]
        args = args[:args.index("--")]
    seed = int(option(args, "--seed", "1"))
    rooms = tuple(float(r) for r in option(args, "--rooms", "18,20,23").split(","))
    exe = args[0] if args else str(ROOT / "target/release/thermcomp")
    with tempfile.TemporaryDirectory() as tmp:
        cal, test = make_runs(exe, tmp, seed, rooms)
        _, col = read(cal[0])
        temps = [c for c in col if c.startswith("T") and c[1:].isdigit()]
        fit_json = json.loads(run(exe, "fit", *data_args(cal), "--target", ",".join(TARGETS),
                                  "--model", "auto", "--inputs", ",".join(temps),
                                  "--out", f"{tmp}/m.bin", "--json", *extra))
        ev_json = json.loads(run(exe, "eval", "--model", f"{tmp}/m.bin", *data_args(test), "--json"))
        run(exe, "predict", "--model", f"{tmp}/m.bin", "--interval", *data_args(test),
            "--out", f"{tmp}/p.csv")
        pred, pcol = read_predictions(f"{tmp}/p.csv")
        refit = refit_on_room1(exe, tmp, f"{tmp}/m.bin", test)
        cal_d = [read(p)[0] for p in cal]
        test_d = [read(p)[0] for p in test]
        quiet = [q["input"] for q in fit_json["details"].get("quiet_inputs", [])]
        kept = [c for c in temps if c not in quiet]
        print(f"left out by auto (did not move in calibration): {', '.join(quiet) or 'none'}")
        print(f"{'target':8} {'auto':>8} {'ridge':>8} {'ols':>8} {'ols*':>8} {'sd y':>8} {'cover%':>7} {'half':>7} {'flag%':>6}"
              f" {'room2':>6} {'refit':>6} {'rcover':>6}  auto's first member (of n)")
        for t in TARGETS:
            xs = [features(d, col, temps) for d in cal_d]
            ys = [d[:, col[t]] for d in cal_d]
            model = ridge_loro(xs, ys)
            e = np.concatenate([model(features(d, col, temps)) - d[:, col[t]] for d in test_d])
            e_ols = ols_error(cal_d, test_d, col, temps, t)
            e_kept = ols_error(cal_d, test_d, col, kept, t)
            y = np.concatenate([d[:, col[t]] for d in test_d])
            lo, hi = pred[:, pcol[f"{t}_lo95"]], pred[:, pcol[f"{t}_hi95"]]
            cover = coverage(y, lo, hi)
            half = float(np.mean(hi - lo) / 2)
            tj = next(x for x in fit_json["details"]["targets"] if x["target"] == t)
            band = tj["band"]
            at_flag = band["half_width"] * (1 + band["growth"] * EXTRAPOLATION_FLAG_AT)
            flagged = 100.0 * np.mean((hi - lo) / 2 >= at_flag * (1 - 1e-9))
            chosen = [r for r in tj["cv_table"] if r["chosen"]] or tj["cv_table"][:1]
            w = chosen[0]
            print(f"{t:8} {ev_json[t]['rmse_um']:8.2f} {rmse(e):8.2f} {rmse(e_ols):8.2f} {rmse(e_kept):8.2f} {y.std():8.2f} {cover:7.1f} "
                  f"{half:7.2f} {flagged:6.1f} {refit[t][0]:6.2f} {refit[t][1]:6.2f} {refit[t][2]:6.1f}  "
                  f"{tj['family']} {w['form']} temps {w['temp_taus_s']} lambda {w['lambda']:g}"
                  f" (of {len(chosen)})")


if __name__ == "__main__":
    main()
