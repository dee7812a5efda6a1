#!/usr/bin/env python3
"""A synthetic spindle run with a known answer (no thermal twin involved).

Writes examples/synthetic_spindle.csv: 36 h at 30 s of a motorised spindle
whose temperatures and displacement come from stated first-order physics, so
a trainer's choices can be checked against the truth:

- speed: a staircase 0/3000/6000/9000/4500/0 rpm, then an ISO 230-3-like
  spectrum changing every 45 min, then cool-down;
- heat: bearing losses ~ speed^1.5, motor losses ~ speed^2;
- sensors (deg C): T1 front bearing (tau 25 min), T2 rear bearing (40 min),
  T3 motor (15 min), T4 housing (90 min, driven by T1 and T3), T5 column
  (4 h, driven by T4 and ambient), T6 ambient (day/night sine + slow drift),
  T7 coolant return (chiller cycling, 30 min period), T8 a sensor on an
  unrelated part (random walk);
- dz_um = -(3.2 um/K * lag(T1, 20 min) + 1.8 um/K * T4 + 0.9 um/K * T5
  - 2.5 um/K * lag(T6, 2 h)) changes + noise: the spindle grows toward the
  workpiece (negative z), the column tilts the head back with ambient;
- dx_um: a tilt term 0.6 um/K * (T2 - T1) lagged 30 min, plus noise.
Sensor noise 0.02 C, displacement noise 0.3 um. Seed fixed: the file is
reproducible. Run by hand; the output is committed.
"""
import pathlib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
DT = 30.0
HOURS = 36.0


def lag(u, tau_s):
    """Exact discretisation of a first-order lag with unit gain, zero start."""
    a = np.exp(-DT / tau_s)
    y = np.zeros_like(u)
    for k in range(1, len(u)):
        y[k] = a * y[k - 1] + (1 - a) * u[k - 1]
    return y


def main():
    rng = np.random.default_rng(20261121)
    t = np.arange(0.0, HOURS * 3600 + DT / 2, DT)
    h = t / 3600
    speed = np.zeros_like(t)
    stair = [0, 3000, 6000, 9000, 4500, 0]
    for i, s in enumerate(stair):
        speed[(h >= 2 * i) & (h < 2 * (i + 1))] = s
    spectrum = rng.choice([1000, 2500, 4000, 6000, 8000, 10000], size=40)
    for i, s in enumerate(spectrum):
        lo = 12 + 0.75 * i
        speed[(h >= lo) & (h < lo + 0.75) & (h < 30)] = s
    speed[h >= 30] = 0
    s = speed / 10000
    bearing = 9.0 * s**1.5
    motor = 7.0 * s**2
    ambient = 21.0 + 1.2 * np.sin(2 * np.pi * (h - 8) / 24) + 0.04 * h
    chiller = 0.35 * np.sign(np.sin(2 * np.pi * h / 0.5))
    t1 = ambient + lag(bearing, 25 * 60)
    t2 = ambient + lag(0.7 * bearing, 40 * 60)
    t3 = ambient + lag(motor, 15 * 60) + 0.3 * lag(chiller, 300)
    t4 = ambient + lag(0.5 * (t1 - ambient) + 0.4 * (t3 - ambient), 90 * 60)
    t5 = lag(ambient + 0.3 * (t4 - ambient) - 21.0, 4 * 3600) + 21.0
    t6 = ambient
    t7 = 20.0 + chiller + 0.2 * lag(motor, 600)
    t8 = 23.0 + np.cumsum(rng.normal(0, 0.01, len(t)))
    temps = [t1, t2, t3, t4, t5, t6, t7, t8]
    d = lambda x: x - x[0]
    dz = -(3.2 * lag(d(t1), 20 * 60) + 1.8 * d(t4) + 0.9 * d(t5) - 2.5 * lag(d(t6), 2 * 3600))
    dx = 0.6 * lag(d(t2) - d(t1), 30 * 60)
    noisy = [x + rng.normal(0, 0.02, len(t)) for x in temps]
    dz = dz + rng.normal(0, 0.3, len(t))
    dx = dx + rng.normal(0, 0.3, len(t))
    cols = [t, speed] + noisy + [dx, dz]
    names = ["t_s", "speed_rpm"] + [f"T{i}" for i in range(1, 9)] + ["dx_um", "dz_um"]
    out = ROOT / "examples" / "synthetic_spindle.csv"
    with open(out, "w") as f:
        f.write(",".join(names) + "\n")
        for row in zip(*cols):
            f.write(f"{row[0]:.0f},{row[1]:.0f}," + ",".join(f"{v:.4f}" for v in row[2:]) + "\n")
    print(f"wrote {out.relative_to(ROOT)} ({len(t)} rows)")


if __name__ == "__main__":
    main()
