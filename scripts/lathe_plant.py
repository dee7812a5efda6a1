#!/usr/bin/env python3
"""A lumped-parameter thermal simulator of a CNC lathe (numpy only), built
apart from thermcomp's thermal twin: written from textbook physics by an
author who did not read thermcomp's source, so that `fit --model auto` can
be judged on a plant its designers did not make (scripts/auto_lathe_split.py,
docs/fit.md "When the room moves").

Usage: python3 scripts/lathe_plant.py --seed S --variant {a,b,c,d} --out DIR

Variants (the protocol of issue 12's second real machine: three
calibration runs at a constant room, two scored runs whose room moves):
  a  every calibration room at 20 C, no HVAC ripple, no sampling jitter
  b  calibration rooms at about 17, 20 and 24 C, HVAC ripple 0.1 K
  c  as b, plus runs started warm from earlier work, sampling jitter, a
     room-side sensor at 0.1 K resolution, sun on the room runs
  d  as c, plus a sensor drifting 0.3 K over a run, 0.5 um displacement
     noise and X-screw heat from a hidden part-programme duty
The seed chooses the machine (time constants, couplings, gains), so seeds
are different machines with the same variant semantics.

Writes DIR/cal1.csv cal2.csv cal3.csv room1.csv room2.csv with columns
t_s, speed_rpm, T1..T24, dx_um, dz_um and prints a one-line JSON summary.

Model (own design, built from textbook physics):
  12 structural thermal nodes, each with heat capacity C_i, conductive links
  G_ij to neighbours and convective links to the ambient air at machine height
  (air_mid) or to the cooler, slower air layer near the floor (air_floor).
      C_i dT_i/dt = sum_j G_ij (T_j - T_i) + Ga_i (T_air_i - T_i) + Q_i(t)
  Integrated with an exact zero-order-hold discretisation (dt = 10 s);
  the state-dependent bearing heat is evaluated at the previous step.
  Heat: spindle bearings ~ rpm^1.3 (with thermally induced preload gain),
  motor ~ idle + rpm^1.1, X/Z ball screws ~ axis duty (hidden), hydraulic
  unit constant while powered, sun load (variants c/d, room runs).
  Displacements are formed from node temperatures relative to a 20 C
  assembly reference (with a small temperature dependence of the expansion
  coefficient and a small quadratic bearing term), then zeroed at row 1.
"""
import argparse
import json
import os
import sys

import numpy as np

DT = 10.0          # internal integration step [s]
TREF = 20.0        # assembly reference temperature [C]
H = 3600.0
MIN = 60.0

NODE_NAMES = ["spindle_front", "spindle_rear", "headstock", "motor",
              "x_screw", "cross_slide", "z_screw", "carriage",
              "bed_top", "bed_base", "hydraulic", "bed_right_tailstock"]
N = len(NODE_NAMES)


# ----------------------------------------------------------------- machine
def make_machine(rng, variant):
    u = lambda lo, hi: float(rng.uniform(lo, hi))
    m = {}
    # nominal local time constants [s]  (C_i = tau_i * sum of conductances)
    tau = np.array([u(8, 15), u(12, 22), u(40, 90), u(20, 40), u(15, 30),
                    u(40, 80), u(20, 40), u(60, 120), u(120, 240),
                    u(240, 480), u(30, 60), u(90, 180)]) * MIN
    links = [(0, 1, 2), (0, 2, 10), (1, 2, 8), (1, 3, 2), (3, 2, 4),
             (2, 8, 15), (4, 5, 4), (5, 7, 10), (4, 7, 2), (6, 7, 3),
             (6, 8, 3), (7, 8, 8), (8, 9, 30), (8, 11, 10), (9, 11, 8),
             (10, 9, 3), (10, 2, 3), (10, 5, 2)]
    Gm = np.zeros((N, N))
    for i, j, g in links:
        g = g * u(0.7, 1.3)
        Gm[i, j] += g
        Gm[j, i] += g
    ga_mid = np.array([1.5, 1.0, 12, 8, 1.0, 4, 1.0, 4, 15, 0, 2, 4]) * \
        rng.uniform(0.7, 1.3, N)
    ga_flo = np.array([0, 0, 0, 0, 0, 0, 0, 0, 0, 12, 6, 3]) * \
        rng.uniform(0.7, 1.3, N)
    gsum = Gm.sum(1) + ga_mid + ga_flo
    C = tau * gsum
    L = np.diag(gsum) - Gm
    A = -L / C[:, None]
    B = np.zeros((N, 2 + N))
    B[:, 0] = ga_mid / C
    B[:, 1] = ga_flo / C
    B[:, 2:] = np.diag(1.0 / C)
    # exact ZOH discretisation via similarity to a symmetric matrix
    Ch = np.sqrt(C)
    S = -L / np.outer(Ch, Ch)
    w, V = np.linalg.eigh(S)
    Ad = (V * np.exp(w * DT)) @ V.T
    Ad = Ad / Ch[:, None] * Ch[None, :]
    Ainv = np.linalg.inv(A)
    Bd = Ainv @ (Ad - np.eye(N)) @ B
    m.update(A=A, B=B, Ad=Ad, Bd=Bd, C=C, slow_tau_h=float(-1 / w.max() / H))

    # heat sources
    m["k_bear"] = u(10, 22)          # W per (krpm)^1.3, front bearing
    m["rear_frac"] = u(0.4, 0.6)
    m["gamma"] = u(0.01, 0.03)       # preload gain per K (front-housing diff)
    m["mot_idle"] = u(15, 35)
    m["k_mot"] = u(10, 25)
    m["q_hyd"] = u(50, 120)
    m["k_xs"] = u(25, 60)
    m["k_zs"] = u(35, 80)
    m["tau_floor"] = u(45, 100) * MIN
    m["floor_off"] = -u(0.3, 0.9)
    m["rpm_max"] = 4000.0

    # displacement coefficients [um/K]
    m["dz"] = dict(sp=u(1.6, 2.8), sp_rear=u(0.2, 0.6), hs=u(1.5, 3.0),
                   zs=u(2.5, 4.5), mean=u(1.0, 2.5), beta=u(0.01, 0.025),
                   tilt=u(1.0, 3.0), car=u(0.4, 1.0))
    m["dx"] = dict(hs_tilt=u(1.5, 3.5), xs=u(1.8, 3.5), sl=u(0.8, 2.0),
                   bend=u(3.0, 7.0), side=u(1.0, 3.0), sp=u(0.3, 0.8),
                   nl=u(0.02, 0.05), prod=u(0.05, 0.15))
    return m


def displacement(m, T):
    """T: (n, N) node temperatures -> dx, dz (um, absolute, not zeroed)."""
    d = {k: T[:, i] - TREF for i, k in enumerate(
        ["sf", "sr", "hs", "mo", "xs", "sl", "zs", "ca", "bt", "bb", "hy", "br"])}
    cz, cx = m["dz"], m["dx"]
    # mean structural temperature (headstock, bed, base) vs assembly ref;
    # expansion coefficient grows slightly with absolute temperature
    tm = 0.3 * d["hs"] + 0.45 * d["bt"] + 0.25 * d["bb"]
    beta = cz["beta"]
    nlin = lambda x: x * (1.0 + 0.5 * beta * x)
    dz = (cz["sp"] * nlin(d["sf"]) + cz["sp_rear"] * d["sr"]
          + cz["hs"] * nlin(d["hs"])
          - cz["zs"] * nlin(d["zs"])
          + cz["mean"] * nlin(tm)
          - cz["car"] * d["ca"]
          + cz["tilt"] * (d["bt"] - d["bb"]))           # bed bow -> Z shift
    dx = (-cx["hs_tilt"] * (d["hs"] - d["bt"])            # headstock tilt
          + cx["sp"] * d["sf"]
          + cx["xs"] * nlin(d["xs"])                      # X screw growth
          + cx["sl"] * d["sl"]                            # cross slide / turret
          - cx["bend"] * (d["bt"] - d["bb"])              # bed bending
          + cx["side"] * (d["br"] - d["bt"])              # uneven (sun) side
          + cx["nl"] * (d["sf"] - d["hs"]) ** 2           # bearing preload
          + cx["prod"] * d["hs"] * (d["bt"] - d["bb"]))   # product term
    return dx, dz


# ----------------------------------------------------------------- sensors
def make_sensors(rng, variant):
    # (weights {node or 'air'/'floor': w}, lag_s, noise, quant, offset)
    s = [
        ({0: .8, 2: .2}, 60), ({0: .75, 2: .25}, 90), ({1: 1}, 90),
        ({2: .9, "air": .1}, 120), ({2: 1}, 400), ({3: 1}, 120),
        ({3: .6, 2: .4}, 150), ({4: .7, 5: .3}, 90), ({4: 1}, 60),
        ({5: 1}, 200), ({5: .8, "air": .2}, 90), ({6: .6, 8: .4}, 150),
        ({7: .5, 6: .5}, 120), ({7: 1}, 300), ({8: 1}, 300),
        ({8: .9, 2: .1}, 400), ({9: 1}, 800), ({9: .6, "floor": .4}, 200),
        ({10: 1}, 120), ({10: .7, 5: .3}, 60), ({11: 1}, 300),
        ({"air": 1}, 40), ({"floor": 1}, 60), ({11: .7, "air": .3}, 60),
    ]
    W = np.zeros((24, N + 2))   # last two columns: air_mid, air_floor
    lag = np.zeros(24)
    for k, (wd, tl) in enumerate(s):
        for key, w in wd.items():
            col = N if key == "air" else N + 1 if key == "floor" else key
            W[k, col] = w
        lag[k] = tl * rng.uniform(0.7, 1.4)
    noise = rng.uniform(0.01, 0.05, 24)
    quant = np.zeros(24)
    for k in (5, 18, 21, 22):            # T6, T19, T22, T23: 1/16 K sensors
        quant[k] = 0.0625
    if variant in "cd":
        quant[17] = 0.1                  # T18: base/foot, sees mostly room
    offset = np.zeros(24)
    for k in rng.choice(24, 4, replace=False):
        offset[k] = rng.uniform(0.1, 0.3) * rng.choice([-1, 1])
    return dict(W=W, lag=lag, noise=noise, quant=quant, offset=offset,
                drift_idx=15, drift=0.3 * rng.choice([-1, 1]))


# ----------------------------------------------------------------- profiles
def speed_profile(rng, kind, tgrid, rpm_max):
    T = tgrid[-1]
    sp = np.zeros_like(tgrid)
    segs = []
    t = 0.0
    if kind == "stairs":
        t = rng.uniform(5, 15) * MIN
        for lvl in [1000, 2000, 3000, rpm_max]:
            d = rng.uniform(30, 60) * MIN
            segs.append((t, t + d, lvl)); t += d
        t += rng.uniform(45, 90) * MIN
        while t < T:
            d = rng.uniform(20, 90) * MIN
            lvl = 0 if rng.random() < 0.3 else rng.choice(np.arange(500, rpm_max + 1, 250))
            segs.append((t, t + d, lvl)); t += d
    elif kind in ("random", "random2"):
        while t < T:
            d = rng.uniform(20, 90) * MIN
            lvl = 0 if rng.random() < 0.25 else rng.choice(np.arange(500, rpm_max + 1, 250))
            segs.append((t, t + d, lvl)); t += d
    elif kind == "spectrum":
        while t < T:
            d = np.exp(rng.uniform(np.log(3), np.log(60))) * MIN
            lvl = 0 if rng.random() < 0.2 else round(rng.uniform(300, rpm_max), -2)
            segs.append((t, t + d, lvl)); t += d
    elif kind == "longhold":
        d = rng.uniform(15, 30) * MIN
        segs.append((0, d, 1000)); t = d
        d = rng.uniform(180, 240) * MIN
        segs.append((t, t + d, rng.uniform(3600, rpm_max) // 100 * 100)); t += d
        t += rng.uniform(45, 75) * MIN
        while t < T:
            d = rng.uniform(20, 60) * MIN
            segs.append((t, t + d, rng.choice([0, 1000, 1500, 2000, 2500]))); t += d
    for a, b, lvl in segs:
        sp[(tgrid >= a) & (tgrid < b)] = lvl
    if kind == "random":      # guarantee at least one hold at high speed
        if sp.max() < 0.7 * rpm_max:
            a = rng.uniform(0.1, 0.4) * T
            sp[(tgrid >= a) & (tgrid < a + 60 * MIN)] = rpm_max
    return sp


def ou(rng, n, tau, sd):
    a = np.exp(-DT / tau)
    e = rng.normal(0, sd * np.sqrt(1 - a * a), n)
    x = np.zeros(n)
    x[0] = rng.normal(0, sd)
    for k in range(1, n):
        x[k] = a * x[k - 1] + e[k]
    return x


def duties(rng, variant, sp, rpm_max):
    on = (sp > 0).astype(float)
    n = len(sp)
    # Z duty: hidden, correlated with spindle activity
    dz = np.clip(on * (0.35 + 0.2 * sp / rpm_max) + on * ou(rng, n, 20 * MIN, 0.12)
                 + 0.03, 0, 1)
    if variant == "d":
        # X duty: hidden part-program variable, only loosely tied to spindle
        seg = np.zeros(n)
        k = 0
        while k < n:
            L = int(rng.uniform(10, 60) * MIN / DT)
            seg[k:k + L] = rng.uniform(0, 0.8)
            k += L
        dx = np.clip(0.5 * seg + 0.25 * on + ou(rng, n, 15 * MIN, 0.1), 0, 1)
    else:
        dx = on * (0.3 + 0.3 * sp / rpm_max) + 0.03
    return dx, dz


def tri(t, period, amp, ph):
    x = ((t / period + ph) % 1.0)
    return amp * (4 * np.abs(x - 0.5) - 1)


def room_profile(rng, variant, kind, tgrid, level, hvac_amp, hvac_per):
    n = len(tgrid)
    air = np.full(n, level, dtype=float)
    dip_in = np.zeros(n)
    sun = np.zeros(n)
    rinfo = (0.0, 0.0, 0.0)
    if kind == "room":
        A = rng.uniform(1.0, 3.0)                     # half amplitude (2-6 K p-p)
        start_h = rng.uniform(-1, 3) if rng.random() < 0.6 else rng.uniform(10, 14)
        drift = rng.uniform(-0.2, 0.2)
        rinfo = (A, start_h, drift)
        air = level + room_base(tgrid, *rinfo) - room_base(np.zeros(1), *rinfo)[0]
        # door openings
        nd = rng.integers(1, 4)
        dip = np.zeros(n)
        events = []
        for _ in range(nd):
            td = rng.uniform(0.1, 0.9) * tgrid[-1]
            events.append((td, td + rng.uniform(2, 6) * MIN, rng.uniform(1, 2),
                           rng.uniform(20, 40) * MIN))
        d = 0.0
        for k, t in enumerate(tgrid):
            tgt, tau = 0.0, 30 * MIN
            for (a, b, D, tr) in events:
                if a <= t < b:
                    tgt, tau = -D * 1.3, 60.0
                    break
                if b <= t < b + 5 * tr:
                    tau = tr
            d += (tgt - d) * (1 - np.exp(-DT / tau))
            dip[k] = d
        air += dip
        dip_in = dip
        if variant in "cd":
            t0 = rng.uniform(0.1, 0.5) * tgrid[-1]
            dur = rng.uniform(2, 4) * H
            P = rng.uniform(40, 120)
            x = (tgrid - t0) / dur
            sun = np.where((x > 0) & (x < 1), P * np.sin(np.pi * np.clip(x, 0, 1)), 0.0)
    if hvac_amp > 0:
        air = air + tri(tgrid, hvac_per, hvac_amp, rng.random())
    return air, dip_in, sun, rinfo


def room_base(t, A, start_h, drift):
    """diurnal swing (24 h cosine, minimum at start_h = 0) plus slow drift"""
    return -A * np.cos(2 * np.pi * (t / H + start_h) / 24.0) + drift * t / H


# ----------------------------------------------------------------- simulate
def heat(m, sp, dux, duz, powered, sun, T):
    Q = np.zeros(N)
    kr = (sp / 1000.0) ** 1.3
    pre = 1.0 + m["gamma"] * max(T[0] - T[2], 0.0)
    Q[0] = m["k_bear"] * kr * pre
    Q[1] = m["k_bear"] * m["rear_frac"] * kr * (1.0 + m["gamma"] * max(T[1] - T[2], 0.0))
    Q[3] = powered * m["mot_idle"] + m["k_mot"] * (sp / 1000.0) ** 1.1
    Q[4] = m["k_xs"] * dux
    Q[6] = m["k_zs"] * duz
    Q[10] = powered * m["q_hyd"]
    Q[11] = 0.7 * sun
    Q[2] += 0.3 * sun
    return Q


def integrate(m, T0, floor0, air, dip, sp, dux, duz, powered, sun):
    n = len(air)
    X = np.empty((n, N))
    FL = np.empty(n)
    T = T0.copy()
    fl = floor0
    af = np.exp(-DT / m["tau_floor"])
    Ad, Bd = m["Ad"], m["Bd"]
    u = np.zeros(2 + N)
    for k in range(n):
        X[k] = T
        FL[k] = fl
        u[0] = air[k]
        u[1] = fl
        u[2:] = heat(m, sp[k], dux[k], duz[k], powered[k], sun[k], T)
        T = Ad @ T + Bd @ u
        fl = af * fl + (1 - af) * (air[k] + m["floor_off"] + 0.5 * dip[k])
    return X, FL


def equilibrium(m, air_level):
    fl = air_level + m["floor_off"]
    u = np.zeros(2 + N)
    u[0], u[1] = air_level, fl
    T = -np.linalg.solve(m["A"], m["B"] @ u)
    return T, fl


def simulate_run(rng, m, sens, variant, name, kind, dur, level, warm, hvac):
    tgrid = np.arange(0.0, dur + 2 * DT, DT)
    n = len(tgrid)
    air, dip, sun, rinfo = room_profile(rng, variant, "room" if name.startswith("room") else "cal",
                                 tgrid, level, *hvac)
    # initial state
    T0, fl0 = equilibrium(m, air[0])
    if name.startswith("room"):
        # the room was already moving before the run (machine off): 8 h history
        # of the same diurnal curve, no doors / sun
        tp = np.arange(-8 * H, 0.0, DT)
        hist = air[0] + (room_base(tp, *rinfo) - room_base(np.zeros(1), *rinfo)[0])
        Tp, fl0 = equilibrium(m, hist[0])
        z = np.zeros(len(tp))
        X, FL = integrate(m, Tp, fl0, hist, z, z, z, z, z, z)
        T0, fl0 = X[-1], FL[-1]
    if warm:
        # machine worked earlier that day, then was switched off for a while
        ton = rng.uniform(1, 2.5) * H
        tp = np.arange(0.0, ton + rng.uniform(45, 120) * MIN, DT)
        spp = np.where(tp < ton, rng.uniform(1500, 3000), 0.0)
        pw = (tp < ton + 10 * MIN).astype(float)
        dxp = np.where(tp < ton, 0.5, 0.0)
        z = np.zeros(len(tp))
        X, FL = integrate(m, T0, fl0, np.full(len(tp), air[0]), z, spp, dxp, dxp, pw, z)
        T0, fl0 = X[-1], FL[-1]
    warm_excess = float((T0 - air[0]).max())
    sp = speed_profile(rng, kind, tgrid, m["rpm_max"])
    dux, duz = duties(rng, variant, sp, m["rpm_max"])
    powered = np.ones(n)
    X, FL = integrate(m, T0, fl0, air, dip, sp, dux, duz, powered, sun)
    dxa, dza = displacement(m, X)

    # sensors on the fine grid (first-order lag)
    src = np.hstack([X, air[:, None], FL[:, None]])
    target = src @ sens["W"].T
    target[:, 23] += 0.012 * sun            # T24 surface sees the sun directly
    a = 1 - np.exp(-DT / sens["lag"])
    S = np.empty_like(target)
    s = target[0].copy()
    for k in range(n):
        s = s + a * (target[k] - s)
        S[k] = s

    # sample times
    nominal = np.arange(0.0, dur + 1e-9, 40.0)
    ts = nominal.copy()
    if variant in "cd":
        ts[1:] += rng.uniform(-1, 1, len(ts) - 1)
    ns = len(ts)
    Ts = np.column_stack([np.interp(ts, tgrid, S[:, j]) for j in range(24)])
    Ts += sens["offset"] + rng.normal(0, 1, (ns, 24)) * sens["noise"]
    if variant == "d":
        Ts[:, sens["drift_idx"]] += sens["drift"] * (ts / ts[-1]) ** 1.2
    q = sens["quant"]
    for j in np.nonzero(q)[0]:
        Ts[:, j] = np.round(Ts[:, j] / q[j]) * q[j]
    spd = sp[np.searchsorted(tgrid, ts, side="right") - 1]
    spd = np.where(spd > 0, spd * (1 + rng.normal(0, 0.001, ns)), 0.0)
    dn = {"a": 0.2, "b": 0.3, "c": 0.3, "d": 0.5}[variant]
    dxs = np.interp(ts, tgrid, dxa) + rng.normal(0, dn, ns)
    dzs = np.interp(ts, tgrid, dza) + rng.normal(0, dn, ns)
    dxs -= dxs[0]
    dzs -= dzs[0]
    data = np.column_stack([ts, spd, Ts, dxs, dzs])
    info = dict(warm_excess_K=round(warm_excess, 2), air_min=round(float(air.min()), 2),
                air_max=round(float(air.max()), 2))
    return data, info


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--variant", choices=list("abcd"), required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--verbose", action="store_true")
    args = ap.parse_args()
    v = args.variant
    # the machine depends on the seed only (same machine across variants)
    rng_m = np.random.default_rng([args.seed, 7])
    m = make_machine(rng_m, v)
    sens = make_sensors(rng_m, v)
    rng = np.random.default_rng([args.seed, ord(v)])

    if v == "a":
        levels = [20.0, 20.0, 20.0]
        hvac_amp = 0.0
    else:
        levels = [rng.uniform(16.5, 17.8), rng.uniform(19.5, 20.5), rng.uniform(23.2, 24.8)]
        levels = list(rng.permutation(levels))
        hvac_amp = 0.1 if v == "b" else rng.uniform(0.05, 0.2)
    hvac_per = rng.uniform(10, 30) * MIN
    warm = {k: False for k in ["cal1", "cal2", "cal3", "room1", "room2"]}
    if v in "cd":
        warm[str(rng.choice(["cal2", "cal3"]))] = True
        warm[str(rng.choice(["room1", "room2"]))] = True
        if v == "d" and rng.random() < 0.5:
            warm["cal1"] = True
    runs = [("cal1", "stairs", levels[0]), ("cal2", "random", levels[1]),
            ("cal3", "spectrum", levels[2]),
            ("room1", "random2", rng.uniform(18, 23)),
            ("room2", "longhold", rng.uniform(18, 23))]
    os.makedirs(args.out, exist_ok=True)
    header = ",".join(["t_s", "speed_rpm"] + ["T%d" % i for i in range(1, 25)]
                      + ["dx_um", "dz_um"])
    summary = dict(seed=args.seed, variant=v, files={})
    for name, kind, lvl in runs:
        dur = rng.uniform(6, 10) * H
        data, info = simulate_run(rng, m, sens, v, name, kind, dur, lvl, warm[name],
                                  (hvac_amp, hvac_per))
        path = os.path.join(args.out, name + ".csv")
        np.savetxt(path, data, fmt="%.4f", delimiter=",", header=header, comments="")
        rec = dict(rows=int(len(data)), dx_std=round(float(data[:, -2].std()), 3),
                   dz_std=round(float(data[:, -1].std()), 3))
        if args.verbose:
            rec.update(info, warm=warm[name],
                       dx_range=round(float(np.ptp(data[:, -2])), 2),
                       dz_range=round(float(np.ptp(data[:, -1])), 2), hours=round(dur / H, 2))
        summary["files"][name + ".csv"] = rec
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
