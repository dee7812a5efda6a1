#!/usr/bin/env python3
"""Independent lumped-parameter thermal / thermo-elastic plant of a vertical
machining centre (motorised spindle on a column), logged over ONE ~46 h run.
Written apart from thermcomp's thermal twin, from textbook physics, by an
author who read none of thermcomp's source, so that `fit --model auto` can be
judged on a one-run plant its designers did not make
(scripts/auto_long_run.py, docs/fit.md "One long run we did not make").

Thermal model (17 nodes, room air is the boundary):
  FB front bearing, RB rear bearing, SH spindle shaft, MOT motor stator,
  HF/HR spindle housing front/rear, HS headstock, HST Z-carriage (guides),
  CF/CR column front/rear wall, CS column side (Z drive side), CT column top,
  BED base, OIL cooling-jacket oil, TANK oil tank with chiller,
  NUT Z ballscrew nut/screw, FIX probe fixture on the table.
  C dT/dt = -K T + diag(g_air(n)) (T_room - T) + q(T, n, t)
  K: conductive links, g_air: convection (shaft/nose and front housing get
  speed-dependent forced convection).  Integrated with an exact zero-order
  hold (symmetric eigendecomposition of C^-1/2 (K+G) C^-1/2, one transition
  matrix per speed level) at 5 s sub-steps; heat inputs are held per sub-step.
Heat sources: bearing friction P ~ n^e (e in 1.2..1.8) x (1 + gamma*max(0,
  T_shaft - T_housing)) (thermal preload) x mild viscosity fall with heat;
  motor idle + speed-dependent losses (rotor part to shaft, rest to stator,
  which sits in the oil jacket); pump heat into the tank; chiller = PI
  controller with actuator lag removing heat from the tank, setpoint fixed
  or room-tracking (seed).  Room: day/night cycle (1-3 K p-p), OU random walk,
  HVAC triangle ripple.
Sensors (16): weighted mixes of 1-2 nodes (some sit between nodes), one
  near-room air sensor and one on the bed; first-order lag 10-120 s,
  calibration offset, white noise, 0.01 K quantisation.
Displacements (um), relative to the state at t=0 (probes zeroed), plus a
  small zeroing offset and probe noise 0.1-0.3 um, 0.01 um quantisation:
  ch1/ch2 Y at the test-bar tip / near the nose: column bending from
  (CF-CR) (delta = a dT H^2/2D, slope a dT H/D), headstock overhang growth,
  headstock pitch (HS-HST);  ch3 Z: shaft + housing + headstock + carriage +
  screw growth toward the table minus column height growth, fixture growth;
  ch4/ch5 X at two heights: side bending from CS - (CF+CR)/2, head roll,
  small projection of axial growth.  Centrifugal/gyroscopic term ~ (n/ntop)^2
  is immediate (ch3: -1..-3 um at top speed).
Speed programme: constant blocks 20 min..3 h, stops between some blocks,
  levels {1,2,3,4,6}/6 * ntop (ntop 8000..20000 rpm by seed).
Variants:
  a cold start; second-half (t >= 24 h) blocks use only first-half levels.
  b cold start; first half limited to 4/6 ntop, second half adds a level
    1.3-1.5x above the first-half maximum (speed extrapolation).
  c as a, but warm start (4-8 h pre-run + short pause before t=0, probes
    zeroed at t=0), larger sensor noise, one sensor drifts 0.2-0.4 K.
  d as b plus hidden heat: Z-axis ballscrew/drive heat with a part-programme
    duty cycle in some blocks (mainly ch3, ch4/ch5), and for even seeds a
    chiller setpoint step at 28-36 h.  Neither appears in any column.
Usage: python3 mill_long_run.py --seed S --variant a --out run.csv
"""
import argparse
import json
import numpy as np

DT_ROW, SUB = 15.0, 3
DT = DT_ROW / SUB
N_ROWS = 11100
DAY = 86400.0
NAMES = ["FB", "RB", "SH", "MOT", "HF", "HR", "HS", "HST", "CF", "CR", "CS",
         "CT", "BED", "OIL", "TANK", "NUT", "FIX"]
I = {k: i for i, k in enumerate(NAMES)}
NN = len(NAMES)
ROOM = NN  # index of room air in the extended state used for sensor mixing


def jit(rng, lo=0.8, hi=1.25):
    return rng.uniform(lo, hi)


def build_machine(rng):
    """Seed-chosen machine: capacities, links, gains, geometry."""
    C0 = dict(FB=1500, RB=1200, SH=4000, MOT=8000, HF=9000, HR=8000, HS=60000,
              HST=40000, CF=180000, CR=180000, CS=90000, CT=70000, BED=9e5,
              OIL=12000, TANK=80000, NUT=2500, FIX=3000)
    C = np.array([C0[k] * jit(rng) for k in NAMES])
    links = [("FB", "SH", 10), ("FB", "HF", 15), ("RB", "SH", 8), ("RB", "HR", 10),
             ("MOT", "SH", 1.5), ("MOT", "HR", 3), ("MOT", "OIL", 40),
             ("HF", "OIL", 10), ("HR", "OIL", 8), ("HF", "HR", 2), ("HF", "HS", 5),
             ("HR", "HS", 4), ("HS", "HST", 6), ("HST", "CF", 4), ("HS", "CF", 3),
             ("CF", "CR", 5), ("CF", "CS", 4), ("CR", "CS", 4), ("CF", "CT", 4),
             ("CR", "CT", 4), ("CS", "CT", 3), ("CF", "BED", 6), ("CR", "BED", 6),
             ("CS", "BED", 3), ("OIL", "TANK", 150), ("NUT", "CS", 2.5),
             ("NUT", "HST", 1.2), ("FIX", "BED", 1.0)]
    K = np.zeros((NN, NN))
    for a, b, g in links:
        g *= jit(rng, 0.7, 1.4)
        i, j = I[a], I[b]
        K[i, i] += g; K[j, j] += g; K[i, j] -= g; K[j, i] -= g
    g0 = dict(FB=.3, RB=.2, SH=.6, MOT=.5, HF=1.5, HR=1.2, HS=4, HST=3, CF=7,
              CR=7, CS=4, CT=5, BED=20, OIL=.5, TANK=4, NUT=.6, FIX=1.5)
    gair = np.array([g0[k] * jit(rng, 0.7, 1.4) for k in NAMES])
    p = dict(C=C, K=K, gair=gair)
    p["ntop"] = float(rng.choice([8000, 10000, 12000, 15000, 18000, 20000]))
    p["Pfb"], p["rb_ratio"] = rng.uniform(90, 180), rng.uniform(0.45, 0.7)
    p["eb"], p["gam"] = rng.uniform(1.2, 1.8), rng.uniform(0.02, 0.05)
    p["visc"] = rng.uniform(0.004, 0.01)
    p["Pidle"], p["Pm"] = rng.uniform(30, 80), rng.uniform(250, 550)
    p["rotor"] = rng.uniform(0.1, 0.2)
    p["Ppump"] = rng.uniform(40, 100)
    p["conv_sh"], p["conv_hf"] = rng.uniform(2.0, 4.0), rng.uniform(0.2, 0.5)
    # chiller
    p["Kp"], p["Ti"] = rng.uniform(200, 400), rng.uniform(600, 1800)
    p["tau_ch"], p["Pmax"] = rng.uniform(60, 300), rng.uniform(1500, 2500)
    p["track"] = bool(rng.random() < 0.5)
    p["sp_off"] = rng.uniform(-0.4, 0.4)
    # hidden axis drive heat (variant d)
    p["Pax"] = rng.uniform(20, 50)
    # centrifugal / gyroscopic (um at ntop)
    p["c_cf"] = rng.uniform(1.0, 3.0)
    p["g_y"], p["g_x"] = rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3)
    return p


def displacement_matrix(rng):
    """J (5 x NN) in um/K: thermo-elastic relations with seed geometry (mm)."""
    a_s, a_c = 11.5e-3, 10.5e-3          # um per (mm K)
    Ls, Lhf, Lhs, Lhst = rng.uniform(120, 200), rng.uniform(60, 140), \
        rng.uniform(150, 300), rng.uniform(80, 200)
    Hc, Lscr, Hfix = rng.uniform(700, 1100), rng.uniform(250, 600), rng.uniform(80, 200)
    H, D, W = rng.uniform(600, 900), rng.uniform(400, 600), rng.uniform(500, 750)
    Loh, kh = rng.uniform(300, 450), rng.uniform(0.3, 0.8)
    z1 = rng.uniform(300, 450)            # pivot to tip probe
    z2 = z1 - rng.uniform(80, 150)        # pivot to nose-side probe
    kroll, eps = rng.choice([-1, 1]) * rng.uniform(0.3, 0.8), rng.uniform(-0.08, 0.08, 2)
    J = np.zeros((5, NN))
    # Z (ch3): + toward table
    J[2, I["SH"]] += a_s * Ls
    J[2, I["HF"]] += a_s * Lhf
    J[2, I["HS"]] += a_c * Lhs
    J[2, I["HST"]] += a_c * Lhst
    for k, w in (("CF", .3), ("CR", .3), ("CS", .2), ("CT", .2)):
        J[2, I[k]] -= a_c * Hc * w
    J[2, I["NUT"]] += a_s * Lscr * 0.5
    J[2, I["CS"]] += a_s * Lscr * 0.5    # screw body follows column side
    J[2, I["FIX"]] -= a_s * Hfix
    for r, z in ((0, z1), (1, z2)):
        # Y: column bending from front/rear difference, overhang, head pitch
        bend = a_c * (H * H / (2 * D) + H * z / D)
        J[r, I["CF"]] -= bend; J[r, I["CR"]] += bend
        J[r, I["HS"]] += a_c * Loh * 0.7
        J[r, I["HST"]] += a_c * Loh * 0.3
        J[r, I["HS"]] -= a_c * kh * z; J[r, I["HST"]] += a_c * kh * z
        J[r, I["FIX"]] -= a_s * 40
        # X (ch4, ch5): side bending, head roll, projected axial growth
        x = r + 3
        sb = a_c * (H * H / (2 * W) + H * z / W)
        J[x, I["CS"]] += sb; J[x, I["CF"]] -= sb / 2; J[x, I["CR"]] -= sb / 2
        J[x, I["HS"]] += a_c * kroll * z; J[x, I["HST"]] -= a_c * kroll * z
        J[x, I["SH"]] += eps[r] * a_s * Ls
        J[x, I["FIX"]] += a_s * 30
    return J


def speed_programme(rng, variant, ntop, t_end, t_pre):
    """List of (t0, t1, rpm) blocks covering [-t_pre, t_end]."""
    rnd = lambda v: float(np.round(v / 100.0) * 100)
    levels = [rnd(f * ntop / 6) for f in (1, 2, 3, 4, 6)]
    if variant in "bd":
        first = levels[:4]
        extrap = rnd(levels[3] * rng.uniform(1.3, 1.5))
        second = first + [extrap, extrap]
    else:
        first, second = levels, levels
    durs = np.array([20, 30, 45, 60, 75, 90, 120, 150, 180]) * 60.0
    blocks, deck = [], []
    t = -t_pre
    if t_pre > 0:                         # earlier work, then a short pause
        while t < -t_pre + rng.uniform(4, 8) * 3600:
            d = rng.choice(durs)
            blocks.append((t, t + d, float(rng.choice(levels[:4])))); t += d
        blocks.append((t, 0.0, 0.0)); t = 0.0
    if rng.random() < 0.5:
        blocks.append((0.0, 1200.0, 0.0)); t = 1200.0
    prev, half = 0.0, 0
    while t < t_end:
        h = 1 if t >= DAY else 0
        if h != half:
            deck, half = [], h
        if prev > 0 and rng.random() < 0.4:
            d, s = rng.choice(durs), 0.0
        else:
            if not deck:
                deck = list(rng.permutation(second if h else first))
            d, s = rng.choice(durs), float(deck.pop())
        blocks.append((t, t + d, s)); t += d; prev = s
    return blocks


def room_temperature(rng, t):
    T0 = rng.uniform(19.5, 22.5)
    A, ph, ph2 = rng.uniform(0.5, 1.5), rng.uniform(0, 2 * np.pi), rng.uniform(0, 2 * np.pi)
    w = 2 * np.pi / DAY
    day = A * (np.sin(w * t + ph) + 0.25 * np.sin(2 * w * t + ph2)) / 1.1
    tc = np.arange(t[0], t[-1] + 120.0, 60.0)       # OU walk on 60 s grid
    tau, sig = rng.uniform(4, 8) * 3600, rng.uniform(0.15, 0.35)
    a = np.exp(-60.0 / tau)
    e = rng.standard_normal(tc.size) * sig * np.sqrt(1 - a * a)
    ou = np.empty(tc.size); ou[0] = rng.normal(0, sig)
    for k in range(1, tc.size):
        ou[k] = a * ou[k - 1] + e[k]
    ou = np.interp(t, tc, ou)
    P, amp = rng.uniform(900, 2400), rng.uniform(0.05, 0.15)
    hv = amp * (2 * np.abs(2 * (((t / P) + 0.3 * np.sin(t / 7200.0)) % 1.0) - 1) - 1)
    return T0 + day + ou + hv


def zoh(C, Kt, dt):
    """Exact ZOH for C dx/dt = -Kt x + u: x+ = Phi x + Gam u."""
    ci = 1.0 / np.sqrt(C)
    S = ci[:, None] * Kt * ci[None, :]
    lam, V = np.linalg.eigh(0.5 * (S + S.T))
    Phi = (ci[:, None] * V) @ np.diag(np.exp(-lam * dt)) @ (V.T / ci[None, :])
    Gam = (ci[:, None] * V) @ np.diag((1 - np.exp(-lam * dt)) / lam) @ (V.T * ci[None, :])
    return Phi, Gam


def simulate(p, rpm, troom, t, hidden, sp_step):
    nr_levels = np.unique(rpm)
    mats, gairs = {}, {}
    for n in nr_levels:
        f = (n / p["ntop"]) ** 0.8
        g = p["gair"].copy()
        g[I["SH"]] *= 1 + p["conv_sh"] * f
        g[I["FB"]] *= 1 + p["conv_sh"] * 0.3 * f
        g[I["HF"]] *= 1 + p["conv_hf"] * f
        mats[n], gairs[n] = zoh(p["C"], p["K"] + np.diag(g), DT), g
    x = np.full(NN, troom[0])
    X = np.empty((t.size, NN))
    Pch = integ = p["Ppump"]
    lp = troom[0]
    a_lp, a_ch = np.exp(-DT / 1800.0), 1 - np.exp(-DT / p["tau_ch"])
    fb, rb, sh, hf, hr = I["FB"], I["RB"], I["SH"], I["HF"], I["HR"]
    for k in range(t.size):
        X[k] = x
        n = rpm[k]
        q = np.zeros(NN)
        if n > 0:
            r = n / p["ntop"]
            fr = r ** p["eb"]
            visc = max(0.7, 1 - p["visc"] * (x[fb] - 20.0))
            q[fb] = p["Pfb"] * fr * (1 + p["gam"] * max(0.0, x[sh] - x[hf])) * visc
            q[rb] = p["Pfb"] * p["rb_ratio"] * fr * \
                (1 + p["gam"] * max(0.0, x[sh] - x[hr])) * visc
            pm = p["Pidle"] + p["Pm"] * (0.5 * r ** 1.5 + 0.5 * r ** 2)
            q[sh] += p["rotor"] * pm
            q[I["MOT"]] += (1 - p["rotor"]) * pm
        q[I["TANK"]] += p["Ppump"] - Pch
        if hidden[k] > 0:
            q[I["NUT"]] += 0.75 * p["Pax"] * hidden[k]
            q[I["CT"]] += 0.25 * p["Pax"] * hidden[k]   # support bearing + Z motor
        Phi, Gam = mats[n]
        x = Phi @ x + Gam @ (q + gairs[n] * troom[k])
        # chiller: PI on tank temperature with actuator lag
        lp = a_lp * lp + (1 - a_lp) * troom[k]
        tset = (lp if p["track"] else troom[0]) + p["sp_off"] + sp_step[k]
        e = x[I["TANK"]] - tset
        integ = min(max(integ + p["Kp"] / p["Ti"] * e * DT, 0.0), p["Pmax"])
        Pch += (min(max(p["Kp"] * e + integ, 0.0), p["Pmax"]) - Pch) * a_ch
    return X


def sensor_sites(rng, variant):
    S = dict(FB={"FB": 1}, RB={"RB": 1}, MOT={"MOT": 1}, HF_FB={"HF": .7, "FB": .3},
             HF={"HF": 1}, HR={"HR": .8, "RB": .2}, HS={"HS": 1},
             HS_F={"HS": .6, "HF": .4}, HST={"HST": 1}, CF_up={"CF": .6, "CT": .4},
             CF_lo={"CF": .7, "BED": .3}, CR_up={"CR": .6, "CT": .4},
             CR_lo={"CR": .7, "BED": .3}, CS={"CS": 1}, CT={"CT": 1}, BED={"BED": 1},
             AIR={"ROOM": .85, "CF": .15}, OIL={"OIL": 1}, TANK={"TANK": 1},
             FIX={"FIX": .5, "BED": .5}, CS_NUT={"CS": .8, "NUT": .2})
    must = ["FB", "HF_FB", "HS", "CF_up", "CR_up", "BED", "AIR", "MOT"]
    rest = [k for k in S if k not in must and k != "CS_NUT"]  # nut never sensed
    pick = must + list(rng.choice(rest, 16 - len(must), replace=False))
    pick = list(rng.permutation(pick))
    Wm = np.zeros((16, NN + 1))
    for s, name in enumerate(pick):
        for node, w in S[name].items():
            if len(S[name]) > 1:
                w = float(np.clip(w + rng.uniform(-0.1, 0.1), 0.05, 0.95))
            Wm[s, ROOM if node == "ROOM" else I[node]] = w
        Wm[s] /= Wm[s].sum()
    return pick, Wm


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--variant", choices=list("abcd"), required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    v = a.variant
    rng = np.random.default_rng([a.seed, 7919])   # machine depends on seed only
    p = build_machine(rng)
    J = displacement_matrix(rng)
    rv = np.random.default_rng([a.seed, ord(v), 104729])  # run-specific draws
    t_end = (N_ROWS - 1) * DT_ROW
    t_pre = 0.0
    if v == "c":
        t_pre = float(np.round(rv.uniform(5, 9) * 3600 / DT_ROW) * DT_ROW)
    t = np.arange(-t_pre, t_end + DT / 2, DT)
    blocks = speed_programme(rv, v, p["ntop"], t_end, t_pre)
    rpm = np.zeros(t.size)
    for b0, b1, s in blocks:
        rpm[(t >= b0 - 1e-6) & (t < b1 - 1e-6)] = s
    troom = room_temperature(rv, t)
    hidden, sp_step = np.zeros(t.size), np.zeros(t.size)
    if v == "d":
        for b0, b1, s in blocks:               # part programme with axis moves
            if s > 0 and rv.random() < (0.5 if b0 >= DAY else 0.3):
                duty = rv.uniform(0.4, 1.0)
                per = rv.uniform(120, 600)
                m = (t >= b0) & (t < b1)
                hidden[m] = (((t[m] - b0) % per) < duty * per) * 1.0
        if a.seed % 2 == 0:
            sp_step[t >= rv.uniform(28, 36) * 3600] = rv.choice([-1, 1]) * rv.uniform(0.8, 1.5)
    X = simulate(p, rpm, troom, t, hidden, sp_step)
    i0 = int(round(t_pre / DT))
    rows = np.arange(i0, t.size, SUB)[:N_ROWS]
    # sensors: mix, first-order lag (exact per sub-step), offset, noise, quant.
    names, Wm = sensor_sites(rng, v)
    Xe = np.column_stack([X, troom])
    raw = Xe @ Wm.T
    tau = np.array([rng.uniform(30, 120) if nm == "AIR" else rng.uniform(10, 60) for nm in names])
    al = np.exp(-DT / tau)
    y = np.empty_like(raw); y[0] = raw[0]
    for k in range(1, raw.shape[0]):
        y[k] = al * y[k - 1] + (1 - al) * raw[k]
    T = y[rows] + rng.uniform(-0.1, 0.1, 16)
    sig = rv.uniform(0.04, 0.07, 16) if v == "c" else rv.uniform(0.01, 0.03, 16)
    T = T + rv.standard_normal(T.shape) * sig
    ts = t[rows]
    if v == "c":
        s = int(rv.choice([i for i, nm in enumerate(names) if nm != "AIR"]))
        T[:, s] += rv.choice([-1, 1]) * rv.uniform(0.2, 0.4) * (ts / ts[-1]) ** rv.uniform(0.7, 1.5)
    T = np.round(T, 2)
    # displacements relative to t=0 state, centrifugal term, noise
    Xr = X[rows]
    d = (Xr - Xr[0]) @ J.T
    r2 = (rpm[rows] / p["ntop"]) ** 2
    d[:, 2] -= p["c_cf"] * r2
    d[:, 0] += p["g_y"] * r2; d[:, 1] += 0.7 * p["g_y"] * r2
    d[:, 3] += p["g_x"] * r2; d[:, 4] += 0.7 * p["g_x"] * r2
    d += rv.normal(0, 0.1, 5) + rv.standard_normal(d.shape) * rng.uniform(0.1, 0.3, 5)
    d = np.round(d, 2)
    out = np.column_stack([np.round(ts), rpm[rows], d, T])
    hdr = "t_s,speed_rpm," + ",".join(f"ch{i}_um" for i in range(1, 6)) + "," + \
        ",".join(f"T{i}" for i in range(1, 17))
    np.savetxt(a.out, out, delimiter=",", header=hdr, comments="",
               fmt=["%d", "%d"] + ["%.2f"] * 21)
    summ = dict(seed=a.seed, variant=v, rows=int(out.shape[0]),
                ch_min_max_um={f"ch{i+1}": [float(d[:, i].min()), float(d[:, i].max())]
                               for i in range(5)},
                T_swing_K={f"T{i+1}": round(float(np.ptp(T[:, i])), 2) for i in range(16)})
    print(json.dumps(summ))


if __name__ == "__main__":
    main()
