#!/usr/bin/env python3
"""Regenerates the tables of docs/diagnose.md, "With the machine file".

Twin-made cases: the real run is the built-in machine with every factor the
recalibration fits 5 % off (every speed loss x1.05, every heat capacity
x0.95, every conductance to the air x1.05) and one effect on; the sim is the
nominal twin driven by the real run (`--profile file:`, another noise seed);
`diagnose --machine` gets the nominal machine file. For each case it runs

    thermcomp simulate --out real.csv --hours H --dt-s DT --profile spectrum \
        --effects E --seed S --machine mm5.toml
    thermcomp simulate --out sim.csv --profile file:real.csv --seed S+1000
    thermcomp diagnose --sim sim.csv --real real.csv --machine nominal.toml --json

and prints one markdown row per case. `E+nolog`: the real run without its
ambient_c and coolant_c columns.

    scripts/diagnose_machine_cases.py [--hours 48] [--dt-s 60] [--seeds 1,2,3] [--out DIR]
"""
import argparse
import csv
import json
import pathlib
import re
import subprocess

ROOT = pathlib.Path(__file__).resolve().parent.parent
CASES = ["none", "ambient", "ambient+nolog", "coolant", "coolant+nolog",
         "cutting", "motor_loss", "sensor_lag"]


def thermcomp(binary, *args):
    return subprocess.run([binary, *args], check=True, capture_output=True,
                          text=True).stdout


def mismatched(nominal_text):
    """The nominal machine file with every fitted factor 5 % off."""
    def scale(text, key, f):
        return re.sub(rf"^({key} = )([0-9.]+)",
                      lambda m: m.group(1) + repr(float(m.group(2)) * f),
                      text, flags=re.M)
    for key in ["front_bearing_w_at_ref", "rear_bearing_w_at_ref",
                "motor_idle_w", "motor_iron_w_at_ref"]:
        nominal_text = scale(nominal_text, key, 1.05)
    nominal_text = scale(nominal_text, "c_j_per_k", 0.95)
    return scale(nominal_text, "g_ambient_w_per_k", 1.05)


def drop_boundaries(path):
    rows = list(csv.reader(open(path)))
    keep = [i for i, c in enumerate(rows[0]) if c not in ("ambient_c", "coolant_c")]
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        for r in rows:
            w.writerow([r[i] for i in keep])


def run_case(binary, out, case, seed, hours, dt):
    effect, _, nolog = case.partition("+")
    tag = f"{case}_s{seed}"
    real, sim = out / f"real_{tag}.csv", out / f"sim_{tag}.csv"
    thermcomp(binary, "simulate", "--out", str(real), "--hours", str(hours),
              "--dt-s", str(dt), "--profile", "spectrum", "--effects", effect,
              "--seed", str(seed), "--machine", str(out / "mm5.toml"))
    if nolog:
        drop_boundaries(real)
    thermcomp(binary, "simulate", "--out", str(sim), "--profile", f"file:{real}",
              "--seed", str(seed + 1000))
    return json.loads(thermcomp(binary, "diagnose", "--sim", str(sim), "--real",
                                str(real), "--machine", str(out / "nominal.toml"),
                                "--json"))


def factors(t):
    keys = ["heat_factor", "bearing_exponent", "capacity_factor", "g_ambient_factor"]
    return "/".join(f"{t[k]:.3f}" for k in keys)


def row(case, seed, v):
    p = v["physical"]
    effect = case.partition("+")[0]
    effects = {e["name"]: e for e in p["effects"]}
    truth = effects.get(effect)
    others = max(e["shrink_pct"] for n, e in effects.items() if n != effect)
    ch = p["channel"]
    cells = [case, seed, v["verdict"], ch, f"{p['gap_of_sim'][ch]:.3f}",
             f"{p['gap_after_recalibration'][ch]:.3f}", f"{p['gap_snr']:.1f}",
             p["best"] if truth else f"({p['best']})",
             f"{truth['shrink_pct']:.1f}" if truth else "-", f"{others:.1f}",
             factors(p["recalibrated"]), factors(truth["twin"]) if truth else "-",
             json.dumps(truth["params"]) if truth else "-", f"{p['seconds']:.2f}"]
    return "| " + " | ".join(str(c) for c in cells) + " |"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hours", type=float, default=48)
    ap.add_argument("--dt-s", type=float, default=60)
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--out", default=str(ROOT / "target" / "diagnose-machine"))
    ap.add_argument("--thermcomp", default=str(ROOT / "target" / "release" / "thermcomp"))
    a = ap.parse_args()
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    nominal = thermcomp(a.thermcomp, "simulate", "--print-machine")
    (out / "nominal.toml").write_text(nominal)
    (out / "mm5.toml").write_text(mismatched(nominal))
    print("| real has | seed | statistical verdict | channel | sim gap | after recalibration "
          "| gap / noise | best physical | its shrink % | next best shrink % "
          "| recalibrated heat/exponent/capacity/g_amb | with the effect | effect params | s |")
    print("|---" * 14 + "|")
    for case in CASES:
        for seed in [int(s) for s in a.seeds.split(",")]:
            print(row(case, seed, run_case(a.thermcomp, out, case, seed, a.hours, a.dt_s)),
                  flush=True)


if __name__ == "__main__":
    main()
