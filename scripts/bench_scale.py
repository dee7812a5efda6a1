#!/usr/bin/env python3
"""Scale benchmark: thermcomp on runs of 10^4..10^6 rows beside pandas/numpy.

    scripts/bench_scale.py [path/to/thermcomp] [--sizes 10000,100000,1000000]
                           [--repeats 3] [--no-diagnose] [--only JOB,...] [--write]

Makes synthetic run files shaped like FL_THERMAL (t_s, speed_rpm, 16
temperatures, five displacements; 6 significant digits; 1 s steps), then
times each command as a whole process with /usr/bin/time (wall seconds and
peak resident memory), the thermcomp command and its Python reference in
turn (A B A B ...), and prints the medians and the ratio of medians:

  read      thermcomp eval of a 1-input model (reading dominates) | pandas read_csv
  eval      thermcomp eval, 16-input linear model, 3 outputs      | pandas + numpy matmul + metrics
  predict   thermcomp predict, same model                         | pandas + numpy + to_csv
  replay    thermcomp replay, same model (the hub's pipeline)     | (none)
  fit mlr   thermcomp fit --model mlr, 16 inputs                  | pandas + numpy lstsq
  diagnose  thermcomp diagnose of a sim/real pair                 | (none)

`--only diagnose` (or any comma-separated jobs of the first column) runs
only those. `--write` replaces the "Scale" section of docs/benchmarks.md with the table.
Run it on an idle machine; OPENBLAS_NUM_THREADS=1 is set for numpy (a 2-core
machine under load is slower with more BLAS threads), and the table says so.
Not run by CI (minutes, and timings need a quiet machine).
"""
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "benchmarks.md"
TEMPS = [f"T{i}" for i in range(1, 17)]


def arg(name, default):
    if name in sys.argv:
        return sys.argv[sys.argv.index(name) + 1]
    return default


def make_run(path, n, seed, ambient_swing=0.0):
    """A run of n rows: speed steps every hour, 16 temperatures that follow
    speed through first-order lags, five displacements linear in them."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    speed = np.repeat(rng.choice([0, 1250, 2500, 3750, 5000], size=n // 3600 + 1), 3600)[:n]
    amb = 22.0 + ambient_swing * np.sin(2 * np.pi * t / 86400.0)
    cols = {"t_s": t, "speed_rpm": speed.astype(float)}
    for i, name in enumerate(TEMPS):
        tau = 600.0 * (1 + i % 5)
        p = np.exp(-1.0 / tau)
        drive = amb + (speed / 1000.0) ** 1.5 * (0.5 + 0.3 * (i % 4))
        # first-order lag, vectorised by blocks to keep generation quick
        out = np.empty(n)
        s = drive[0]
        for a in range(0, n, 4096):
            d = drive[a:a + 4096]
            k = np.arange(1, len(d) + 1)
            # s_k = p^k s + (1-p) sum p^(k-j) d_j
            w = p ** (-k)
            acc = np.cumsum(d * w) * (1 - p)
            blk = p ** k * (s + acc)
            out[a:a + len(d)] = blk
            s = blk[-1]
        cols[name] = out + rng.normal(0, 0.02, n)
    for c in range(1, 6):
        cols[f"ch{c}_um"] = sum(cols[name] * (((i + 1) * c) % 7 - 3) * 0.1
                                for i, name in enumerate(TEMPS)) + rng.normal(0, 0.2, n)
        cols[f"ch{c}_um"] -= cols[f"ch{c}_um"][0]
    names = list(cols)
    data = np.column_stack([cols[k] for k in names])
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        np.savetxt(f, data, fmt="%.6g", delimiter=",")


def timed(cmd):
    """(wall s, peak MiB) of one whole-process run."""
    r = subprocess.run(["/usr/bin/time", "-f", "%e %M", *cmd], capture_output=True, text=True,
                       env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    if r.returncode != 0:
        raise SystemExit(f"failed: {' '.join(cmd)}\n{r.stderr[-2000:]}")
    wall, kb = r.stderr.strip().splitlines()[-1].split()
    return float(wall), int(kb) / 1024.0


PY_READ = "import pandas as pd, sys; pd.read_csv(sys.argv[1])"
PY_EVAL = """
import sys, json, numpy as np, pandas as pd
d = pd.read_csv(sys.argv[1]); w = np.linspace(-0.1, 0.1, 16)
x = d[[f"T{i}" for i in range(1, 17)]].to_numpy()
out = {}
for c in ("ch1_um", "ch3_um", "ch5_um"):
    y = d[c].to_numpy(); r = y - (x - x[0]) @ w
    out[c] = {"rmse": float(np.sqrt(np.mean(r * r))), "mae": float(np.mean(np.abs(r)))}
print(json.dumps(out))
"""
PY_PREDICT = """
import sys, numpy as np, pandas as pd
d = pd.read_csv(sys.argv[1]); w = np.linspace(-0.1, 0.1, 16)
x = d[[f"T{i}" for i in range(1, 17)]].to_numpy()
p = pd.DataFrame({"t_s": d.t_s})
for c in ("ch1_um", "ch3_um", "ch5_um"):
    p[c + "_pred"] = (x - x[0]) @ w
p.to_csv(sys.argv[2], index=False)
"""
PY_LSTSQ = """
import sys, numpy as np, pandas as pd
d = pd.read_csv(sys.argv[1])
X = np.c_[np.ones(len(d)), d[[f"T{i}" for i in range(1, 17)]].to_numpy()]
np.linalg.lstsq(X, d.ch1_um.to_numpy(), rcond=None)
"""


def spec(path, inputs):
    lines = ['kind = "linear"']
    for out in ("ch1_um", "ch3_um", "ch5_um"):
        coef = ", ".join(f"{c} = {w:.4f}" for c, w in zip(inputs, np.linspace(-0.1, 0.1, len(inputs))))
        lines += ["", "[[linear]]", f'output = "{out}"', "intercept = 0.0", f"coef = {{ {coef} }}"]
    Path(path).write_text("\n".join(lines) + "\n")


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    for flag in ("--sizes", "--repeats", "--only"):
        if flag in sys.argv:
            args.remove(sys.argv[sys.argv.index(flag) + 1])
    exe = str(Path(args[0]).resolve()) if args else str(ROOT / "target" / "release" / "thermcomp")
    sizes = [int(s) for s in arg("--sizes", "10000,100000,1000000").split(",")]
    repeats = int(arg("--repeats", "3"))
    only = arg("--only", None)
    only = set(only.split(",")) if only else None
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for n in sizes:
            run, real = tmp / f"run{n}.csv", tmp / f"real{n}.csv"
            print(f"making {n} rows", file=sys.stderr)
            make_run(run, n, 1)
            make_run(real, n, 2, ambient_swing=1.5)
            spec(tmp / "m16.toml", TEMPS)
            spec(tmp / "m1.toml", ["T1"])
            for m in ("m16", "m1"):
                subprocess.run([exe, "model", "build", "--spec", tmp / f"{m}.toml", "--out", tmp / f"{m}.bin"],
                               check=True, capture_output=True)
            mb = run.stat().st_size / 2**20
            jobs = [
                ("read", [exe, "eval", "--model", tmp / "m1.bin", "--data", run, "--json"],
                 ["python3", "-c", PY_READ, run]),
                ("eval", [exe, "eval", "--model", tmp / "m16.bin", "--data", run, "--json"],
                 ["python3", "-c", PY_EVAL, run]),
                ("predict", [exe, "predict", "--model", tmp / "m16.bin", "--data", run, "--out", tmp / "p.csv"],
                 ["python3", "-c", PY_PREDICT, run, tmp / "pp.csv"]),
                ("replay", [exe, "replay", "--model", tmp / "m16.bin", "--data", run, "--candump", tmp / "r.log"],
                 None),
                ("fit mlr", [exe, "fit", "--data", run, "--target", "ch1_um", "--inputs", ",".join(TEMPS),
                             "--model", "mlr", "--out", tmp / "f.bin", "--json"],
                 ["python3", "-c", PY_LSTSQ, run]),
            ]
            if "--no-diagnose" not in sys.argv:
                jobs.append(("diagnose", [exe, "diagnose", "--sim", run, "--real", real, "--json"], None))
            if only:
                jobs = [j for j in jobs if j[0] in only]
            for name, a, b in jobs:
                a = [str(x) for x in a]
                b = [str(x) for x in b] if b else None
                ta, tb = [], []
                for _ in range(repeats):
                    ta.append(timed(a))
                    if b:
                        tb.append(timed(b))
                med = lambda v, i: statistics.median(x[i] for x in v)
                row = {"n": n, "mb": mb, "job": name, "t": med(ta, 0), "mem": med(ta, 1),
                       "pt": med(tb, 0) if b else None, "pmem": med(tb, 1) if b else None}
                rows.append(row)
                print(fmt(row), file=sys.stderr)
    table = render(rows, repeats)
    print(table)
    if "--write" in sys.argv:
        write(table)


def fmt(r):
    ref = f"{r['pt']:.2f} s {r['pmem']:.0f} MiB ratio {r['t'] / r['pt']:.2f}" if r["pt"] else "-"
    return f"{r['n']:>8} {r['job']:<9} {r['t']:.2f} s {r['mem']:.0f} MiB | {ref}"


def render(rows, repeats):
    out = ["| rows (file) | job | thermcomp wall s | thermcomp peak MiB | Python wall s | Python peak MiB | time ratio |",
           "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        py = (f"{r['pt']:.2f} | {r['pmem']:.0f} | {r['t'] / r['pt']:.2f}" if r["pt"] else "- | - | -")
        out.append(f"| {r['n']:,} ({r['mb']:.0f} MB) | {r['job']} | {r['t']:.2f} | {r['mem']:.0f} | {py} |")
    import pandas
    out.append("")
    out.append(f"Medians of {repeats} paired runs (A B A B), whole processes, `/usr/bin/time`; "
               f"numpy {np.__version__}, pandas {pandas.__version__}, OPENBLAS_NUM_THREADS=1.")
    return "\n".join(out)


def write(table):
    text = DOC.read_text()
    begin, end = "<!-- scale:begin -->", "<!-- scale:end -->"
    block = f"{begin}\n{table}\n{end}"
    if begin in text:
        text = re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda _: block, text, flags=re.S)
    else:
        text += f"\n## Scale (`scripts/bench_scale.py`)\n\n{block}\n"
    DOC.write_text(text)


if __name__ == "__main__":
    main()
