#!/usr/bin/env python3
"""`fit --model auto` calibrated on ONE constant-room run, scored on the
room-moving runs: the single-run case of docs/fit.md ("A plant we did not
build", "One calibration run").

For each seed and variant, each named calibration run is fitted alone
(`--inputs` every T column, every displacement target) and scored with
`thermcomp eval` on the plant's scored runs; the line gives the sum of the
targets' rmse, um, and the last line the total over all fits.

  --plant lathe  scripts/lathe_plant.py, calibration runs cal1 and cal3,
                 dx + dz (variants a-d)
  --plant vmc    scripts/vmc_plant.py, cal1, dx + dy + dz (variants a-d)
  --plant twin   scripts/auto_room_split.py's runs: the steps run at 18 C
                 and the spectrum run at 20 C, dx + dy + dz (no variants)

Seeds measured in docs/fit.md: development lathe 1-6 (a, b) and twin 1-6;
never run before and run once: lathe 13-18, vmc 7-9, twin 19-24. "Before"
there is the release binary of d18abb2, "now" that of 9d1977b.

usage: scripts/auto_one_run.py [path/to/thermcomp] [--plant lathe|vmc|twin]
       [--variants abcd] [--seeds 13-18]
"""
import json
import pathlib
import subprocess
import sys
import tempfile

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import auto_lathe_split as split  # noqa: E402
import auto_room_split as room  # noqa: E402

# Per plant: which calibration runs are fitted alone.
ALONE = {"lathe": ["cal1", "cal3"], "vmc": ["cal1"]}


def scored_sum(exe, cal, test, targets):
    """Sum over `targets` of auto's rmse on `test`, fitted on `cal` alone, um."""
    temps = [c for c in room.read(cal)[1] if c.startswith("T") and c[1:].isdigit()]
    with tempfile.TemporaryDirectory() as tmp:
        room.run(exe, "fit", "--data", cal, "--target", ",".join(targets), "--model", "auto",
                 "--inputs", ",".join(temps), "--out", f"{tmp}/m.bin")
        ev = json.loads(room.run(exe, "eval", "--model", f"{tmp}/m.bin",
                                 *room.data_args(test), "--json"))
    return sum(ev[t]["rmse_um"] for t in targets)


def plant_fits(exe, plant, variant, seed):
    """(label, sum) of every single-run fit of one seed of a simulated plant."""
    script, _, test_names, targets = split.PLANTS[plant]
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, str(split.HERE / script), "--seed", str(seed),
                        "--variant", variant, "--out", tmp], check=True, capture_output=True)
        test = [f"{tmp}/{n}.csv" for n in test_names]
        return [(f"{plant} {variant} seed {seed} {c}",
                 scored_sum(exe, f"{tmp}/{c}.csv", test, targets)) for c in ALONE[plant]]


def twin_fits(exe, seed):
    """The same on the twin's room protocol: each of its first two runs alone."""
    with tempfile.TemporaryDirectory() as tmp:
        cal, test = room.make_runs(exe, tmp, seed)
        return [(f"twin seed {seed} {pathlib.Path(c).stem}",
                 scored_sum(exe, c, test, room.TARGETS)) for c in cal[:2]]


def main():
    args = sys.argv[1:]
    plant = room.option(args, "--plant", "lathe")
    variants = room.option(args, "--variants", "abcd")
    seeds = split.seeds_of(room.option(args, "--seeds", "13-18"))
    exe = args[0] if args else str(room.ROOT / "target/release/thermcomp")
    total, n = 0.0, 0
    for seed in seeds:
        groups = [twin_fits(exe, seed)] if plant == "twin" else \
            [plant_fits(exe, plant, v, seed) for v in variants]
        for label, value in (f for g in groups for f in g):
            print(f"{label:32} {value:9.2f}", flush=True)
            total, n = total + value, n + 1
    print(f"total over {n} fits: {total:.1f} um")


if __name__ == "__main__":
    main()
