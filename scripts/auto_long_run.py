#!/usr/bin/env python3
"""`fit --model auto` on ONE long run of a plant we did not build, under
FL_THERMAL's two protocols, beside the numpy references of
`validate_real.py`: the one-run case that FL_THERMAL alone tested before.

The plant is `scripts/mill_long_run.py` (a milling centre, written apart
from thermcomp's twin by an author who read none of its source): 46 h at
15 s, 16 temperatures, spindle speed, ch1..ch5. Its variants: a, second
half at speeds already seen; b, a speed 30-50 % above the first 24 h;
c, a warm start, noisier sensors and one drifting; d, b plus a hidden
heat source. Seeds are different machines.

Protocols (every choice on calibration rows only; scored rows touched once):
  24h      calibrate on t < 86400 s, score the rest: reduction %
  authors  rows [0, 60 %) calibrate, rows [60 %, 80 %) scored: mean |error| um

Methods, per channel:
  auto   thermcomp fit --model auto (every T column and speed_rpm)
  ridge  validate_real.py's numpy ridge (changes, 15/60 min filtered
         temperatures, 30/120 min filtered speed, 6-block CV)
  ols    least squares on the temperature changes and speed, with intercept
  ridge_sq  (only when asked) the ridge with the squared speed through the
         same two filters besides the linear one
  ridge_forward  (only when asked) the ridge with its penalty chosen as
         thermcomp auto chooses one: rolling origin over the 6 blocks,
         geometric mean of the blocks' mse
Also, with auto: the coverage of its 95 % band (`predict --interval`) on
the scored rows, per channel.

usage: scripts/auto_long_run.py [path/to/thermcomp] [--variants abcd]
       [--seeds 1-3] [--protocols 24h,authors] [--methods auto,ridge,ols]
(auto takes about 20 min for seeds 3-5 on 2 cores; the numpy methods alone
seconds)
"""
import pathlib
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import auto_lathe_split as split  # noqa: E402
import auto_room_split as room  # noqa: E402
import validate_real as v  # noqa: E402

HERE = pathlib.Path(__file__).resolve().parent
TARGETS = [f"ch{i}_um" for i in range(1, 6)]
METHODS = ["auto", "ridge", "ols"]


def temps_of(col):
    return [c for c in col if c.startswith("T") and c[1:].isdigit()]


def squared_speed(data, col):
    """The squared speed (krpm^2) through the ridge's two speed filters."""
    s = (data[:, col["speed_rpm"]] / 1000.0) ** 2
    return np.column_stack([v.low_pass(s, tau) for tau in (1800.0, 7200.0)])


def ols(x, y):
    a = np.column_stack([np.ones(len(y)), x])
    w = np.linalg.lstsq(a, y, rcond=None)[0]
    return lambda xn: np.column_stack([np.ones(len(xn)), xn]) @ w


def score(p, y, yh):
    return v.reduction(y, yh) if p == "24h" else float(np.mean(np.abs(y - yh)))


def one(exe, variant, seed, wanted, methods):
    """{protocol: {target: {method: figure, "cover": auto's band coverage %}}}
    for one seed of one variant."""
    with tempfile.TemporaryDirectory() as tmp:
        path = f"{tmp}/run.csv"
        subprocess.run([sys.executable, str(HERE / "mill_long_run.py"), "--seed", str(seed),
                        "--variant", variant, "--out", path], check=True, capture_output=True)
        data, col = room.read(path)
        x = v.features(data, col, temps_of(col))
        x_sq = np.column_stack([x, squared_speed(data, col)])
        temps = data[:, [col[c] for c in temps_of(col)]]
        xo = np.column_stack([temps - temps[0], data[:, col["speed_rpm"]] / 1000.0])
        out = {}
        for p, (cal, hold, split) in v.protocols(data[:, col["t_s"]]).items():
            if p not in wanted:
                continue
            out[p] = {}
            for tg in TARGETS:
                y = data[:, col[tg]]
                fits = {"ridge": lambda: v.ridge_cv(x[cal], y[cal])(x),
                        "ridge_sq": lambda: v.ridge_cv(x_sq[cal], y[cal])(x_sq),
                        "ridge_forward": lambda: v.ridge_cv(x[cal], y[cal], forward=True)(x),
                        "ols": lambda: ols(xo[cal], y[cal])(xo)}
                row = {m: score(p, y[hold], fits[m]()[hold]) for m in methods if m != "auto"}
                if "auto" in methods:
                    pred, lo, hi, _, _ = v.thermcomp_fit_predict(exe, "auto", tg, split,
                                                                 run=path)
                    row["auto"] = score(p, y[hold], pred[hold])
                    row["cover"] = 100 * np.mean((y[hold] >= lo[hold]) & (y[hold] <= hi[hold]))
                out[p][tg] = row
        return out


def main():
    args = sys.argv[1:]
    variants = room.option(args, "--variants", "abcd")
    seeds = split.seeds_of(room.option(args, "--seeds", "1-3"))
    wanted = room.option(args, "--protocols", "24h,authors").split(",")
    methods = room.option(args, "--methods", ",".join(METHODS)).split(",")
    exe = (args[0] if args and not args[0].startswith("--")
           else str(room.ROOT / "target/release/thermcomp"))
    total = {p: {m: [] for m in methods} for p in wanted}
    cover = {p: [] for p in wanted}
    print("protocol var seed " + " ".join(f"{m:>8}" for m in methods)
          + "   (24h: mean reduction % over ch1-5; authors: summed MAE um)")
    for var in variants:
        for seed in seeds:
            print(f"  variant {var} seed {seed} ...", file=sys.stderr, flush=True)
            for p, per in one(exe, var, seed, wanted, methods).items():
                agg = {m: [per[t][m] for t in TARGETS] for m in methods}
                fig = {m: (np.mean(agg[m]) if p == "24h" else np.sum(agg[m])) for m in methods}
                for m in methods:
                    total[p][m].append(fig[m])
                chans = " ".join("/".join(f"{per[t][m]:.1f}" for m in methods) for t in TARGETS)
                band = ""
                if "auto" in methods:
                    cover[p].extend(per[t]["cover"] for t in TARGETS)
                    band = "; band coverage % " + " ".join(
                        f"{per[t]['cover']:.0f}" for t in TARGETS)
                print(f"{p:8} {var:3} {seed:4} " + " ".join(f"{fig[m]:8.2f}" for m in methods)
                      + f"   per ch ({'/'.join(methods)}): {chans}{band}", flush=True)
    for p in wanted:
        band = ""
        if cover[p]:
            band = (f"   auto's 95 % band: median coverage {np.median(cover[p]):.0f} %,"
                    f" fits below 80 %: {sum(c < 80 for c in cover[p])} of {len(cover[p])}")
        print(f"{p:8} all mean " + " ".join(f"{np.mean(total[p][m]):8.2f}" for m in methods) + band)


if __name__ == "__main__":
    main()
