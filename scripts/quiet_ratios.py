#!/usr/bin/env python3
"""Swing over noise of every temperature, as fit/quiet.rs judges it (the
figures quoted there and in docs/fit.md): the smallest ratio on each of
FL_THERMAL's calibration parts (first 16 h and 24 h, first 40 % and 60 % of
the rows), and on the thermal twin's room-protocol calibration runs
(scripts/auto_room_split.py, seeds 1-18) the smallest of the heated sensors
and those of T7, T8, ambient_c and coolant_c (which only the room moves).

A sensor is quiet when its ratio is at most 3 (MIN_SWING_OVER_NOISE).
usage: scripts/quiet_ratios.py [path/to/thermcomp]
"""
import csv
import pathlib
import sys
import tempfile

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import auto_room_split as room  # noqa: E402
import realrun  # noqa: E402

MAX_HOLD_SAMPLES = 20
ROOM_ONLY = ("T7", "T8", "ambient_c", "coolant_c")


def white_sigma(runs):
    d = np.concatenate([np.abs(np.diff(x, 2)) for x in runs if len(x) > 2])
    return float(np.sort(d)[len(d) // 2] / 0.6745 / np.sqrt(6))


def without_repeats(x):
    return x[np.concatenate([[True], x[1:] != x[:-1]])]


def hold_lengths(x):
    return np.diff(np.flatnonzero(np.concatenate([[True], x[1:] != x[:-1], [True]])))


def noise(runs):
    plain = white_sigma(runs)
    holds = np.concatenate([hold_lengths(x) for x in runs])
    if np.sort(holds)[len(holds) // 2] > MAX_HOLD_SAMPLES:
        return plain
    return max(plain, white_sigma([without_repeats(x) for x in runs]))


def swing(runs):
    total = sum(((x - x.mean()) ** 2).sum() for x in runs if not np.all(x == x[0]))
    return float(np.sqrt(total / sum(len(x) for x in runs)))


def ratio(runs):
    return swing(runs) / noise(runs)


def fl_thermal():
    path = realrun.ROOT.parent / "shared/data/fl_thermal/run.csv"
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    head, d = rows[0], np.array(rows[1:], dtype=float)
    n = len(d)
    parts = {"first 16 h": int(np.searchsorted(d[:, 0], 57600)),
             "first 24 h": int(np.searchsorted(d[:, 0], 86400)),
             "first 40 %": int(0.4 * n), "first 60 %": int(0.6 * n)}
    for name, end in parts.items():
        r, c = min((ratio([d[:end, j]]), c) for j, c in enumerate(head) if c.startswith("T"))
        print(f"FL_THERMAL {name}: smallest ratio {r:.2f} ({c})")


def twin(exe):
    heated, quiet = [], []
    for seed in range(1, 19):
        with tempfile.TemporaryDirectory() as tmp:
            cal, _ = room.make_runs(exe, tmp, seed)
            runs = [room.read(p) for p in cal]
        col = runs[0][1]
        of = {c: ratio([x[:, col[c]] for x, _ in runs]) for c in col
              if (c.startswith("T") and c[1:].isdigit()) or c in ROOM_ONLY}
        heated.append(min((r, c) for c, r in of.items() if c not in ROOM_ONLY))
        quiet.extend(of[c] for c in ROOM_ONLY)
    r, c = min(heated)
    print(f"twin seeds 1-18: smallest heated ratio {r:.2f} ({c}); "
          f"T7, T8, ambient_c, coolant_c {min(quiet):.2f} .. {max(quiet):.2f}")


if __name__ == "__main__":
    fl_thermal()
    twin(sys.argv[1] if len(sys.argv) > 1 else str(realrun.ROOT / "target/release/thermcomp"))
