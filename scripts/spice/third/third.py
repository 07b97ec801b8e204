#!/usr/bin/env python3
"""Third, independent ngspice generator of "real converter" data for ``buckid diagnose``.

Written apart from ``../buck_spice.py`` (VDMOS cards, Schottky, the passive network of the
model) and ``../harness/harness.py`` (SW switches, level-1 NMOS, flux-controlled softplus
inductor, Cl/(1 + c v/Vr)^2 ceramic), and tuned on neither, it draws converters at three
scales (``FAMILIES``):

* ``thesis``  the thesis power stage (3.3 uH, 100 mOhm, 100 uF, 100 mOhm, 330 kHz, 12 V);
* ``lab``     a 24 V bench buck, 22-100 uH, electrolytic 220-470 uF, 50-150 kHz;
* ``pol``     a 5 V point-of-load buck, 0.47-2.2 uH, polymer 47-220 uF, 0.5-1 MHz;

with devices of its own: level-3 MOSFET channels in subcircuits (gate resistance, Meyer
gate capacitances plus overlap, i.e. a Cgd that changes with the region, series drain and
source resistances) and explicit body diodes with reverse recovery (TT > 0) and junction
capacitance; a gate driver with propagation delay and separate rise and fall times; dead
time; a Schottky or fast-recovery freewheeling diode for the asynchronous buck; an input
source with series resistance, bulk and decoupling capacitors and a damped hot-loop
inductance; a switch-node capacitance; capacitor ESL; a core-loss resistance; a feedback
divider at the output; a DC-biased ceramic of its own law, Cl(v) = Cl0/sqrt(1 + (v/V0)^2)
(charge-controlled: v = V0*sinh(q/(Cl0*V0))); a saturating inductor of its own law, the
incremental inductance L*(1 - s*g((|i| - Isat)/w)) with the algebraic sigmoid
g(x) = (1 + x/sqrt(1 + x^2))/2 (current-controlled: a series B source scales the voltage of
a linear inductor); an ADC sampling late, an RC anti-alias filter, probe gain and zero
errors and seeded Gaussian noise.

The CSV carries the data contract (``time,duty,vin,io,vout[,il]``) and, as metadata, only
``# fs``, ``# U``, the NOMINAL ``# L``, ``# RL``, ``# C``, ``# Rc`` the user believes (and
``# rload`` for a resistive load); ``--truth`` writes everything that was used, the
design-table effects deliberately present and material (``effects``), and the Cl to score
(``cl_true``).

Which effects are material is judged, for the linear ones (switch resistance, L/C/Rc drift,
load ESR, ESL, and per-operating-point approximations of the DC-biased ceramic and the
saturating inductor), by an exact sampled-data model of the passive network with ideal
switches (``Linear``): the effect's period-start vout against the nominal model with Cl
refitted; RMS of what is left over the last third, divided by the vout noise. An effect is
listed when that ratio is at least ``MATERIAL_RATIO``. Dead time, a diode's drop and DCM are
listed by construction (tens to hundreds of mV).

Examples:
    python scripts/spice/third/third.py --family lab --case several --seed 3 \
        --out data.csv --truth truth.json
    python scripts/spice/third/third.py --family pol --case single --effect esl --seed 1 \
        --periods 300 --out d.csv
"""

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

try:
    from scipy.linalg import expm
except ImportError:  # pragma: no cover - scipy is in scripts/requirements.txt
    expm = None

KINDS = ("clean", "single", "several")
SINGLE_EFFECTS = ("switch_resistance", "diode_drop", "dead_time", "load_esr", "esl",
                  "inductor_saturation", "cap_dc_bias", "param_drift")
# An effect is listed in the truth when its isolated linear estimate leaves at least this
# many vout noise sigmas (RMS over the held-out third, Cl refitted); drawn magnitudes aim
# for DRAW_RATIO.
MATERIAL_RATIO = 1.0
DRAW_RATIO = 1.5
# A clean case's parasitics together must stay below this ratio.
CLEAN_RATIO = 0.3


# --------------------------------------------------------------------------------------
# Families
# --------------------------------------------------------------------------------------

def _u(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def _lu(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


FAMILIES = {
    # Ranges: (lo, hi). Values fixed by the family are plain numbers.
    "thesis": dict(
        U=12.0, L=(3.3e-6, 3.3e-6), RL=(0.1, 0.1), C=(100e-6, 100e-6), Rc=(0.1, 0.1),
        fs=(330e3, 330e3), cl=(0.2e-6, 100e-6), io=(0.5, 5.0), rload=(2.0, 12.0),
        levels=((0.4, 0.6),), vdrv=10.0, vth=(2.0, 3.0), tp=(10e-9, 40e-9),
        tr=(4e-9, 12e-9), tf=(3e-9, 10e-9), dead=(10e-9, 80e-9), rdrv=(0.5, 2.5),
        rg=(0.5, 2.0), cgs=(0.8e-9, 2.5e-9), ron=(5e-3, 40e-3), rsrc=(0.5e-3, 5e-3),
        adc=(20e-9, 300e-9), noise_v=(1e-3, 4e-3), noise_i=(2e-3, 20e-3),
        load_esr=(5e-3, 60e-3), esl=(1e-9, 5e-9), esl_cl=(0.1e-9, 0.5e-9),
        csw=(100e-12, 1e-9), lloop=(0.5e-9, 5e-9), cdec=(2e-6, 20e-6),
        cbulk=(100e-6, 470e-6), rcore=(300.0, 3000.0), rbleed=20e3, vbd=60.0,
        lloop_tiny=0.1e-9,
    ),
    "lab": dict(
        U=24.0, L=(22e-6, 100e-6), RL=(30e-3, 150e-3), C=(220e-6, 470e-6), Rc=(30e-3, 200e-3),
        fs=(50e3, 150e3), cl=(1e-6, 200e-6), io=(0.2, 3.0), rload=(5.0, 50.0),
        levels=((0.4, 0.6), (0.3, 0.5)), vdrv=12.0, vth=(3.0, 4.0), tp=(30e-9, 100e-9),
        tr=(10e-9, 40e-9), tf=(8e-9, 30e-9), dead=(40e-9, 200e-9), rdrv=(1.0, 4.0),
        rg=(1.0, 3.0), cgs=(1.5e-9, 4e-9), ron=(20e-3, 150e-3), rsrc=(2e-3, 20e-3),
        adc=(50e-9, 400e-9), noise_v=(1e-3, 5e-3), noise_i=(5e-3, 20e-3),
        load_esr=(20e-3, 200e-3), esl=(5e-9, 20e-9), esl_cl=(0.3e-9, 2e-9),
        csw=(200e-12, 2e-9), lloop=(2e-9, 5e-9), cdec=(1e-6, 10e-6),
        cbulk=(220e-6, 1000e-6), rcore=(1000.0, 10000.0), rbleed=50e3, vbd=100.0,
        lloop_tiny=0.2e-9,
    ),
    "pol": dict(
        U=5.0, L=(0.47e-6, 2.2e-6), RL=(2e-3, 15e-3), C=(47e-6, 220e-6), Rc=(5e-3, 20e-3),
        fs=(500e3, 1e6), cl=(1e-6, 100e-6), io=(1.0, 10.0), rload=(0.25, 2.0),
        levels=((0.3, 0.5), (0.4, 0.6)), vdrv=5.0, vth=(1.2, 1.8), tp=(5e-9, 20e-9),
        tr=(1e-9, 5e-9), tf=(1e-9, 4e-9), dead=(10e-9, 40e-9), rdrv=(0.3, 1.5),
        rg=(0.3, 1.2), cgs=(1e-9, 3e-9), ron=(1e-3, 10e-3), rsrc=(0.2e-3, 2e-3),
        adc=(10e-9, 120e-9), noise_v=(0.5e-3, 2e-3), noise_i=(5e-3, 20e-3),
        load_esr=(2e-3, 20e-3), esl=(0.3e-9, 2e-9), esl_cl=(0.05e-9, 0.3e-9),
        csw=(300e-12, 3e-9), lloop=(0.5e-9, 2e-9), cdec=(10e-6, 47e-6),
        cbulk=(100e-6, 330e-6), rcore=(50.0, 500.0), rbleed=10e3, vbd=30.0,
        lloop_tiny=0.02e-9,   # the commutation costs about Lloop*io*fs of vout: 0.2 mV at 10 A
    ),
}


def _rng(family, kind, seed, salt=0):
    return np.random.default_rng([int(seed), list(FAMILIES).index(family), KINDS.index(kind), 7431, salt])


# --------------------------------------------------------------------------------------
# PRBS
# --------------------------------------------------------------------------------------

def prbs(n, seed, bit_periods=8, low=0.4, high=0.6):
    """Per-period duty: a PRBS9 (x^9 + x^5 + 1, Galois form), each bit held ``bit_periods``.

    ``seed`` picks the non-zero 9-bit start state; the sequence repeats after 511 bits
    (4088 periods at 8 periods per bit)."""
    state = int(seed) % 511 + 1
    nbits = -(-int(n) // int(bit_periods))
    bits = np.empty(nbits, dtype=bool)
    for i in range(nbits):
        out = state & 1
        state >>= 1
        if out:
            state ^= 0x110  # taps 9 and 5
        bits[i] = bool(out)
    return np.where(np.repeat(bits, bit_periods)[:n], high, low).astype(float)


# --------------------------------------------------------------------------------------
# Device cards
# --------------------------------------------------------------------------------------

VT300 = 1.380649e-23 * 300.15 / 1.602176634e-19
LCH = 0.5e-6       # channel length of the level-3 cards [m]; width 1 m
EPS_OX = 3.453e-11


def fet_params(rng, F, ron, vth=None, ideal=False):
    """Level-3 channel + body diode of one power MOSFET with on-resistance ``ron`` at the
    family's gate drive (channel 65 %, drain 25 %, source 10 %).

    ``ideal``: a near-ideal part (tiny gate charge and output capacitance, fast body diode)
    for clean stages."""
    vth = _u(rng, *F["vth"]) if vth is None else vth
    theta = _u(rng, 0.02, 0.1)
    vov = F["vdrv"] - vth
    rch = 0.65 * ron
    kp = (1.0 + theta * vov) * LCH / (rch * vov)
    p = dict(ron=ron, vth=vth, theta=theta, kp=kp, rd=0.25 * ron, rs=0.10 * ron,
             eta=_u(rng, 0.0005, 0.003), kappa=_u(rng, 0.1, 0.5))
    if ideal:
        p.update(tox=3e-7, cgso=2e-12, cgdo=1e-12, rg=0.05, cgs=100e-12,
                 body=dict(is_=1e-13, n=1.0, rs=5e-3, tt=1e-9, cjo=10e-12, vj=0.7, m=0.4, bv=F["vbd"]))
    else:
        p.update(tox=_u(rng, 20e-9, 60e-9), cgso=_u(rng, 100e-12, 400e-12), cgdo=_u(rng, 30e-12, 150e-12),
                 rg=_u(rng, *F["rg"]), cgs=_u(rng, *F["cgs"]),
                 body=dict(is_=_lu(rng, 1e-12, 1e-10), n=_u(rng, 1.0, 1.3), rs=_u(rng, 3e-3, 20e-3),
                           tt=_u(rng, 10e-9, 50e-9), cjo=_lu(rng, 200e-12, 1.5e-9), vj=_u(rng, 0.6, 0.8),
                           m=_u(rng, 0.35, 0.5), bv=F["vbd"]))
    p["eta"] = min(p["eta"], eta_limit(p, vth, F["U"]))
    return p


def eta_limit(p, vth, U):
    """The largest ETA (drain-induced barrier lowering) at which the card's threshold keeps at
    least half its value at Vds = U: level 3 lowers it by SIGMA*Vds, SIGMA =
    ETA*8.15e-22/(COX*L^3). A power MOSFET blocks its supply with the gate at zero; uncapped,
    the thick-oxide near-ideal card (small COX) lost its whole threshold at 24 V and the
    diode buck's "off" high side carried the inductor current at a 2.4 V node."""
    cox = EPS_OX / p["tox"]
    return 0.5 * vth * cox * LCH ** 3 / (8.15e-22 * U)


def fet_ron_model(p, vgs):
    """On-resistance of a level-3 card at small Vds [ohm] (the formula the card is built from)."""
    vov = vgs - p["vth"]
    beta = p["kp"] * 1.0 / LCH / (1.0 + p["theta"] * vov)
    return p["rd"] + p["rs"] + 1.0 / (beta * vov)


def diode_params(rng, kind):
    """A vendor-like freewheeling diode card: ``schottky`` (Vf ~ 0.35-0.5 V, no recovery) or
    ``fast`` (fast-recovery pn, Vf ~ 0.75-0.95 V, TT 15-40 ns)."""
    if kind == "schottky":
        return dict(kind=kind, is_=_lu(rng, 2e-6, 5e-5), n=_u(rng, 1.0, 1.12), rs=_u(rng, 10e-3, 40e-3),
                    tt=0.0, cjo=_lu(rng, 150e-12, 800e-12), vj=_u(rng, 0.35, 0.5), m=_u(rng, 0.4, 0.55),
                    eg=0.69, xti=2.0, bv=60.0)
    return dict(kind=kind, is_=_lu(rng, 1e-10, 2e-9), n=_u(rng, 1.6, 1.9), rs=_u(rng, 15e-3, 40e-3),
                tt=_u(rng, 15e-9, 40e-9), cjo=_lu(rng, 40e-12, 150e-12), vj=_u(rng, 0.6, 0.8),
                m=_u(rng, 0.35, 0.5), eg=1.11, xti=3.0, bv=100.0)


def diode_vf(i, d):
    """Static forward drop of a diode card at current i [A] (27 C)."""
    return d["n"] * VT300 * math.log1p(max(i, 1e-6) / d["is_"]) + d["rs"] * max(i, 0.0)


def _n(x):
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite circuit value {x}")
    return repr(x)


def _diode_card(name, d):
    extra = f" EG={_n(d['eg'])} XTI={_n(d['xti'])}" if "eg" in d else ""
    return (f".model {name} D(IS={_n(d['is_'])} N={_n(d['n'])} RS={_n(d['rs'])} TT={_n(d['tt'])} "
            f"CJO={_n(d['cjo'])} VJ={_n(d['vj'])} M={_n(d['m'])} BV={_n(d['bv'])} IBV=1e-4{extra})")


def fet_subckt(name, p):
    """A power MOSFET subcircuit (drain gate source): gate resistance, level-3 channel with
    Meyer gate capacitances (overlap CGSO/CGDO; the channel part moves between gate-source
    and gate-drain with the region), an explicit Cgs, drain/source resistances and a body
    diode with reverse recovery and junction capacitance from source to drain."""
    b = p["body"]
    return "\n".join([
        f".subckt {name} d g s",
        f"Rg  g  gi {_n(p['rg'])}",
        f"Rd  d  di {_n(p['rd'])}",
        f"Rs  si s  {_n(p['rs'])}",
        f"M1  di gi si si {name}_CH W=1 L={_n(LCH)}",
        f"Cgs gi si {_n(p['cgs'])}",
        f"Db  s  d  {name}_BD",
        (f".model {name}_CH NMOS(LEVEL=3 VTO={_n(p['vth'])} KP={_n(p['kp'])} THETA={_n(p['theta'])} "
         f"ETA={_n(p['eta'])} KAPPA={_n(p['kappa'])} GAMMA=0 PHI=0.6 NFS=0 VMAX=0 TOX={_n(p['tox'])} "
         f"CGSO={_n(p['cgso'])} CGDO={_n(p['cgdo'])} IS=1e-20 CBD=0 CBS=0)"),
        _diode_card(f"{name}_BD", b),
        ".ends",
    ])


# --------------------------------------------------------------------------------------
# Laws of the nonlinear passives
# --------------------------------------------------------------------------------------

def sat_g(x):
    """Algebraic sigmoid: 0 far below the knee, 1 far above."""
    return 0.5 * (1.0 + x / np.sqrt(1.0 + x * x))


def sat_l(i, L, sat):
    """Incremental inductance at current i under the saturation law ``sat`` (s, isat, w)."""
    if not sat:
        return L + 0.0 * np.asarray(i, float)
    return L * (1.0 - sat["s"] * sat_g((np.abs(i) - sat["isat"]) / sat["w"]))


def bias_cl(v, cl0, bias):
    """Small-signal capacitance of the DC-biased ceramic at voltage v."""
    if not bias:
        return cl0 + 0.0 * np.asarray(v, float)
    return cl0 / np.sqrt(1.0 + (np.asarray(v, float) / bias["v0"]) ** 2)


# --------------------------------------------------------------------------------------
# Exact sampled-data model of the passive network (ideal switches)
# --------------------------------------------------------------------------------------

class Linear:
    """The passive network as a piecewise-LTI system over each period (on: the switch node at
    ``v_on``, off: at ``v_off``), exact by matrix exponentials; period-start samples of vout
    (and of the measured il). ``per_duty(d)`` may change L, Cl and v_on per duty level (the
    per-operating-point stand-ins of the saturating inductor, the biased ceramic and the
    sagging input).

    Parameters (dict): L, R_on, R_off, C, Rc, Lc, Cl, rcl, Lcl, rload (None: none), rbleed
    (None), rcore (None), v_on, v_off, io, fs."""

    def __init__(self, p, per_duty=None):
        self.p = dict(p)
        self.per_duty = per_duty
        self._cache = {}

    def _ab(self, q, R, vsw):
        L, C, Rc, Lc, Cl, rcl, Lcl = q["L"], q["C"], q["Rc"], q["Lc"], q["Cl"], q["rcl"], q["Lcl"]
        idx = {"iL": 0, "vC": 1}
        k = 2
        if Lc > 0:
            idx["iC"] = k
            k += 1
        idx["vCl"] = k
        k += 1
        if Lcl > 0:
            idx["iCl"] = k
            k += 1
        n = k
        G = 0.0
        g = np.zeros(n)
        c0 = -q["io"]
        g[idx["iL"]] = 1.0
        for r in (q.get("rload"), q.get("rbleed")):
            if r:
                G += 1.0 / r
        if q.get("rcore"):
            G += 1.0 / q["rcore"]
            c0 += vsw / q["rcore"]
        if Lc > 0:
            g[idx["iC"]] = -1.0
        else:
            G += 1.0 / Rc
            g[idx["vC"]] = 1.0 / Rc
        if Lcl > 0:
            g[idx["iCl"]] = -1.0
        else:
            G += 1.0 / rcl
            g[idx["vCl"]] = 1.0 / rcl
        g, c0 = g / G, c0 / G          # vo = g.x + c0
        A = np.zeros((n, n))
        b = np.zeros(n)
        e = np.eye(n)
        # iL' = (vsw - R iL - vo)/L
        A[0] = (-R * e[0] - g) / L
        b[0] = (vsw - c0) / L
        # C branch
        if Lc > 0:
            A[idx["vC"]] = e[idx["iC"]] / C
            A[idx["iC"]] = (g - e[idx["vC"]] - Rc * e[idx["iC"]]) / Lc
            b[idx["iC"]] = c0 / Lc
        else:
            A[idx["vC"]] = (g - e[idx["vC"]]) / (Rc * C)
            b[idx["vC"]] = c0 / (Rc * C)
        if Lcl > 0:
            A[idx["vCl"]] = e[idx["iCl"]] / Cl
            A[idx["iCl"]] = (g - e[idx["vCl"]] - rcl * e[idx["iCl"]]) / Lcl
            b[idx["iCl"]] = c0 / Lcl
        else:
            A[idx["vCl"]] = (g - e[idx["vCl"]]) / (rcl * Cl)
            b[idx["vCl"]] = c0 / (rcl * Cl)
        # measured il = iL + (vsw - vo)/rcore
        h = e[0].copy()
        h0 = 0.0
        if q.get("rcore"):
            h = h - g / q["rcore"]
            h0 = (vsw - c0) / q["rcore"]
        return A, b, g, c0, h, h0, idx

    @staticmethod
    def _disc(A, b, t):
        n = len(b)
        M = np.zeros((n + 1, n + 1))
        M[:n, :n] = A * t
        M[:n, n] = b * t
        E = expm(M)
        return E[:n, :n], E[:n, n]

    def maps(self, d):
        if d in self._cache:
            return self._cache[d]
        q = dict(self.p)
        if self.per_duty:
            q.update(self.per_duty(d, q))
        T = 1.0 / q["fs"]
        A1, b1, g1, c1, h1, h10, idx = self._ab(q, q["R_on"], q["v_on"])
        A0, b0, g0, c00, h0, h00, _ = self._ab(q, q["R_off"], q["v_off"])
        P1, G1 = self._disc(A1, b1, d * T)
        P0, G0 = self._disc(A0, b0, (1.0 - d) * T)
        Phi = P0 @ P1
        Gam = P0 @ G1 + G0
        out = dict(Phi=Phi, Gam=Gam, A1=A1, b1=b1, g0=g0, c0=c00, h0=h0, h00=h00,
                   g1=g1, c1=c1, h1=h1, h10=h10, idx=idx)
        self._cache[d] = out
        return out

    def steady(self, d):
        m = self.maps(d)
        n = len(m["Gam"])
        return np.linalg.solve(np.eye(n) - m["Phi"], m["Gam"])

    def _powers(self, d, jmax):
        """Phi^j and the accumulated input sum_{i<j} Phi^i Gam, j = 0..jmax, at duty d."""
        key = (d, jmax)
        if key in self._pow:
            return self._pow[key]
        m = self.maps(d)
        n = len(m["Gam"])
        P = np.empty((jmax + 1, n, n))
        S = np.empty((jmax + 1, n))
        P[0], S[0] = np.eye(n), 0.0
        for j in range(1, jmax + 1):
            P[j] = m["Phi"] @ P[j - 1]
            S[j] = m["Phi"] @ S[j - 1] + m["Gam"]
        self._pow[key] = (P, S)
        return P, S

    def simulate(self, duty, delay=0.0):
        """(vout, il, states) at each period start (+ ``delay`` into the on-phase), from the
        steady state of duty[0]; vectorised over each run of equal duty."""
        if not hasattr(self, "_pow"):
            self._pow = {}
        duty = np.asarray(duty, float)
        runs = _runs(duty)
        jmax = max(k1 - k0 for k0, k1, _ in runs)
        x = self.steady(float(duty[0]))
        n = len(duty)
        states = np.empty((n, len(x)))
        vo = np.empty(n)
        il = np.empty(n)
        for k0, k1, d in runs:
            P, S = self._powers(d, jmax)
            m = k1 - k0
            X = P[:m] @ x + S[:m]
            states[k0:k1] = X
            mm = self.maps(d)
            if delay > 0:
                Pd, Gd = self._disc(mm["A1"], mm["b1"], delay)
                Xs = X @ Pd.T + Gd
                vo[k0:k1] = Xs @ mm["g1"] + mm["c1"]
                il[k0:k1] = Xs @ mm["h1"] + mm["h10"]
            else:
                vo[k0:k1] = X @ mm["g0"] + mm["c0"]
                il[k0:k1] = X @ mm["h0"] + mm["h00"]
            x = P[m] @ x + S[m]
        return vo, il, states

    def slowest_rate(self, d):
        """Slowest decay rate [1/s] of the period map at duty d."""
        m = self.maps(d)
        lam = np.abs(np.linalg.eigvals(m["Phi"]))
        lam = lam[lam > 0]
        return float(-math.log(max(lam.max(), 1e-300)) * self.p["fs"])


def nominal_linear(nom, cl, io, rload):
    return dict(L=nom["L"], R_on=nom["RL"], R_off=nom["RL"], C=nom["C"], Rc=nom["Rc"], Lc=0.0,
                Cl=cl, rcl=1e-6, Lcl=0.0, rload=rload, rbleed=None, rcore=None, v_on=nom["U"],
                v_off=0.0, io=io, fs=nom["fs"])


def fit_cl(y, duty, nom, io, rload):
    """The Cl that brings the nominal model closest to ``y`` (least squares over the record,
    from the best of a log grid 0.05 uF-1 mF, refined by Gauss-Newton in ln Cl), and the
    model's vout there."""
    def sim(lcl):
        return Linear(nominal_linear(nom, math.exp(lcl), io, rload)).simulate(duty)[0]

    def cost(v):
        r = v - y
        return float(np.dot(r, r))
    grid = np.linspace(math.log(0.05e-6), math.log(1e-3), 24)
    sims = [sim(g) for g in grid]
    j = int(np.argmin([cost(v) for v in sims]))
    lcl, v = float(grid[j]), sims[j]
    best = cost(v)
    h = 1e-3
    for _ in range(8):
        jac = (sim(lcl + h) - v) / h
        jj = float(np.dot(jac, jac))
        if jj <= 0:
            break
        step = -float(np.dot(jac, v - y)) / jj
        step = max(min(step, 0.5), -0.5)
        for _ in range(6):
            v2 = sim(lcl + step)
            c2 = cost(v2)
            if c2 < best:
                break
            step /= 2
        else:
            break
        lcl, v, gain = lcl + step, v2, best - c2
        best = c2
        if abs(step) < 1e-4 or gain < 1e-9 * max(best, 1e-30):
            break
    return math.exp(lcl), v


# --------------------------------------------------------------------------------------
# Drawing a case
# --------------------------------------------------------------------------------------

def _nominal(rng, F):
    nom = dict(U=F["U"])
    for k in ("L", "RL", "C", "Rc"):
        lo, hi = F[k]
        nom[k] = lo if lo == hi else float(_lu(rng, lo, hi))
    lo, hi = F["fs"]
    nom["fs"] = lo if lo == hi else float(round(_u(rng, lo, hi) / 1e3) * 1e3)
    # round to datasheet-like figures
    for k in ("L", "C"):
        nom[k] = float(f"{nom[k]:.2g}")
    for k in ("RL", "Rc"):
        nom[k] = float(f"{nom[k]:.2g}")
    return nom


def ripple(nom, d, L=None, U=None):
    """Peak-to-peak inductor ripple of the ideal buck at duty d [A]."""
    L = nom["L"] if L is None else L
    U = nom["U"] if U is None else U
    return (U - d * U) * d / (L * nom["fs"])


def _tiny_parasitics(rng, F, nom):
    """Near-ideal layout: what every board has, at a size the data cannot show."""
    return dict(rsrc=_u(rng, 2e-6, 8e-6), cbulk=None, rbulk=None, cdec=_u(rng, *F["cdec"]),
                rdec=1e-3, lloop=_u(rng, 0.5, 1.0) * F["lloop_tiny"], rloop=None, csw=_u(rng, 10e-12, 30e-12),
                esl_c=0.0, esl_cl=0.0, rcl=_u(rng, 20e-6, 80e-6), rcore=None, rbleed=F["rbleed"],
                rl_drift=0.0)


def _real_parasitics(rng, F, nom):
    """A real board: hot loop, bulk and decoupling capacitors, cables, capacitor ESL, a core."""
    return dict(rsrc=_u(rng, *F["rsrc"]), cbulk=_u(rng, *F["cbulk"]), rbulk=_u(rng, 10e-3, 50e-3),
                cdec=_u(rng, *F["cdec"]), rdec=_u(rng, 1e-3, 5e-3), lloop=_u(rng, *F["lloop"]),
                rloop=None, csw=_lu(rng, *F["csw"]),
                esl_c=_u(rng, *F["esl"]) * _u(rng, 0.3, 1.0),
                esl_cl=_u(rng, *F["esl_cl"]) if rng.random() < 0.5 else 0.0,
                rcl=_u(rng, 0.2e-3, 1e-3) if F is not FAMILIES["lab"] else _u(rng, 0.5e-3, 3e-3),
                rcore=_lu(rng, *F["rcore"]) if rng.random() < 0.5 else None, rbleed=F["rbleed"],
                rl_drift=0.0)


def _drive(rng, F, kind):
    """Gate driver timing: propagation delay, rise/fall times, dead time, output resistance."""
    if kind == "complementary":
        # Centred, symmetric edges; the incoming channel still needs sqrt(2*il/beta) of
        # overdrive before it carries il, so the node rises late and falls early by about
        # ramp*that/Vdrv (body diode meanwhile): -0.16 mV per ns of ramp at 7 A and 0.8 MHz.
        # Short edges, through 2 ohm into 100 pF (0.2 ns): the 0.7 ns edges into a 10 ps gate
        # tried first made ngspice give up ("timestep too small").
        ramp = _u(rng, 0.5e-9, 1.0e-9)
        return dict(kind=kind, vdrv=F["vdrv"], tp=_u(rng, *F["tp"]), tr=ramp, tf=ramp, dead=0.0, rdrv=2.0)
    return dict(kind=kind, vdrv=F["vdrv"], tp=_u(rng, *F["tp"]), tr=_u(rng, *F["tr"]), tf=_u(rng, *F["tf"]),
                dead=_u(rng, *F["dead"]) if kind == "deadtime" else 0.0, rdrv=_u(rng, *F["rdrv"]))


def _load(rng, F, nom, levels, io_range=None, resistive=None):
    """(io, rload): a current load or a resistive one."""
    if resistive is None:
        resistive = rng.random() < 0.3
    if resistive:
        if io_range is not None:
            # a resistor drawing about io_range at the mean duty
            vm = nom["U"] * sum(levels) / 2
            return 0.0, float(f"{vm / _u(rng, *io_range):.3g}")
        return 0.0, float(f"{_lu(rng, *F['rload']):.3g}")
    lo, hi = io_range or F["io"]
    return float(f"{_u(rng, lo, hi):.3g}"), None


def _mean_io(c):
    if c["rload"]:
        return c["nominal"]["U"] * sum(c["levels"]) / 2 / c["rload"]
    return c["io"]


def truth_linear(c, include):
    """Linear stand-in of the case's circuit with the effects/parasitics in ``include`` only
    (names: switch_resistance, param_drift, load_esr, esl, cap_dc_bias, inductor_saturation,
    vin_sag, esl_cl, core, bleeder, rcl, rl_drift, diode, dead_time), the rest nominal."""
    nom, ci = c["nominal"], c["circuit"]
    io, rload = c["io"], c["rload"]
    p = nominal_linear(nom, ci["cl0"], io, rload)
    if "param_drift" in include:
        p.update(L=ci["L"], C=ci["C"], Rc=ci["Rc"])
    R_on = R_off = nom["RL"] * (1 + (ci["rl_drift"] if "rl_drift" in include else 0.0))
    if "switch_resistance" in include:
        R_on += c["fet_hs"]["ron"]
        R_off += c["fet_ls"]["ron"] if c["topology"] == "sync" else 0.0
    p.update(R_on=R_on, R_off=R_off)
    if "load_esr" in include or "rcl" in include:
        p["rcl"] = max(ci["rcl"], 1e-6)
    if "esl" in include:
        p["Lc"] = ci["esl_c"]
    if "esl_cl" in include:
        p["Lcl"] = ci["esl_cl"]
    if "core" in include:
        p["rcore"] = ci["rcore"]
    if "bleeder" in include:
        p["rbleed"] = ci["rbleed"]
    iom = _mean_io(c)
    if "diode" in include and c["topology"] == "async":
        p["v_off"] = -diode_vf(iom, c["diode"])
    vdt = 0.0
    if "dead_time" in include and c["topology"] == "sync" and c["drive"]["dead"] > 0:
        vbd = diode_vf(abs(iom), c["fet_ls"]["body"])
        vdt = nom["fs"] * c["drive"]["dead"] * (nom["U"] + 2 * vbd) * (1 if iom >= 0 else -1)
    sat = c["sat"] if "inductor_saturation" in include else None
    bias = c["bias"] if "cap_dc_bias" in include else None
    sag = ci["rsrc"] if "vin_sag" in include else 0.0
    L0 = p["L"]

    def per_duty(d, q):
        out = {}
        vo = d * nom["U"]
        i_avg = vo / rload if rload else io
        if sag:
            out["v_on"] = q["v_on"] - sag * d * i_avg
        if vdt:
            out["v_on"] = out.get("v_on", q["v_on"]) - vdt / d
        if sat:
            dI = ripple(nom, d, L=L0)
            ii = np.linspace(i_avg - dI / 2, i_avg + dI / 2, 41)
            out["L"] = float(np.mean(sat_l(ii, L0, sat)))
        if bias:
            out["Cl"] = float(bias_cl(vo, ci["cl0"], bias))
        return out
    return Linear(p, per_duty if (sag or vdt or sat or bias) else None)


def dcm_fraction(c):
    """Share of the check record's periods whose period-start (valley) inductor current the
    linear stand-in of the diode buck puts below zero: where the real diode blocks (DCM)."""
    lin = truth_linear(c, ["diode", "param_drift", "switch_resistance", "load_esr", "bleeder"])
    il = lin.simulate(c["_duty_check"])[1]
    return float(np.mean(il < 0.0))


def material_ratio(c, include, duty=None):
    """RMS of what the nominal model with Cl refitted leaves of the linear stand-in's vout over
    the last third, in vout noise sigmas."""
    duty = c["_duty_check"] if duty is None else duty
    y = truth_linear(c, include).simulate(duty)[0]
    _, ynom = fit_cl(y, duty, c["nominal"], c["io"], c["rload"])
    n = len(duty)
    r = (y - ynom)[2 * n // 3:]
    return float(np.sqrt(np.mean(r * r)) / c["acq"]["noise_v"])


def _check_duty(c, n=900):  # the held-out third: 300 periods
    lo, hi = c["levels"]
    return prbs(n, c["seed"], c["bit_periods"], lo, hi)


def draw(family, kind, seed, effect=None, with_il=None):
    """A case (a dict with everything the netlist and the truth need): ``kind`` is ``clean``,
    ``single`` (``effect`` one of SINGLE_EFFECTS, else drawn) or ``several``."""
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family}")
    if kind not in KINDS:
        raise ValueError(f"unknown case kind {kind}")
    F = FAMILIES[family]
    rng = _rng(family, kind, seed)
    nom = _nominal(rng, F)
    levels = tuple(F["levels"][int(rng.integers(len(F["levels"])))])
    c = dict(family=family, kind=kind, seed=int(seed), nominal=nom, levels=levels, bit_periods=8,
             sat=None, bias=None, notes=[])
    # acquisition defaults: aligned ADC, no filter, no probe errors
    acq = dict(adc_delay=None, aa_tau=0.0, noise_v=_u(rng, *F["noise_v"]), noise_i=_u(rng, *F["noise_i"]),
               vout_gain=0.0, vout_offset=0.0, il_gain=0.0, il_offset=0.0,
               with_il=bool(rng.random() >= 0.2) if with_il is None else bool(with_il))
    c["acq"] = acq
    cl0 = _lu(rng, *F["cl"])
    if kind == "single" and effect is None:
        effect = SINGLE_EFFECTS[int(rng.integers(len(SINGLE_EFFECTS)))]
    if kind != "single" and effect is not None:
        raise ValueError("--effect only with --case single")
    if effect is not None and effect not in SINGLE_EFFECTS:
        raise ValueError(f"unknown single effect {effect} (one of {', '.join(SINGLE_EFFECTS)})")
    c["single_effect"] = effect
    wanted = []            # effects deliberately present
    if kind == "clean":
        topo, drive = "sync", "complementary"
        par = _tiny_parasitics(rng, F, nom)
    elif kind == "single":
        par = _tiny_parasitics(rng, F, nom)
        wanted = [effect]
        if effect == "diode_drop":
            topo, drive = "async", "async"
        elif effect == "dead_time":
            topo, drive = "sync", "deadtime"
        else:
            topo, drive = "sync", "complementary"
    else:
        par = _real_parasitics(rng, F, nom)
        topo = "sync" if rng.random() < 0.65 else "async"
        drive = "deadtime" if topo == "sync" else "async"
    c["topology"] = topo
    c["drive"] = _drive(rng, F, drive)
    # devices
    ideal_fets = kind != "several"
    vth = _u(rng, *F["vth"])
    if drive == "complementary":
        vth = F["vdrv"] / 2  # complementary gates cross at mid drive: no overlap, no gap
    ron_tiny = lambda: _u(rng, 20e-6, 50e-6)  # noqa: E731  (a few uOhm let ngspice's step collapse)
    c["fet_hs"] = fet_params(rng, F, ron_tiny(), vth=vth, ideal=ideal_fets and drive != "deadtime")
    if topo == "sync":
        c["fet_ls"] = fet_params(rng, F, ron_tiny(), vth=vth, ideal=ideal_fets and drive != "deadtime")
        c["diode"] = None
    else:
        c["fet_ls"] = None
        c["diode"] = diode_params(rng, "schottky" if rng.random() < 0.7 else "fast")
    # load
    io_range = None
    dcm = False
    if topo == "async":
        crit = min(ripple(nom, d) for d in levels) / 2   # il reaches 0 at both levels below this
        ccm = max(ripple(nom, d) for d in levels) / 2    # and at neither above this
        if kind == "several" and rng.random() < 0.5:
            dcm = True
            c["dcm_by_load"] = True
            io_range = (0.25 * crit, 0.6 * crit)
        else:
            lo = max(1.4 * ccm, F["io"][0])
            io_range = (lo, lo + F["io"][1] / 2)
    resistive = None
    if effect == "inductor_saturation" or (kind == "several" and topo == "sync" and rng.random() < 0.4):
        resistive = True
    io, rload = _load(rng, F, nom, levels, io_range=io_range, resistive=resistive if not dcm else False)
    c["io"], c["rload"] = io, rload
    c["circuit"] = dict(L=nom["L"], RL=nom["RL"], C=nom["C"], Rc=nom["Rc"], cl0=cl0, **par)
    # The hot loop's losses (skin effect, the capacitors' ESR) damp its ring with the node's
    # capacitance: a resistance across the loop inductance at about its impedance (Q ~ 0.5-1.5;
    # a fixed 0.5 ohm left a 10 pH loop ringing at GHz for many cycles, at great cost in steps).
    cnode = par["csw"] + (c["fet_hs"]["body"]["cjo"] if topo == "sync" else c["diode"]["cjo"]) + 20e-12
    c["circuit"]["rloop"] = _u(rng, 0.5, 1.5) * math.sqrt(par["lloop"] / cnode)
    c["_duty_check"] = _check_duty(c)
    ci = c["circuit"]
    ci["snubber"] = None
    if topo == "async" and (kind == "several" or rng.random() < 0.5):
        # A switch-node RC snubber as a diode buck's layout carries (damps the DCM ring within
        # the idle interval): R at the ring's impedance, C a few times the node's capacitance.
        cnode = ci["csw"] + c["diode"]["cjo"] + 50e-12
        if rng.random() < (0.6 if kind == "several" else 1.0):
            z0 = math.sqrt(ci["L"] / cnode)
            ci["snubber"] = dict(r=float(f"{z0 * _u(rng, 0.7, 1.5):.2g}"), c=float(f"{cnode * _u(rng, 2.5, 5):.2g}"))
    if topo == "async" and not dcm:
        # The PRBS steps ring the L-C network (the thesis stage swings il by several amperes):
        # a diode buck meant to stay in CCM needs a load whose valley current stays positive
        # through the transients. Raise it (up to the family's largest load); what still
        # dips is DCM and is listed as such.
        for _ in range(12):
            if dcm_fraction(c) == 0.0:
                break
            if c["rload"]:
                if _mean_io(c) * 1.25 > F["io"][1]:
                    break
                c["rload"] = float(f"{c['rload'] / 1.25:.3g}")
            else:
                if c["io"] * 1.25 > F["io"][1]:
                    break
                c["io"] = float(f"{c['io'] * 1.25:.3g}")
        io, rload = c["io"], c["rload"]

    def accept(name, include, setter, tries=12):
        """Draw ``setter(scale)`` until the isolated ratio reaches DRAW_RATIO (scale grows)."""
        scale = 1.0
        r = 0.0
        for _ in range(tries):
            setter(scale)
            r = material_ratio(c, include)
            if r >= DRAW_RATIO:
                return r
            scale *= 1.35
        return r

    ratios = {}
    if kind == "several":
        ci["rl_drift"] = 0.0
        if topo == "sync":
            wanted += ["dead_time", "switch_resistance"]
            extra_pool = ["param_drift", "param_drift", "param_drift", "load_esr", "inductor_saturation", "cap_dc_bias"]
            if rload is None:
                extra_pool.remove("inductor_saturation")
            n_extra = int(rng.integers(1, 3))
            for _ in range(n_extra):
                e = extra_pool[int(rng.integers(len(extra_pool)))]
                if e != "param_drift" and e in wanted:
                    continue
                wanted.append(e)
            ci["rl_drift"] = _u(rng, 0.0, 0.08)       # a warm winding: part of the series resistance
        else:
            wanted += ["diode_drop", "switch_resistance"]
            if dcm:
                wanted.append("dcm")
            wanted.append("param_drift")
            if dcm:
                c["drift_only"] = ["L"]   # in DCM the level goes with 1/sqrt(L): C and Rc barely show
        # the ADC reads late (and sometimes through a filter), the probes are off
        acq["adc_delay"] = c["drive"]["tp"] + _u(rng, *F["adc"])
        if rng.random() < 0.3:
            acq["aa_tau"] = _u(rng, 0.003, 0.02) / nom["fs"]
        if rng.random() < 0.25:
            acq["vout_gain"] = _u(rng, -3e-3, 3e-3)
            acq["vout_offset"] = _u(rng, -3e-3, 3e-3)
        if rng.random() < 0.3 and acq["with_il"]:
            acq["il_gain"] = _u(rng, -0.02, 0.02)
            acq["il_offset"] = _u(rng, -0.03, 0.03)
    elif kind == "single":
        if rng.random() < 0.5:
            acq["adc_delay"] = c["drive"]["tp"] + _u(rng, *F["adc"])
    # ---- magnitudes of the wanted effects
    if "switch_resistance" in wanted:
        lo, hi = F["ron"]
        base = (_u(rng, lo, hi), _u(rng, lo, hi))

        def set_ron(s):
            c["fet_hs"] = fet_params(rng, F, min(base[0] * s, 3 * hi), vth=c["fet_hs"]["vth"], ideal=c["fet_hs"]["rg"] < 0.1)
            if topo == "sync":
                c["fet_ls"] = fet_params(rng, F, min(base[1] * s, 3 * hi), vth=c["fet_ls"]["vth"], ideal=c["fet_ls"]["rg"] < 0.1)
        if kind == "several" and topo == "async":
            set_ron(1.0)   # the high side as it comes: listed only if material
            ratios["switch_resistance"] = material_ratio(c, ["switch_resistance"])
            if dcm:
                # the CCM stand-in overstates a resistance at light load: ask for more
                ratios["switch_resistance"] /= 2.0
        else:
            ratios["switch_resistance"] = accept("switch_resistance", ["switch_resistance"], set_ron)
    if "load_esr" in wanted:
        base = _lu(rng, *F["load_esr"])
        ratios["load_esr"] = accept("load_esr", ["load_esr"], lambda s: ci.update(rcl=base * s))
    if "esl" in wanted:
        base = _u(rng, *F["esl"])
        ratios["esl"] = accept("esl", ["esl"], lambda s: ci.update(esl_c=base * s))
    n_drift = wanted.count("param_drift")
    if n_drift:
        names = list(c.get("drift_only") or rng.permutation(["L", "C", "Rc"]))
        drifted = []
        for name in names:
            if len(drifted) >= n_drift:
                break
            sign = 1.0 if rng.random() < 0.5 else -1.0
            mag = _u(rng, 0.05, 0.2)
            r = 0.0
            for _ in range(8):
                ci[name] = nom[name] * (1 + sign * mag)
                # isolated: only this drift (others reset for the check)
                saved = {x: ci[x] for x in ("L", "C", "Rc") if x != name}
                for x in saved:
                    ci[x] = nom[x]
                if dcm:
                    # the linear stand-in is CCM: judge the drift by the DCM level it moves
                    r = max(abs(dcm_vout(c, d) - dcm_vout(dict(c, circuit=dict(ci, L=nom["L"])), d))
                            for d in levels) / acq["noise_v"]
                else:
                    r = material_ratio(c, ["param_drift"])
                ci.update(saved)
                if r >= DRAW_RATIO or mag >= 0.25:
                    break
                mag = min(mag * 1.3, 0.25)
            if r >= MATERIAL_RATIO:
                drifted.append(name)
                ratios[f"param_drift ({name})"] = r
            else:
                ci[name] = nom[name]
        wanted = [w for w in wanted if w != "param_drift"] + ["param_drift"] * len(drifted)
        c["drifted"] = drifted
    if "inductor_saturation" in wanted:
        # knee between the two duty levels' peak currents: the high level runs into it
        peaks = sorted(d * nom["U"] / rload + ripple(nom, d) / 2 for d in levels)
        isat = peaks[0] + _u(rng, 0.3, 0.7) * (peaks[1] - peaks[0])
        base_s = _u(rng, 0.25, 0.4)

        def set_sat(s):
            c["sat"] = dict(s=min(base_s * s, 0.6), isat=isat, w=_u(rng, 0.08, 0.2) * isat)
        ratios["inductor_saturation"] = accept("inductor_saturation", ["inductor_saturation"], set_sat, tries=4)
    if "cap_dc_bias" in wanted:
        lo, hi = F["cl"]
        ci["cl0"] = _lu(rng, max(lo, 0.2 * nom["C"]), max(hi, 0.3 * nom["C"]))
        vm = nom["U"] * sum(levels) / 2
        keep = _u(rng, 0.4, 0.7)  # capacitance kept at the mean output voltage

        def set_bias(s):
            k = max(keep / s, 0.25)
            c["bias"] = dict(v0=vm / math.sqrt(1 / k ** 2 - 1), kept_at_mean=k)
        ratios["cap_dc_bias"] = accept("cap_dc_bias", ["cap_dc_bias"], set_bias, tries=4)
    # ---- acquisition in clean/single cases: the ADC aligned with the driver's delay
    if acq["adc_delay"] is None:
        acq["adc_delay"] = c["drive"]["tp"]
    # ---- the parasitics' own weight (not design-table effects): recorded
    if kind == "several":
        if "esl" not in wanted and ci["esl_c"] > 0:
            r = material_ratio(c, ["esl"])
            ratios["esl (C's own, as drawn)"] = r
            if r >= MATERIAL_RATIO and dcm:
                c["notes"].append("C's ESL material by the CCM stand-in, but the case is in DCM: not listed")
            elif r >= MATERIAL_RATIO:
                wanted.append("esl")
                ratios["esl"] = r
        if "load_esr" not in wanted:
            r = material_ratio(c, ["rcl"])
            ratios["load_esr (ceramic's own)"] = r
            if r >= MATERIAL_RATIO and dcm:
                c["notes"].append("Cl's ESR material by the CCM stand-in, but the case is in DCM: not listed")
            elif r >= MATERIAL_RATIO:
                wanted.append("load_esr")
                ratios["load_esr"] = r
        if ci["rl_drift"]:
            ratios["rl_drift (in switch_resistance)"] = material_ratio(c, ["rl_drift"])
    par_names = ["vin_sag", "bleeder", None if "load_esr" in wanted else "rcl",
                 None if "esl" in wanted else "esl", "esl_cl" if ci["esl_cl"] else None,
                 "core" if ci["rcore"] else None]
    par_names = [p for p in par_names if p]
    r = material_ratio(c, par_names)
    if kind == "clean":
        for _ in range(6):
            if r < CLEAN_RATIO:
                break
            ci["rsrc"] *= 0.3
            ci["rcl"] *= 0.3
            r = material_ratio(c, par_names)
    ratios["parasitics (" + ", ".join(par_names) + ")"] = r
    # near-ideal switches (not an effect here): their resistance comes out of the winding's
    c["switches_compensated"] = "switch_resistance" not in wanted
    # final list of effects (design-table names), sample_delay when the ADC is late
    effects = []
    for w in wanted:
        if w == "switch_resistance" and ratios.get("switch_resistance", 99) < MATERIAL_RATIO:
            continue
        if w in ("load_esr", "esl", "inductor_saturation", "cap_dc_bias") and ratios.get(w, 99) < MATERIAL_RATIO:
            c["notes"].append(f"{w} drawn but below the material ratio ({ratios.get(w):.2f}): not listed")
            continue
        effects.append(w)
    if topo == "async":
        frac = dcm_fraction(c)
        ratios["dcm (share of periods, linear stand-in)"] = frac
        if "dcm" not in effects and (dcm or frac > 0.02):
            effects.append("dcm")
            c["notes"].append(f"the diode buck dips into DCM in {100 * frac:.0f} % of the periods (PRBS transients)")
    net = acq["adc_delay"] - c["drive"]["tp"] + acq["aa_tau"]
    if abs(net) > 2e-9:
        effects.append("sample_delay")
    c["effects"] = effects
    c["material"] = ratios
    c["warmup"] = warmup_periods(c)
    return c


def warmup_periods(c):
    """Periods simulated before the record: 5 time constants of the slowest mode (from a start
    already near the periodic steady state), 100-600."""
    lin = truth_linear(c, ["param_drift", "switch_resistance", "load_esr", "bleeder"])
    rate = min(lin.slowest_rate(d) for d in c["levels"])
    n = int(min(max(math.ceil(5.0 / rate * c["nominal"]["fs"]), 100), 600))
    if "dcm" in c["effects"] and c.get("dcm_by_load"):
        # light-load DCM: vout settles with Ctot/(d i_avg/d vo), hundreds of periods
        tau = max(dcm_tau(c, d) for d in c["levels"])
        n = max(n, int(min(math.ceil(4.0 * tau * c["nominal"]["fs"]), 1500)))
    return n


def dcm_tau(c, d):
    """Time constant of vout in DCM at duty d: (C + Cl)/(d(mean il - load)/d vo) at the DCM
    operating point (the inductor current no state: it starts from zero every period)."""
    nom, ci = c["nominal"], c["circuit"]
    T, U, L = 1.0 / nom["fs"], nom["U"], ci["L"]

    def net(vo):
        ip = (U - vo) * d * T / L
        vf = diode_vf(ip / 2, c["diode"])
        avg = ip * (d * T + ip * L / (vo + vf)) / (2 * T)
        return avg - ((c["io"] or 0.0) + vo / ci["rbleed"] + (vo / c["rload"] if c["rload"] else 0.0))
    vo = dcm_vout(c, d)
    h = 1e-3 * U
    slope = abs(net(vo + h) - net(vo - h)) / (2 * h)
    return (ci["C"] + ci["cl0"]) / max(slope, 1e-9)


# --------------------------------------------------------------------------------------
# Netlist
# --------------------------------------------------------------------------------------

def _runs(duty):
    out, k0 = [], 0
    for k in range(1, len(duty) + 1):
        if k == len(duty) or duty[k] != duty[k0]:
            out.append((k0, k, float(duty[k0])))
            k0 = k
    return out


def gate_sources(c, duty, T):
    """Driver waveforms as PULSE current sources into 1 ohm nodes xh/xl (node volts = drive).

    High side: Vdrv minus one "off" pulse per period (the gate falls tp after the PWM's
    trailing edge over tf, rises again tp + dead after the next period start over tr), one
    train per run of equal duty; so a train's pulses start at offsets that differ from the
    next run's (no two trains put corners on the same instant). Low side (dead-time drive):
    one "on" pulse per period, tp + dead after the trailing edge until tp after the next
    period start. Complementary drive: the low side is Vdrv - v(xh) (an E source), both
    ramps centred on tp after the PWM instants. Period 0 starts with the low side on."""
    dv = c["drive"]
    V, tp, tr, tf, dead = dv["vdrv"], dv["tp"], dv["tr"], dv["tf"], dv["dead"]
    centred = dv["kind"] == "complementary"
    sh_f = tf / 2 if centred else 0.0
    sh_r = tr / 2 if centred else 0.0
    hs = [f"Ihs0 0 xh DC {_n(V)}"]
    # the previous period's off-interval lasts until the first turn-on
    t_on0 = tp + dead - sh_r
    hs.append(f"Ihsi xh 0 PULSE({_n(V)} 0 {_n(t_on0)} {_n(tr)} {_n(tr)} {_n(2 * len(duty) * T)} {_n(4 * len(duty) * T)} 1)")
    ls = []
    for j, (k0, k1, d) in enumerate(_runs(duty)):
        a = k0 * T + d * T + tp - sh_f           # HS fall start
        pw = (1 - d) * T + dead - sh_r + sh_f - tf  # until HS rise start
        hs.append(f"Ihs{j + 1} xh 0 PULSE(0 {_n(V)} {_n(a)} {_n(tf)} {_n(tr)} {_n(pw)} {_n(T)} {k1 - k0})")
        if dv["kind"] == "deadtime":
            a2 = k0 * T + d * T + tp + dead
            pw2 = (1 - d) * T - dead - tr
            if pw2 <= 0:
                raise ValueError("dead time longer than the off-time")
            ls.append(f"Ils{j + 1} 0 xl PULSE(0 {_n(V)} {_n(a2)} {_n(tr)} {_n(tf)} {_n(pw2)} {_n(T)} {k1 - k0})")
    if dv["kind"] == "deadtime":
        ls.insert(0, f"Ilsi 0 xl PULSE({_n(V)} 0 {_n(tp)} {_n(tf)} {_n(tf)} {_n(2 * len(duty) * T)} {_n(4 * len(duty) * T)} 1)")
    return "\n".join(hs), "\n".join(ls)


def corner_offsets(c, duty_levels, T):
    """Per-period offsets of every source corner, by source group (for the separation check)."""
    dv = c["drive"]
    tp, tr, tf, dead = dv["tp"], dv["tr"], dv["tf"], dv["dead"]
    centred = dv["kind"] == "complementary"
    sh_f = tf / 2 if centred else 0.0
    sh_r = tr / 2 if centred else 0.0
    groups = {"hs": [], "ls": [], "adc": []}
    for d in duty_levels:
        a = d * T + tp - sh_f
        b = T + tp + dead - sh_r
        groups["hs"] += [a, a + tf, b, b + tr]
        if dv["kind"] == "deadtime":
            a2 = d * T + tp + dead
            groups["ls"] += [a2, a2 + tr, T + tp, T + tp + tf]
    delta = c["acq"]["adc_delay"]
    groups["adc"] = [delta, delta + 1e-9, delta + T / 2 + 1e-9, delta + T / 2 + 2e-9]
    return {k: np.mod(np.array(v), T) for k, v in groups.items()}


def separate_corners(c, T, margin=50e-12):
    """Nudge the ADC instant (by 20 ps steps) and the dead time until no two corners of
    different sources lie within ``margin`` (near-coincident breakpoints make ngspice take a
    minimum step and can abort). Returns the nudges made."""
    def clash():
        g = corner_offsets(c, c["levels"], T)
        keys = [k for k in g if len(g[k])]
        for i, a in enumerate(keys):
            for b in keys[i + 1:]:
                dd = np.abs(g[a][:, None] - g[b][None, :])
                dd = np.minimum(dd, T - dd)
                if dd.min() < margin:
                    return a, b
        return None
    nudges = []
    for _ in range(200):
        cl = clash()
        if cl is None:
            return nudges
        if "adc" in cl:
            c["acq"]["adc_delay"] += 20e-12
            nudges.append("adc +20 ps")
        else:
            c["drive"]["dead"] += 100e-12
            nudges.append("dead +100 ps")
    raise RuntimeError("could not separate the sources' corners")


def winding_resistance(c):
    """The inductor's winding resistance in the netlist: RL (times a warm winding's drift);
    where the switches are near-ideal stand-ins (20-50 uOhm channels, not an effect of the
    case), less their mean resistance in the loop, so that the loop's resistance is RL as
    the user believes (a channel of a few uOhm makes ngspice's step collapse)."""
    nom, ci = c["nominal"], c["circuit"]
    rw = nom["RL"] * (1 + ci["rl_drift"])
    if c.get("switches_compensated"):
        dm = sum(c["levels"]) / 2
        if c["topology"] == "sync":
            rw -= dm * c["fet_hs"]["ron"] + (1 - dm) * c["fet_ls"]["ron"]
        else:
            rw -= dm * c["fet_hs"]["ron"]
        # and what the near-ideal input costs like a resistance: the source's (in series with
        # the high side while it conducts) and the hot loop's commutation (Lloop*il of
        # volt-seconds at each turn-on, Lloop*fs). A lightly damped stage (the pol family's
        # Q ~ 10) showed 14 uOhm of either as 0.36 mV of ringing residual.
        rw -= dm * ci["rsrc"] + ci["lloop"] * nom["fs"]
    return rw


def initial_state(c):
    """Period-start state of the truth circuit's linear stand-in at duty[0] (devices as
    resistances, the diode as its drop at the mean current, dead time as its volt-seconds)."""
    lin = truth_linear(c, ["param_drift", "switch_resistance", "load_esr", "esl", "esl_cl", "bleeder",
                           "core", "vin_sag", "diode", "dead_time", "rcl", "rl_drift",
                           "cap_dc_bias", "inductor_saturation"])
    d0 = float(c["_duty0"])
    x = lin.steady(d0)
    idx = lin.maps(d0)["idx"]
    m = lin.maps(d0)
    vo = float(m["g0"] @ x + m["c0"])
    st = dict(il=float(x[idx["iL"]]), vc=float(x[idx["vC"]]), vcl=float(x[idx["vCl"]]), vo=vo,
              ic=float(x[idx["iC"]]) if "iC" in idx else 0.0, icl=float(x[idx["iCl"]]) if "iCl" in idx else 0.0)
    if c["topology"] == "async" and "dcm" in c["effects"]:
        vo = dcm_vout(c, d0)
        st.update(il=0.0, vc=vo, vcl=vo, vo=vo, ic=0.0, icl=0.0)
    return st


def dcm_vout(c, d):
    """Steady vout of the diode buck in DCM at duty d (ideal switch, the diode's drop at half
    the peak current, the winding's drop neglected): the mean inductor current, a triangle of
    peak (U - vo)*d*T/L lasting d*T + its fall time, equals the load's."""
    nom, ci = c["nominal"], c["circuit"]
    T, U, L = 1.0 / nom["fs"], nom["U"], ci["L"]
    lo, hi = 0.0, U
    for _ in range(80):
        vo = (lo + hi) / 2
        ip = (U - vo) * d * T / L
        vf = diode_vf(ip / 2, c["diode"])
        avg = ip * (d * T + ip * L / (vo + vf)) / (2 * T)
        load = (c["io"] or 0.0) + vo / ci["rbleed"] + (vo / c["rload"] if c["rload"] else 0.0)
        lo, hi = (vo, hi) if avg > load else (lo, vo)
    return vo


def netlist(c, duty, rawfile, reltol=1e-4, steps=150):
    nom, ci, acq = c["nominal"], c["circuit"], c["acq"]
    T = 1.0 / nom["fs"]
    U = nom["U"]
    c["_duty0"] = float(duty[0])
    st = initial_state(c)
    hs_src, ls_src = gate_sources(c, duty, T)
    L = []
    a = L.append
    a(f"* third generator: {c['family']} {c['kind']} seed {c['seed']} ({c['topology']}, {c['drive']['kind']} drive)")
    # --- input: source with series resistance, bulk and decoupling capacitors, hot loop
    a(f"Vsrc vsup 0 DC {_n(U)}")
    a(f"Rsrc vsup vb {_n(ci['rsrc'])}")
    if ci["cbulk"]:
        a(f"Cbulk vb nbk {_n(ci['cbulk'])} IC={_n(U)}")
        a(f"Rbulk nbk 0 {_n(ci['rbulk'])}")
    a(f"Cdec vb ndc {_n(ci['cdec'])} IC={_n(U)}")
    a(f"Rdec ndc 0 {_n(ci['rdec'])}")
    a(f"Lhl vb vd {_n(ci['lloop'])}")
    a(f"Rhl vb vd {_n(ci['rloop'])}")
    # --- gate drivers
    a(hs_src)
    a("Rxh xh 0 1")
    a("Ehs dh sw xh 0 1")
    a(f"Rdh dh gh {_n(c['drive']['rdrv'])}")
    a(fet_subckt("FETH", c["fet_hs"]))
    a("Xhs vd gh sw FETH")
    if c["topology"] == "sync":
        if c["drive"]["kind"] == "deadtime":
            a(ls_src)
            a("Rxl xl 0 1")
            a("Els dl 0 xl 0 1")
        else:
            a("Els dl1 0 xh 0 -1")
            a(f"Vlsb dl dl1 DC {_n(c['drive']['vdrv'])}")
        a(f"Rdl dl gl {_n(c['drive']['rdrv'])}")
        a(fet_subckt("FETL", c["fet_ls"]))
        a("Xls sw gl 0 FETL")
    else:
        a("Dfw 0 sw DFW")
        a(_diode_card("DFW", c["diode"]))
    a(f"Csw sw 0 {_n(ci['csw'])}")
    if ci.get("snubber"):
        a(f"Rsn sw nsn {_n(ci['snubber']['r'])}")
        a(f"Csn nsn 0 {_n(ci['snubber']['c'])} IC=0")
    # --- inductor (optionally saturating), winding, core loss, ammeter
    if c["sat"]:
        s = c["sat"]
        a("Vls sw nli 0")
        a(f"Lm nli nsat {_n(ci['L'])} IC={_n(st['il'])}")
        x = f"((abs(i(Vls))-{_n(s['isat'])})/{_n(s['w'])})"
        a(f"Bsat nsat nl V = -{_n(s['s'])}*0.5*(1+{x}/sqrt(1+{x}*{x}))*(v(nli)-v(nsat))")
    else:
        a(f"Lm sw nl {_n(ci['L'])} IC={_n(st['il'])}")
    rw = winding_resistance(c)
    a(f"Rw nl nam {_n(rw)}")
    if ci["rcore"]:
        a(f"Rcore sw nl {_n(ci['rcore'])}")
    a("Vam nam out 0")
    # --- main capacitor (ESR Rc, ESL)
    if ci["esl_c"] > 0:
        a(f"Rcm out nc1 {_n(ci['Rc'])}")
        a(f"Lcm nc1 nc2 {_n(ci['esl_c'])} IC={_n(st['ic'])}")
        a(f"Cm nc2 0 {_n(ci['C'])} IC={_n(st['vc'])}")
    else:
        a(f"Rcm out nc2 {_n(ci['Rc'])}")
        a(f"Cm nc2 0 {_n(ci['C'])} IC={_n(st['vc'])}")
    # --- load capacitor (ESR, ESL, optionally DC-biased)
    a(f"Rcl out nl1 {_n(max(ci['rcl'], 1e-6))}")
    nodec = "nl1"
    if ci["esl_cl"] > 0:
        a(f"Lcl nl1 nl2 {_n(ci['esl_cl'])} IC={_n(st['icl'])}")
        nodec = "nl2"
    if c["bias"]:
        v0, cl0 = c["bias"]["v0"], ci["cl0"]
        q0 = v0 * math.asinh(st["vcl"] / v0)     # v(q) = charge / Cl0
        a(f"Vqm {nodec} ncv 0")
        a("Fq 0 q Vqm 1")
        a(f"Cq q 0 {_n(cl0)} IC={_n(q0)}")
        a(f"Bcv ncv 0 V = {_n(v0)}*sinh(v(q)/{_n(v0)})")
    else:
        a(f"Clo {nodec} 0 {_n(ci['cl0'])} IC={_n(st['vcl'])}")
    # --- load and feedback divider
    if c["rload"]:
        a(f"Rload out 0 {_n(c['rload'])}")
    else:
        a(f"Iload out 0 DC {_n(c['io'])}")
    a(f"Rfb out 0 {_n(ci['rbleed'])}")
    # --- the ADC's anti-alias filter and the forced time points at its sampling instants
    save = ["v(out)", "i(vam)", "v(sw)"]
    if acq["aa_tau"] > 0:
        a("Eaa nab 0 out 0 1")
        a(f"Raa nab vaa {_n(1e3)}")
        a(f"Caa vaa 0 {_n(acq['aa_tau'] / 1e3)} IC={_n(st['vo'])}")
        save.append("v(vaa)")
    a(f"Vadc nadc 0 PULSE(0 1 {_n(acq['adc_delay'])} 1e-9 1e-9 {_n(T / 2)} {_n(T)} {len(duty) + 1})")
    a("Radc nadc 0 1k")
    a(".save " + " ".join(save))
    max_step = T / steps
    a(f".options reltol={_n(reltol)} abstol=1e-9 vntol=1e-6 chgtol=1e-15 itl4=100 method=trap "
      f"trtol={_n(c.get('trtol', 7))}")
    a(f".tran {_n(max_step)} {_n(len(duty) * T)} 0 {_n(max_step)} uic")
    a(".control")
    a("set filetype=binary")
    a("run")
    a(f"write {rawfile} " + " ".join(save))
    a("quit")
    a(".endc")
    a(".end")
    return "\n".join(L) + "\n"


# --------------------------------------------------------------------------------------
# Running ngspice
# --------------------------------------------------------------------------------------

def read_raw(path):
    """An ngspice raw file (binary, real) -> {lower-case name: float64 array}.

    Header lines "Key: value" up to "Binary:"; the variables listed one a line after
    "Variables:" as "<index> <name> <type>"; then No. Points records of No. Variables
    little-endian doubles."""
    with open(path, "rb") as fh:
        blob = fh.read()
    marker = b"\nBinary:\n"
    cut = blob.find(marker)
    if cut < 0:
        raise RuntimeError(f"{path}: not a binary raw file")
    head = blob[:cut].decode("latin-1").split("\n")
    start = cut + len(marker)
    info, names, in_vars = {}, [], False
    for line in head:
        if in_vars:
            parts = line.split()
            if len(parts) >= 3 and parts[0].isdigit():
                names.append(parts[1].lower())
                continue
            in_vars = False
        if line.startswith("Variables:"):
            in_vars = True
            continue
        if ":" in line:
            key, val = line.split(":", 1)
            info[key.strip().lower()] = val.strip()
    if "complex" in info.get("flags", "").lower():
        raise RuntimeError(f"{path}: complex data")
    nvar, npts = int(info["no. variables"]), int(info["no. points"])
    if len(names) != nvar:
        raise RuntimeError(f"{path}: {len(names)} names for {nvar} variables")
    data = np.frombuffer(blob, dtype="<f8", count=nvar * npts, offset=start).reshape(npts, nvar)
    return {nm: data[:, j].copy() for j, nm in enumerate(names)}


def default_steps(c):
    """Max time step T/steps: T/120 for the synchronous buck (its samples agree with T/400 at
    reltol 1e-5 within 0.05 mV); the diode buck with a snubber T/200 (within 0.07 mV of T/1000
    at reltol 1e-5), without one T/400: its undamped DCM ring's phase at the next turn-on sets
    each period's energy (T/120 was 5 mV off in a 1 MHz DCM case; even T/400 against T/1000
    differed by 11 mV in a lab case: the known limit of that circuit)."""
    if c["topology"] == "async":
        return 200 if c["circuit"].get("snubber") else 400
    return 120


# Longest a transient may run [s]: the longest good case takes about 6 min on two busy cores;
# seed 2302's thesis buck ran 37 min at reltol 1e-4 without finishing.
NGSPICE_TIMEOUT = 1200.0


def _run(c, duty, reltol, workdir):
    nom = c["nominal"]
    T = 1.0 / nom["fs"]
    with tempfile.TemporaryDirectory(prefix="third_") as tmp:
        work = os.path.abspath(workdir or tmp)
        os.makedirs(work, exist_ok=True)
        raw = os.path.join(work, "third.raw")
        cir = os.path.join(work, "third.cir")
        if os.path.exists(raw):
            os.remove(raw)
        with open(cir, "w") as fh:
            fh.write(netlist(c, duty, raw, reltol=reltol, steps=c.get("steps", default_steps(c))))
        try:
            proc = subprocess.run(["ngspice", "-b", cir], cwd=work, capture_output=True, text=True, timeout=NGSPICE_TIMEOUT)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"ngspice failed: timed out after {NGSPICE_TIMEOUT:g} s at reltol {reltol:g}") from None
        log = proc.stdout + proc.stderr
        if workdir:
            with open(os.path.join(work, "ngspice.log"), "w") as fh:
                fh.write(log)
        vec = read_raw(raw) if os.path.exists(raw) else None
    # ngspice -b exits 0 after an aborted transient: require tstop reached
    if vec is None or abs(vec["time"][-1] - len(duty) * T) > 1e-6 * T:
        tail = "\n".join(log.strip().splitlines()[-12:])
        raise RuntimeError(f"ngspice failed (exit {proc.returncode}):\n{tail}")
    return vec


def transient(c, duty, workdir=None):
    """Simulate the warm-up (``c['warmup']`` periods at duty[0]) and ``duty``; the vectors with
    time measured from the first recorded period's start. Retries once at reltol 1e-3 when
    ngspice gives up ("timestep too small") or runs past ``NGSPICE_TIMEOUT``."""
    if shutil.which("ngspice") is None:
        raise RuntimeError("ngspice not found on PATH")
    T = 1.0 / c["nominal"]["fs"]
    separate_corners(c, T)
    full = np.concatenate([np.full(c["warmup"], duty[0]), duty])
    reltol = c.get("reltol", 1e-4)
    try:
        vec = _run(c, full, reltol, workdir)
    except RuntimeError as e:
        if reltol >= 1e-3 or not any(k in str(e).lower() for k in ("too small", "timed out")):
            raise
        print(f"third: {str(e).splitlines()[-1].strip()}; retrying at reltol 1e-3", file=sys.stderr)
        c["reltol"] = 1e-3
        c["notes"].append("ngspice retried at reltol 1e-3")
        vec = _run(c, full, 1e-3, workdir)
    vec["time"] = vec["time"] - c["warmup"] * T
    return vec


def window_mean(t, y, t0, t1):
    """Mean of y over [t0, t1], y linear between ngspice's points (the cumulative trapezoid
    interpolated at both ends, so no partial step is lost)."""
    cum = np.concatenate(([0.0], np.cumsum(np.diff(t) * (y[1:] + y[:-1]) / 2)))

    def at(x):
        i = int(np.clip(np.searchsorted(t, x, side="right") - 1, 0, len(t) - 2))
        yx = y[i] + (y[i + 1] - y[i]) * (x - t[i]) / (t[i + 1] - t[i])
        return cum[i] + (x - t[i]) * (y[i] + yx) / 2
    return float((at(t1) - at(t0)) / (t1 - t0))


def sample(t, y, instants):
    """Linear interpolation of ngspice's points at the instants (a time point is forced at
    each ADC instant, so this is the simulator's own value there)."""
    return np.interp(instants, t, y)


def edge_offsets(t, vsw, U, n, T):
    """Median offsets after each period start of the switch node's rise (first point at or
    above 0.9 U in the first 45 % of the period) and fall (first point at or below 0.1 U after
    that): the real switching instants, for the truth. A DCM ring that reaches 0.9 U before
    the turn-on counts as the rise (seen only in deep DCM; the median ignores a few)."""
    k = np.floor(t / T).astype(int)
    ok = (k >= 0) & (k < n)
    off = t - k * T
    rise = np.full(n, np.nan)
    fall = np.full(n, np.nan)
    hi = ok & (vsw >= 0.9 * U) & (off < 0.45 * T)
    kk, first = np.unique(k[hi], return_index=True)
    rise[kk] = off[hi][first]
    r_at = np.full(n, np.inf)
    r_at[kk] = rise[kk]
    lo = ok & (vsw <= 0.1 * U)
    lo &= off > r_at[np.clip(k, 0, n - 1)]
    kk, first = np.unique(k[lo], return_index=True)
    fall[kk] = off[lo][first]
    return float(np.nanmedian(rise)) if np.isfinite(rise).any() else float("nan"), \
        float(np.nanmedian(fall)) if np.isfinite(fall).any() else float("nan")


def drain_current(p, vgs, vds):
    """Drain current of a FET subcircuit by an ngspice operating point [A]."""
    with tempfile.TemporaryDirectory(prefix="third_fet_") as tmp:
        cir = os.path.join(tmp, "fet.cir")
        with open(cir, "w") as fh:
            fh.write("* fet\n" + fet_subckt("FETX", p) + f"\nVg g 0 {_n(vgs)}\nVd d 0 {_n(vds)}\nX1 d g 0 FETX\n"
                     ".control\nop\necho DRAIN_I $&i(vd)\nquit\n.endc\n.end\n")
        out = subprocess.run(["ngspice", "-b", cir], capture_output=True, text=True).stdout
    for line in out.splitlines():
        if line.startswith("DRAIN_I"):
            return -float(line.split()[1])
    raise RuntimeError("fet: no operating point")


def measure_ron(p, vgs):
    """On-resistance of a FET subcircuit at Vds = 10 mV [ohm]."""
    return 0.01 / drain_current(p, vgs, 0.01)


# --------------------------------------------------------------------------------------
# The data set
# --------------------------------------------------------------------------------------

def duty_sequence(c, periods):
    lo, hi = c["levels"]
    return prbs(periods, c["seed"], c["bit_periods"], lo, hi)


def simulate(c, duty, workdir=None):
    """Noise-free samples (vout read through the acquisition's filter, il) at each period
    start + adc_delay, and the raw transient's facts."""
    clock = time.perf_counter()
    vec = transient(c, duty, workdir)
    seconds = time.perf_counter() - clock
    T = 1.0 / c["nominal"]["fs"]
    n = len(duty)
    ts = np.arange(n) * T + c["acq"]["adc_delay"]
    vname = "v(vaa)" if c["acq"]["aa_tau"] > 0 else "v(out)"
    t = vec["time"]
    vout = sample(t, vec[vname], ts)
    il = sample(t, vec["i(vam)"], ts)
    rise, fall = edge_offsets(t, vec["v(sw)"], c["nominal"]["U"], n, T)
    # period averages of the real node (trapezoid over ngspice's points) for the truth
    vmean = window_mean(t, vec["v(out)"], 0.0, n * T)
    imean = window_mean(t, vec["i(vam)"], 0.0, n * T)
    return dict(vout=vout, il=il, seconds=seconds, points=int(len(t)), rise=rise, fall=fall,
                vout_mean=vmean, il_mean=imean)


def quieter(c, scale):
    """Case ``c`` with its sensor noise (vout and il) scaled by ``scale`` > 0, all else as drawn."""
    if not scale > 0:
        raise ValueError(f"noise scale {scale} must be positive")
    acq = dict(c["acq"], noise_v=c["acq"]["noise_v"] * scale, noise_i=c["acq"]["noise_i"] * scale)
    return dict(c, acq=acq)


def _public(c):
    """The case without its private working fields (JSON-safe)."""
    return {k: v for k, v in c.items() if not k.startswith("_")}


def generate(c, periods=3001, workdir=None):
    """(csv text, truth dict) of case ``c``."""
    nom, acq = c["nominal"], c["acq"]
    T = 1.0 / nom["fs"]
    duty = duty_sequence(c, periods)
    sim = simulate(c, duty, workdir)
    rng = np.random.default_rng([c["seed"], 99, list(FAMILIES).index(c["family"]), KINDS.index(c["kind"])])
    vout = sim["vout"] + rng.normal(0.0, acq["noise_v"], periods)
    il = sim["il"] + rng.normal(0.0, acq["noise_i"], periods)
    vout = (1 + acq["vout_gain"]) * vout + acq["vout_offset"]
    il = (1 + acq["il_gain"]) * il + acq["il_offset"]
    io = np.full(periods, 0.0 if c["rload"] else c["io"])
    meta = [f"# fs = {_n(nom['fs'])}", f"# U = {_n(nom['U'])}", f"# L = {_n(nom['L'])}",
            f"# RL = {_n(nom['RL'])}", f"# C = {_n(nom['C'])}", f"# Rc = {_n(nom['Rc'])}"]
    if c["rload"]:
        meta.append(f"# rload = {_n(c['rload'])}")
    cols = ["time", "duty", "vin", "io", "vout"] + (["il"] if acq["with_il"] else [])
    rows = [",".join(cols)]
    U = nom["U"]
    for k in range(periods):
        vals = [repr(k * T), repr(float(duty[k])), repr(U), repr(float(io[k])), repr(float(vout[k]))]
        if acq["with_il"]:
            vals.append(repr(float(il[k])))
        rows.append(",".join(vals))
    # the Cl to score: the linear one, or the biased ceramic's small-signal value at the mean
    vm_noise_free = float(np.mean(sim["vout"]))
    ci = c["circuit"]
    if c["bias"]:
        cl_true = float(bias_cl(sim["vout_mean"], ci["cl0"], c["bias"]))
    else:
        cl_true = ci["cl0"]
    truth = _public(c)
    truth.update(
        periods=periods,
        cl_true=cl_true,
        cl_true_note=("small-signal Cl0/sqrt(1+(v/V0)^2) at the record's mean vout" if c["bias"] else "linear Cl"),
        ngspice_seconds=sim["seconds"],
        ngspice_points=sim["points"],
        reltol_used=c.get("reltol", 1e-4),
        vout_mean=sim["vout_mean"], vout_sample_mean=vm_noise_free, il_mean=sim["il_mean"],
        switch_node_rise_offset=sim["rise"], switch_node_fall_offset=sim["fall"],
        sample_delay_after_driver=acq["adc_delay"] + acq["aa_tau"] - c["drive"]["tp"],
        columns=cols,
        always_present=[
            "input source series resistance (vin written as the nominal U)", "bulk and decoupling capacitors",
            "hot-loop inductance with damping", "switch-node capacitance and the devices' junction capacitances",
            "gate driver propagation delay and finite edges", "feedback divider at the output",
            "load capacitor ESR" + (" and ESL" if ci["esl_cl"] else ""),
        ] + (["inductor core loss (parallel resistance)"] if ci["rcore"] else []),
        scored_effects=[e for e in c["effects"] if e != "sample_delay"],
    )
    truth["fet_hs"]["ron_measured"] = measure_ron(c["fet_hs"], c["drive"]["vdrv"])
    if c["fet_ls"]:
        truth["fet_ls"]["ron_measured"] = measure_ron(c["fet_ls"], c["drive"]["vdrv"])
    if c["diode"]:
        truth["diode"]["vf_at_mean_current"] = diode_vf(abs(sim["il_mean"]), c["diode"])
    return "\n".join(meta + rows) + "\n", truth


def parser():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add = p.add_argument
    add("--family", choices=tuple(FAMILIES), required=True)
    add("--case", dest="kind", choices=KINDS, required=True)
    add("--seed", type=int, default=1)
    add("--effect", choices=SINGLE_EFFECTS, help="the effect of a --case single (default: drawn)")
    add("--no-il", action="store_true", help="omit the il column (a vout-only capture)")
    add("--noise-scale", type=float, default=1.0,
        help="scale the drawn sensor noise (0.1: a bench ten times quieter, e.g. an averaging scope)")
    add("--aa-tau", type=float,
        help="the vout reading's RC anti-alias filter, its time constant as a fraction of the period "
             "(overrides the draw; 0 = none)")
    add("--adc-delay", type=float,
        help="the ADC's sampling instant after the period start, as a fraction of the period (overrides the draw)")
    add("--periods", type=int, default=3001)
    add("--out", default="-", help="CSV file ('-' = stdout)")
    add("--truth", help="JSON file with everything the run used")
    add("--workdir", help="keep the netlist, raw file and ngspice log here")
    return p


def main(argv=None):
    a = parser().parse_args(argv)
    c = draw(a.family, a.kind, a.seed, effect=a.effect, with_il=False if a.no_il else None)
    c = quieter(c, a.noise_scale)
    if a.aa_tau is not None:
        c["acq"]["aa_tau"] = a.aa_tau / c["nominal"]["fs"]
    if a.adc_delay is not None:
        c["acq"]["adc_delay"] = a.adc_delay / c["nominal"]["fs"]
    text, truth = generate(c, a.periods, a.workdir)
    if a.out == "-":
        sys.stdout.write(text)
    else:
        with open(a.out, "w") as fh:
            fh.write(text)
    if a.truth:
        with open(a.truth, "w") as fh:
            json.dump(truth, fh, indent=2, default=float)
            fh.write("\n")
    print(f"third: {a.family}/{a.kind} seed {a.seed}: effects {', '.join(c['effects']) or 'none'}; "
          f"Cl {truth['cl_true'] * 1e6:.4g} uF; ngspice {truth['ngspice_seconds']:.1f} s "
          f"({truth['ngspice_points']} points, warm-up {c['warmup']} periods)", file=sys.stderr)


if __name__ == "__main__":
    main()
