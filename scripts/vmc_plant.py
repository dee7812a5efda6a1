#!/usr/bin/env python3
"""A lumped-parameter thermal simulator of a vertical machining centre,
built apart from thermcomp's thermal twin and from scripts/lathe_plant.py:
written from physics by an author who read none of thermcomp's source, to
judge `fit --model auto` on a second plant its designers did not make
(scripts/auto_lathe_split.py --plant vmc; docs/fit.md "A plant we did not
build"). Four calibration runs, two scored runs, T1..T16, dx/dy/dz:
  a  calibration at a constant 20 C room, scored runs under a 3-6 K
     day-night swing with door openings; displacements zeroed at each start
  b  calibration rooms at 18/20/22/24 C; displacements not zeroed (against
     a fixed artefact, so a run starts at its thermal state's displacement)
  c  a shop: every run's room moves (HVAC ripple, drift, doors), warm and
     cold starts, coolant in some runs, a scored run faster than any
     calibration run; zeroed
  d  as c, not zeroed, 60 s sampling with a 5-20 min gap in one run

16 thermal nodes (2 of them unsensed: spindle shaft, Y screw), 3 boundaries
(air low, air high, spindle oil chiller).  Exact zero-order-hold discretisation
(dt = 10 s) of the linear network, heat sources re-evaluated every step
(bearing heat has a mild temperature-dependent preload term -> nonlinear).
Displacements are (mostly) linear in node temperatures relative to a 20 C
assembly, plus mild quadratic / speed terms and measurement noise.

usage: python3 scripts/vmc_plant.py --seed S --variant {a,b,c,d} --out DIR
"""
import argparse
import json
import os

import numpy as np

NODES = ['SH', 'SF', 'SR', 'HD', 'MO', 'CFT', 'CFB', 'CRT', 'CRB',
         'ZS', 'XS', 'YS', 'TB', 'BD', 'CT', 'CR']
N = len(NODES)
I = {n: i for i, n in enumerate(NODES)}
IAL, IAH, ICH = N, N + 1, N + 2          # boundary indices in augmented vector
DT = 10.0                                 # internal step, s
T_REF = 20.0


# ---------------------------------------------------------------- utilities
def expm(M):
    nrm = np.abs(M).sum(axis=1).max()
    s = int(max(0, np.ceil(np.log2(max(nrm, 1e-12) / 0.25))))
    A = M / (2.0 ** s)
    E = np.eye(M.shape[0])
    term = np.eye(M.shape[0])
    for k in range(1, 14):
        term = term @ A / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


def lag_filter(x, tau, dt):
    """first-order lag of series x (1-D), exact for piecewise-constant input."""
    a = np.exp(-dt / tau)
    y = np.empty_like(x)
    acc = x[0]
    for k in range(len(x)):
        acc = a * acc + (1 - a) * x[k]
        y[k] = acc
    return y


# ---------------------------------------------------------------- machine
def build_machine(rng):
    U = lambda a, b: float(rng.uniform(a, b))
    lf = lambda s=0.25: float(np.exp(rng.normal(0.0, s)))
    m = {}
    C = np.array([7e3, 4e3, 2.5e3, 1.4e5, 2.5e4, 1.9e5, 2.2e5, 1.9e5, 2.2e5,
                  1.2e4, 8e3, 8e3, 2.0e5, 1.5e6, 8e5, 6e3])
    m['C'] = C * np.array([lf(0.3) for _ in range(N)])
    links = [('SH', 'SF', 8), ('SH', 'SR', 5), ('SH', 'MO', 2), ('SF', 'HD', 10),
             ('SR', 'HD', 8), ('MO', 'HD', 6), ('HD', 'CFT', 12), ('HD', 'ZS', 3),
             ('ZS', 'CFT', 3), ('CFT', 'CFB', 15), ('CRT', 'CRB', 15),
             ('CFT', 'CRT', 10), ('CFB', 'CRB', 10), ('CFB', 'BD', 20),
             ('CRB', 'BD', 20), ('TB', 'BD', 8), ('YS', 'BD', 2), ('YS', 'TB', 1.5),
             ('XS', 'TB', 2), ('XS', 'BD', 1)]
    m['links'] = [(I[a], I[b], g * lf(0.3)) for a, b, g in links]
    # air couplings: node, G [W/K], height fraction (0 = low sensor, 1 = high), speed coef
    air = [('SH', 0.6, 0.5, 2.0), ('SF', 1.5, 0.5, 1.0), ('SR', 0.8, 0.7, 0.5),
           ('HD', 10, 0.75, 0.0), ('MO', 5, 0.95, 0.0),
           ('CFT', U(8, 14), 0.85, 0.0), ('CFB', U(6, 12), 0.3, 0.0),
           ('CRT', U(10, 20), 0.85, 0.0), ('CRB', U(8, 16), 0.3, 0.0),
           ('ZS', 1.0, 0.8, 0.0), ('XS', 1.0, 0.3, 0.0), ('YS', 1.0, 0.2, 0.0),
           ('TB', 8, 0.35, 0.0), ('BD', 25, 0.1, 0.0), ('CT', 20, 0.0, 0.0),
           ('CR', 1.5, 0.1, 0.0)]
    m['air'] = [(I[n], g * lf(0.25), float(np.clip(h + rng.normal(0, 0.05), 0, 1)), sc * lf(0.2))
                for n, g, h, sc in air]
    m['motor_fan'] = U(0.8, 2.0)
    chs = U(0.5, 1.5)
    m['chiller'] = [(I['SF'], 14 * chs * lf(0.2)), (I['SR'], 7 * chs * lf(0.2)),
                    (I['MO'], 18 * chs * lf(0.2)), (I['HD'], 6 * chs * lf(0.2))]
    m['ch_off'] = U(-1.0, 0.4)
    m['ch_rip'] = U(0.1, 0.35)
    m['ch_per'] = U(300, 900)
    m['G_flow'] = U(900, 1800)
    m['G_tc'] = U(25, 70)
    # heat sources
    m['nmax'] = float(rng.choice(np.arange(8000, 12001, 500)))
    m['Bf'] = U(80, 180)
    m['Br'] = m['Bf'] * U(0.4, 0.7)
    m['p'] = U(1.2, 1.5)
    m['kpre'] = U(0.01, 0.04)
    m['fs'] = U(0.35, 0.6)
    m['M0'] = U(20, 60)
    m['M1'] = U(50, 150)
    m['M2'] = U(50, 150)
    m['frot'] = U(0.1, 0.3)
    m['cab0'] = U(30, 80)
    m['cab1'] = U(0.05, 0.15)
    m['Kx'], m['Ky'], m['Kz'] = U(20, 60), U(20, 60), U(25, 70)
    m['Kc'] = U(20, 80)
    m['Qp'] = U(100, 300)
    # room / local air
    m['grad0'] = U(0.8, 2.0)
    m['kloc'] = U(0.5, 1.5) / 1000.0       # K per W of machine heat (air high)
    # sensors: (weights over augmented vector, tau, noise, offset, quantised)
    spec = [[('SF', 1.0)], [('SR', 1.0)], [('HD', 1.0)], [('MO', 1.0)],
            [('CFT', 1.0)], [('CFB', 1.0)], [('CRT', 1.0)], [('CRB', 1.0)],
            [('ZS', 0.6), ('HD', 0.4)], [('TB', 1.0)], [('BD', 1.0)], [('CT', 1.0)],
            [('CR', 1.0)], [('AL', 1.0)], [('AH', 1.0)], [('XS', 1.0)]]
    idx_ext = dict(I, AL=IAL, AH=IAH, CH=ICH)
    W = np.zeros((16, N + 3))
    for s, parts in enumerate(spec):
        for n, w in parts:
            W[s, idx_ext[n]] += w
        if s not in (13, 14):      # surface sensors see a bit of local air
            hgt = {i: h for i, _, h, _ in m['air']}[idx_ext[parts[0][0]]]
            wa = U(0.0, 0.08)
            W[s] *= (1 - wa)
            W[s, IAL] += wa * (1 - hgt)
            W[s, IAH] += wa * hgt
    m['W'] = W
    m['tau'] = np.array([U(30, 120) if s in (13, 14) else U(60, 600) for s in range(16)])
    m['snoise'] = np.array([U(0.01, 0.05) for _ in range(16)])
    m['soff'] = np.clip(rng.normal(0, 0.12, 16), -0.3, 0.3)
    m['squant'] = np.zeros(16, bool)
    m['squant'][rng.choice(16, size=int(rng.integers(3, 6)), replace=False)] = True
    m['dnoise'] = np.array([U(0.2, 0.5) for _ in range(3)])
    m['cache'] = {}
    _build_displacement_gains(m, rng)
    return m


def system_matrices(m, rpm, cool, power):
    L = np.zeros((N, N))
    Gb = np.zeros((N, 3))
    for a, b, g in m['links']:
        L[a, a] += g; L[b, b] += g; L[a, b] -= g; L[b, a] -= g
    r = rpm / 1e4
    for i, g, h, sc in m['air']:
        ge = g * (1 + sc * r ** 0.7)
        if i == I['MO'] and rpm > 0:
            ge *= 1 + m['motor_fan']
        L[i, i] += ge
        Gb[i, 0] += ge * (1 - h)
        Gb[i, 1] += ge * h
    cr, ct, tb = I['CR'], I['CT'], I['TB']
    gfl, gtc = (m['G_flow'], m['G_tc']) if cool else (0.0, 0.3)
    for a, b, g in ((cr, ct, gfl), (cr, tb, gtc)):
        L[a, a] += g; L[b, b] += g; L[a, b] -= g; L[b, a] -= g
    if power and rpm > 0:          # spindle oil cooler interlocked with spindle run
        for i, g in m['chiller']:
            L[i, i] += g
            Gb[i, 2] += g
    return L, Gb


def discretize(m, key):
    rpm, cool, power = key[0] * 100.0, key[1], key[2]
    L, Gb = system_matrices(m, rpm, cool, power)
    C = m['C']
    A = -L / C[:, None]
    Phi = expm(A * DT)
    Gam = np.linalg.solve(A, Phi - np.eye(N))
    return Phi, Gam / C[None, :], Gam @ (Gb / C[:, None])


def heat(m, x, rpm, dux, duy, duz, cut, cool, power):
    q = np.zeros(N)
    if power:
        qm = 0.0
        if rpm > 0:
            r = rpm / 1e4
            rp = r ** m['p']
            qbf = m['Bf'] * rp * (1 + m['kpre'] * max(0.0, x[0] - x[1]))
            qbr = m['Br'] * rp * (1 + m['kpre'] * max(0.0, x[0] - x[2]))
            qm = m['M0'] + m['M1'] * r + m['M2'] * r * r
            q[0] += m['fs'] * (qbf + qbr) + m['frot'] * qm
            q[1] += (1 - m['fs']) * qbf
            q[2] += (1 - m['fs']) * qbr
            q[4] += (1 - m['frot']) * qm
            if cut:
                qc = m['Kc'] * r
                if cool:
                    q[15] += 0.7 * qc; q[12] += 0.3 * qc
                else:
                    q[12] += qc
        qcab = m['cab0'] + m['cab1'] * qm
        q[7] += 0.4 * qcab; q[8] += 0.6 * qcab
        q[10] += m['Kx'] * dux
        q[11] += m['Ky'] * duy
        q[9] += 0.8 * m['Kz'] * duz
        q[5] += 0.2 * m['Kz'] * duz
        if cool:
            q[14] += m['Qp']
    return q


def steady_rise(m, rpm, duty=0.4):
    L, Gb = system_matrices(m, rpm, False, True)
    q = heat(m, np.zeros(N), rpm, duty, duty, duty, True, False, True)
    return np.linalg.solve(L, q)


# ---------------------------------------------------------------- displacement model
def _build_displacement_gains(m, rng):
    U = lambda a, b: float(rng.uniform(a, b))
    lf = lambda s=0.2: float(np.exp(rng.normal(0.0, s)))
    gz = np.zeros(N); gy = np.zeros(N); gx = np.zeros(N)
    # dz > 0: tool centre point moves toward the table
    gz[I['SH']] = 3.0 * lf()          # shaft axial growth (front-bearing located)
    gz[I['SF']] = 0.8 * lf()          # spindle nose housing
    gz[I['SR']] = 0.1 * lf()
    gz[I['HD']] = 2.5 * lf()          # head casting below Z-nut bracket
    gz[I['MO']] = 0.2 * lf()
    for n, v in (('CFT', -1.8), ('CRT', -1.8), ('CFB', -1.2), ('CRB', -1.2)):
        gz[I[n]] = v * lf(0.15)       # column height growth lifts head
    gz[I['ZS']] = 1.5 * lf(0.3)       # Z screw, fixed at top, nut on head
    gz[I['TB']] = 1.0 * lf()          # table thickness
    gz[I['BD']] = 0.3 * lf(0.5)
    # dy: column bending from front-rear gradient + head nod + Y screw/table
    sb = 12.0 * lf(0.25)
    wt = U(0.5, 0.7)
    gy[I['CFT']] += -sb * wt; gy[I['CRT']] += sb * wt
    gy[I['CFB']] += -sb * (1 - wt); gy[I['CRB']] += sb * (1 - wt)
    hn = U(0.5, 1.5)
    gy[I['SF']] += -hn; gy[I['HD']] += hn
    gy[I['YS']] += 1.5 * lf(0.3)
    gy[I['TB']] += -0.8 * lf(0.3)
    # dx: X screw, table, left-right asymmetry (offset motor, column twist)
    gx[I['XS']] += 2.0 * lf(0.3)
    gx[I['TB']] += -0.6 * lf(0.3)
    sg = rng.choice([-1.0, 1.0])
    a_lr = sg * U(0.4, 1.2)
    gx[I['MO']] += a_lr; gx[I['HD']] -= a_lr
    a_c = rng.choice([-1.0, 1.0]) * U(0.5, 2.0)
    gx[I['CFT']] += a_c; gx[I['CRT']] -= a_c
    gx[I['SF']] += rng.choice([-1.0, 1.0]) * U(0.1, 0.5)
    # scale so that the steady state at nmax lands in a plausible range
    dT = steady_rise(m, m['nmax'])
    for g, lo, hi in ((gz, 25, 50), (gy, 8, 20), (gx, 4, 10)):
        v = float(g @ dT)
        tgt = U(lo, hi)
        s = np.clip(tgt / max(abs(v), 1e-6), 0.4, 2.5)
        g *= s
    m['gx'], m['gy'], m['gz'] = gx, gy, gz
    m['qz'] = U(0.02, 0.08)            # um/K^2 on shaft-housing difference
    m['cf'] = U(0.5, 2.0)              # um at 10000 rpm, centrifugal/Poisson shortening
    m['qy'] = U(-0.03, 0.03)           # bilinear bending term


def displacements(m, X, rpm):
    d = X - T_REF
    dx = d @ m['gx']
    dy = d @ m['gy'] + m['qy'] * (X[:, I['CFT']] - X[:, I['CRT']]) * (X[:, I['HD']] - T_REF)
    dsh = X[:, I['SH']] - X[:, I['HD']]
    dz = d @ m['gz'] + m['qz'] * dsh * np.abs(dsh) - m['cf'] * (rpm / 1e4) ** 2
    return dx, dy, dz


# ---------------------------------------------------------------- programmes
class Prog:
    def __init__(self, rng):
        self.rng = rng
        self.segs = []    # (dur_s, rpm, dux, duy, duz, cut)

    def idle(self, minutes):
        self.segs.append((minutes * 60.0, 0.0, 0.0, 0.0, 0.0, False))

    def axes(self, minutes, duty=0.6):
        self.segs.append((minutes * 60.0, 0.0, duty, duty, duty, False))

    def cut(self, minutes, rpm, pauses=True):
        """constant-speed level, split into part-programme chunks with varied axis duty"""
        rng = self.rng
        left = minutes * 60.0
        while left > 1:
            d = min(left, rng.uniform(5, 15) * 60)
            du = rng.uniform(0.1, 0.7, 3)
            self.segs.append((d, float(round(rpm, -2)), du[0], du[1], du[2], True))
            left -= d
            if pauses and left > 120 and rng.random() < 0.2:
                p = rng.uniform(1, 2) * 60
                self.segs.append((p, 0.0, 0.0, 0.0, 0.0, False))
                left -= p

    def total(self):
        return sum(s[0] for s in self.segs)

    def fit(self, lo=5 * 3600, hi=9 * 3600):
        tot = self.total()
        if tot < lo:
            self.idle((lo - tot) / 60 + 5)
        out, acc = [], 0.0
        for s in self.segs:
            if acc + s[0] > hi:
                s = (hi - acc,) + s[1:]
            if s[0] > 0:
                out.append(s)
            acc += s[0]
            if acc >= hi:
                break
        self.segs = out
        return self


def prog_stair(rng, nmax):
    p = Prog(rng)
    p.idle(rng.uniform(15, 30))
    for f in (0.25, 0.5, 0.75, 1.0):
        p.cut(rng.uniform(50, 75), f * nmax, pauses=False)
    p.idle(rng.uniform(90, 130))
    return p.fit()


def prog_onoff(rng, nmax):
    p = Prog(rng)
    p.idle(rng.uniform(10, 20))
    p.cut(rng.uniform(100, 130), nmax)
    p.idle(rng.uniform(50, 70))
    p.cut(rng.uniform(90, 120), 0.5 * nmax)
    p.idle(rng.uniform(80, 110))
    return p.fit()


def prog_spectrum(rng, nmax):
    p = Prog(rng)
    p.idle(rng.uniform(5, 15))
    target = rng.uniform(6.3, 7.6) * 3600
    while p.total() < target:
        d = rng.uniform(5, 30)
        if rng.random() < 0.2:
            p.idle(d)
        else:
            p.cut(d, rng.uniform(0.1, 1.0) * nmax, pauses=False)
    p.idle(rng.uniform(40, 60))
    return p.fit()


def prog_mixed(rng, nmax):
    p = Prog(rng)
    p.idle(rng.uniform(10, 20))
    p.axes(rng.uniform(20, 40), rng.uniform(0.5, 0.8))       # axis-only warm-up cycle
    p.cut(rng.uniform(70, 100), 0.6 * nmax)
    p.idle(rng.uniform(20, 40))
    p.cut(rng.uniform(70, 100), 0.85 * nmax)
    p.cut(rng.uniform(60, 90), 0.3 * nmax)
    p.idle(rng.uniform(60, 90))
    return p.fit()


def _cycles(p, rng, nmax, hours, lo=0.2, hi=1.0, full_prob=0.0):
    end = p.total() + hours * 3600
    while p.total() < end:
        for _ in range(int(rng.integers(3, 6))):            # tools in one part
            f = 1.0 if rng.random() < full_prob else rng.uniform(lo, hi)
            p.cut(rng.uniform(2, 8), f * nmax, pauses=False)
        p.idle(rng.uniform(1, 3))                            # part change


def prog_job(rng, nmax):
    p = Prog(rng)
    p.idle(rng.uniform(5, 20))
    _cycles(p, rng, nmax, rng.uniform(2.5, 3.5))
    p.idle(rng.uniform(40, 60))                              # lunch break
    _cycles(p, rng, nmax, rng.uniform(1.5, 2.5))
    p.idle(rng.uniform(45, 75))
    return p.fit()


def prog_rough_finish(rng, nmax):
    p = Prog(rng)
    p.idle(rng.uniform(10, 20))
    p.cut(rng.uniform(15, 25), 0.4 * nmax)                   # warm-up
    _cycles(p, rng, nmax, rng.uniform(1.5, 2.0), 0.6, 1.0, full_prob=0.4)
    p.cut(rng.uniform(30, 50), nmax)                          # long high-speed finishing
    p.idle(rng.uniform(30, 50))
    _cycles(p, rng, nmax, rng.uniform(1.0, 1.5), 0.2, 0.7)
    p.idle(rng.uniform(45, 70))
    return p.fit()


def prog_arrays(segs, t):
    """evaluate a programme on time grid t (t < 0 -> idle)."""
    ends = np.cumsum([s[0] for s in segs])
    vals = np.array([s[1:] for s in segs], float)
    k = np.searchsorted(ends, t, side='right')
    k = np.clip(k, 0, len(segs) - 1)
    out = vals[k].copy()
    out[t < 0] = 0.0
    return out[:, 0], out[:, 1], out[:, 2], out[:, 3], out[:, 4] > 0.5


# ---------------------------------------------------------------- room
def room_series(m, rng, t, cfg):
    """returns AL, AH (air low / high near the machine) on grid t."""
    kind = cfg['room']
    Tend = t[-1]
    if kind == 'const':
        room = cfg['level'] + 0.02 * np.sin(2 * np.pi * t / rng.uniform(900, 1800) + rng.uniform(0, 6.3))
    elif kind == 'diurnal':
        amp = rng.uniform(3, 6) / 2
        ph = rng.uniform(-1.0, 1.0) + (0 if rng.random() < 0.5 else np.pi)   # rising or falling part
        room = cfg['level'] + amp * np.sin(2 * np.pi * t / 86400 + ph) \
            + 0.1 * np.sin(2 * np.pi * t / rng.uniform(900, 2400))
    elif kind == 'shop':
        D = rng.choice([-1, 1]) * rng.uniform(1, 2)
        s = np.clip(t / max(Tend, 1), 0, 1)
        s = s * s * (3 - 2 * s)
        P = rng.uniform(900, 2400)
        room = cfg['level'] + D * s + rng.uniform(0.15, 0.25) * np.sin(2 * np.pi * t / P + rng.uniform(0, 6.3)) \
            + 0.05 * np.sin(2 * np.pi * t / (P / 2.7) + 1.0)
    else:
        raise ValueError(kind)
    # door openings: cold floor air
    door = np.zeros_like(t)
    ev = []
    for _ in range(cfg.get('doors', 0)):
        t0 = rng.uniform(0.1, 0.85) * Tend
        ev.append((t0, rng.uniform(3, 10) * 60, rng.uniform(1.0, 3.0)))
    if ev:
        to, tc = rng.uniform(60, 120), rng.uniform(900, 1800)
        d = 0.0
        for k in range(len(t)):
            opened = any(t0 <= t[k] < t0 + du for t0, du, _ in ev)
            if opened:
                dep = max(dp for t0, du, dp in ev if t0 <= t[k] < t0 + du)
                d += (-dep - d) * (1 - np.exp(-DT / to))
            else:
                d += (0 - d) * (1 - np.exp(-DT / tc))
            door[k] = d
    g = np.clip(m['grad0'] + 0.12 * (room - 20.0), 0.2, None)
    AL = room - g / 2 + door
    AH = room + g / 2 + 0.4 * door
    return AL, AH


# ---------------------------------------------------------------- one run
def run(m, rng, cfg, dt_out):
    segs = cfg['prog'].segs
    Trun = sum(s[0] for s in segs)
    Tpre = cfg.get('pre', 0.0)
    t = np.arange(-Tpre, Trun + DT / 2, DT)
    rpm, dux, duy, duz, cut = prog_arrays(segs, t)
    power = t >= 0
    cool = cut & cfg.get('coolant', False)
    # prior job (warm start)
    if cfg.get('warm'):
        gap = rng.uniform(3, 25) * 60
        dur = rng.uniform(1.5, 3.5) * 3600
        pr = rng.uniform(0.6, 1.0) * cfg['nprev']
        win = (t >= -gap - dur) & (t < -gap)
        rpm[win] = round(pr, -2)
        dux[win] = duy[win] = duz[win] = 0.35
        cut[win] = True
        power = power | (t >= -gap - dur)
    AL, AH = room_series(m, rng, t, cfg)
    # local air warming by the machine's own heat (filtered)
    r = rpm / 1e4
    qest = power * m['cab0'] + (rpm > 0) * ((m['Bf'] + m['Br']) * r ** m['p'] + m['M0'] + m['M1'] * r)
    loc = lag_filter(qest, 900.0, DT) * m['kloc']
    AH = AH + loc
    AL = AL + 0.3 * loc
    tri = 2 * np.abs(((t / m['ch_per']) % 1.0) - 0.5) - 0.5          # -0.5..0.5
    CH = AL + (rpm > 0) * (m['ch_off'] + 2 * m['ch_rip'] * tri)
    # initial equilibrium (machine off) at the first boundary values
    L0, Gb0 = system_matrices(m, 0.0, False, False)
    x = np.linalg.solve(L0, Gb0 @ np.array([AL[0], AH[0], CH[0]]))
    K = len(t)
    X = np.empty((K, N))
    cache = m['cache']
    for k in range(K):
        X[k] = x
        key = (int(round(rpm[k] / 100.0)), bool(cool[k]), bool(power[k]))
        mats = cache.get(key)
        if mats is None:
            mats = cache[key] = discretize(m, key)
        Phi, Gq, Gb = mats
        q = heat(m, x, rpm[k], dux[k], duy[k], duz[k], cut[k], cool[k], power[k])
        x = Phi @ x + Gq @ q + Gb @ np.array([AL[k], AH[k], CH[k]])
    Z = np.column_stack([X, AL, AH, CH])
    Y = Z @ m['W'].T
    a = np.exp(-DT / m['tau'])
    S = np.empty_like(Y)
    acc = Y[0].copy()
    for k in range(K):
        acc = a * acc + (1 - a) * Y[k]
        S[k] = acc
    dx, dy, dz = displacements(m, X, rpm)
    # sample
    step = int(round(dt_out / DT))
    i0 = int(np.argmin(np.abs(t)))
    sel = np.arange(i0, K, step)
    ts = t[sel] - t[i0]
    T = S[sel] + m['soff'] + rng.normal(0, 1, (len(sel), 16)) * m['snoise']
    T[:, m['squant']] = np.round(T[:, m['squant']] / 0.0625) * 0.0625
    D = np.column_stack([dx[sel], dy[sel], dz[sel]]) + rng.normal(0, 1, (len(sel), 3)) * m['dnoise']
    if cfg['zero']:
        D = D - D[0]
    keep = np.ones(len(sel), bool)
    if cfg.get('gap'):
        g0 = rng.uniform(0.2, 0.8) * ts[-1]
        glen = rng.uniform(5, 20) * 60
        keep = ~((ts > g0) & (ts < g0 + glen))
    return ts[keep], rpm[sel][keep], T[keep], D[keep]


def write_csv(path, ts, rpm, T, D):
    hdr = ['t_s', 'speed_rpm'] + ['T%d' % i for i in range(1, 17)] + ['dx_um', 'dy_um', 'dz_um']
    arr = np.column_stack([ts, rpm, T, D])
    np.savetxt(path, arr, delimiter=',', fmt='%.4f', header=','.join(hdr), comments='')


# ---------------------------------------------------------------- variants
def plan(variant, m, rng):
    nmax = m['nmax']
    cal_progs = [prog_stair, prog_onoff, prog_spectrum, prog_mixed]
    runs = {}
    if variant in ('a', 'b'):
        levels = [20.0] * 4 if variant == 'a' else list(rng.permutation([18.0, 20.0, 22.0, 24.0]))
        for i, f in enumerate(cal_progs):
            runs['cal%d' % (i + 1)] = dict(prog=f(rng, nmax), room='const', level=levels[i],
                                           zero=(variant == 'a'))
        for i, f in enumerate((prog_job, prog_spectrum)):
            runs['test%d' % (i + 1)] = dict(prog=f(rng, nmax), room='diurnal',
                                            level=rng.uniform(19, 22.5), doors=int(rng.integers(1, 4)),
                                            pre=12 * 3600.0, zero=(variant == 'a'))
        dt_out = 30.0
    elif variant in ('c', 'd'):
        ncal = round(rng.uniform(0.7, 0.85) * nmax, -2)
        warm = list(rng.permutation([True, False, True, False]))
        coolc = list(rng.permutation([True, False, bool(rng.random() < 0.5), False]))
        for i, f in enumerate(cal_progs):
            runs['cal%d' % (i + 1)] = dict(prog=f(rng, ncal), room='shop', level=rng.uniform(19, 22.5),
                                           doors=int(rng.integers(0, 2)), pre=12 * 3600.0,
                                           warm=warm[i], nprev=ncal, coolant=coolc[i],
                                           zero=(variant == 'c'))
        twarm = list(rng.permutation([True, False]))
        tcool = list(rng.permutation([True, False]))
        runs['test1'] = dict(prog=prog_job(rng, ncal), room='shop', level=rng.uniform(19, 22.5),
                             doors=int(rng.integers(1, 3)), pre=12 * 3600.0, warm=twarm[0],
                             nprev=ncal, coolant=tcool[0], zero=(variant == 'c'))
        runs['test2'] = dict(prog=prog_rough_finish(rng, nmax), room='shop', level=rng.uniform(19, 22.5),
                             doors=int(rng.integers(0, 3)), pre=12 * 3600.0, warm=twarm[1],
                             nprev=ncal, coolant=tcool[1], zero=(variant == 'c'))
        dt_out = 30.0 if variant == 'c' else 60.0
        if variant == 'd':
            runs[str(rng.choice(sorted(runs)))]['gap'] = True
    else:
        raise SystemExit('unknown variant %r' % variant)
    return runs, dt_out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--seed', type=int, required=True)
    ap.add_argument('--variant', required=True, choices=['a', 'b', 'c', 'd'])
    ap.add_argument('--out', required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    vnum = 'abcd'.index(a.variant)
    m = build_machine(np.random.default_rng([a.seed, 7919]))          # machine = f(seed)
    rng = np.random.default_rng([a.seed, 104729, vnum])                # runs = f(seed, variant)
    runs, dt_out = plan(a.variant, m, rng)
    summary = {'seed': a.seed, 'variant': a.variant, 'dt_s': dt_out, 'files': {}}
    for name in ['cal1', 'cal2', 'cal3', 'cal4', 'test1', 'test2']:
        ts, rpm, T, D = run(m, rng, runs[name], dt_out)
        write_csv(os.path.join(a.out, name + '.csv'), ts, rpm, T, D)
        summary['files'][name + '.csv'] = {
            'rows': int(len(ts)), 'std_dx': round(float(D[:, 0].std()), 3),
            'std_dy': round(float(D[:, 1].std()), 3), 'std_dz': round(float(D[:, 2].std()), 3)}
    print(json.dumps(summary, separators=(',', ':')))


if __name__ == '__main__':
    main()
