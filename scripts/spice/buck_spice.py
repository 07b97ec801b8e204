#!/usr/bin/env python3
"""Buck converter simulated in ngspice: ideal switch, MOSFET synchronous, or diode asynchronous.

Independent "real plant" reference: a netlist next to this file is driven by
a per-period duty sequence with trailing-edge PWM and the transient is reduced
to per-switching-period data (period-start samples and exact period
averages).  Only numpy is required (plus ``ngspice`` on PATH).

Circuits (``circuit=`` / ``--circuit``):

  ideal  ``buck_ideal.cir``: ideal switch node, the averaged model's physics
  sync   ``buck_sync.cir``: two VDMOS MOSFETs (Rds_on, body diodes,
         capacitances), gate drivers with finite ramps and a dead time
  async  ``buck_async.cir``: one VDMOS high-side switch and a Schottky
         freewheeling diode (forward drop; DCM at light load, with ringing)

All three share the passive network and its states:

    L  dil/dt = u_sw - RL*il - vo
    C  dvc/dt = (vo - vc)/Rc
    Cl dvo/dt = il - io - (vo - vc)/Rc

Period k spans [k*T, (k+1)*T); the PWM signal is high on [k*T, k*T + d_k*T).
Ideal: u_sw = U while the PWM is high, 0 otherwise.

Switch-node edges (ideal): SPICE needs finite edges, so each ideal step is replaced by
a linear ramp of width ``edge`` (default 10 ps) *centred* on the ideal
switching instant.  Each period's volt-seconds are then exactly U*d_k*T and the
state after an edge equals the ideal one; only inside an edge does il deviate,
and the il period-start sample (linearly interpolated at k*T, the middle of
an edge) is off by at most U*edge/(4*L), about 9 uA with the defaults.  Duties
within 2*edge/T of 0 or 1 get proportionally shorter edges; period 0 rises
over [0, edge/2] (nothing can start before t = 0), see _switch_sources.

Gate timing (sync/async): gate voltages ramp linearly over ``gate_rise``
(default 5 ns), ramps centred on the nominal instants.  async: the high-side
gate follows the PWM signal.  sync: a dead-time generator delays each turn-on
by ``dead_time`` (30 ns): high side on over [k*T + dead_time, k*T + d_k*T],
low side on over [k*T + d_k*T + dead_time, (k+1)*T].  Gate pulses shorter
than one ramp are swallowed.  ``warmup`` periods at duty[0] are simulated
first and dropped (the real circuits start from an approximate DC point).

Run time for 3001 PRBS periods (0.4/0.6, Cl = 10 uF, one core): ideal ~3 s,
sync ~22 s, async ~17-19 s.

CLI example:
    python scripts/spice/buck_spice.py --periods 3001 --cl 10e-6 --io 1 --seed 1 --out data.csv
    python scripts/spice/buck_spice.py --circuit sync --warmup 200 --out sync.csv --truth sync.json
"""

import argparse
import json
import math
import os
import re
import shutil
import string
import subprocess
import sys
import tempfile
import time as _time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
CIRCUITS = ("ideal", "sync", "async")
TEMPLATES = {c: os.path.join(HERE, f"buck_{c}.cir") for c in CIRCUITS}
TEMPLATE = TEMPLATES["ideal"]

# Solver settings.  The circuit is linear, so the step size is set by max_step
# (tolerances barely matter); trapezoidal integration is 2nd order and beat
# gear.  Checked against an exact matrix-exponential solution over 3001 PRBS
# periods (Cl = 0.2u/10u/100u): at T/100 the errors are <= 2 uV in vout_avg,
# <= 6 uA in il_avg, <= 11 uA in il_start, ~3 s wall time.
DEFAULT_STEPS_PER_PERIOD = 100
SOLVER_OPTIONS = dict(method="trap", reltol=1e-6, abstol=1e-12, vntol=1e-9, chgtol=1e-16)

# Solver settings of the real (nonlinear) circuits.  Accuracy, measured as
# the largest difference over 300 PRBS periods (Cl = 10u) against runs with
# max_step T/1600 and reltol 3e-6 (sync: T/400, reltol 1e-5): sync at T/100
# <= 20 uV in vout_avg, <= 0.1 mA in il_avg/il_start; async at T/400 (the
# diode and the DCM ringing need the finer step: T/100 was off by 0.3-0.8 mV)
# <= 0.25 mV and <= 0.6 mA, in CCM (io = 3 A) and DCM (io = 0.1 A).  Tighter
# tolerances on the sync circuit (reltol <= 3e-6 with abstol 1e-10) abort
# with "timestep too small" at the gate-drive branches: keep these.  rshunt
# (1e12 ohm from every node to ground) keeps the floating gate drive posed;
# itl4 = 50 Newton iterations per time point (default 10).
REAL_STEPS_PER_PERIOD = {"sync": 100, "async": 400}
REAL_SOLVER_OPTIONS = dict(method="trap", reltol=1e-4, abstol=1e-9, vntol=1e-6, chgtol=1e-14,
                           rshunt=1e12, itl4=50)

# Power MOSFET (ngspice VDMOS, n-channel), roughly a 30 V / 10 mOhm part.
# Kp, Rd and Rs are derived from rds_on and the gate drive in mosfet_params;
# the built-in body diode is Is/N/Rb (Vf about 0.77 V at 2 A), its junction
# capacitance Cjo/Vj/M is the output capacitance Coss; TT = 0 (no reverse recovery).
MOSFET_DEFAULTS = dict(Vto=2.5, Rg=1.0, Cgs=1.5e-9, Cgdmax=0.5e-9, Cgdmin=50e-12, A=0.5,
                       Is=1e-12, N=1.0, Rb=20e-3, Cjo=400e-12, Vj=0.7, M=0.5, TT=0.0)
# Schottky freewheeling diode, roughly a 40 V / 3 A part: Vf = 0.454 V at 3 A
# (0.372 V at 1 A, 0.284 V at 0.1 A), Cj(0) = 300 pF.
DIODE_DEFAULTS = dict(Is=5e-6, N=1.1, Rs=25e-3, Cjo=300e-12, Vj=0.4, M=0.5)
# Switch-node RC snubber of the asynchronous buck: damps the DCM ringing (L
# with ~200 pF of diode and MOSFET capacitance, ~3.5 MHz, Z0 ~ 130 ohm) within
# a few cycles; without it the ring lasts the whole idle interval and the
# period-start il carries up to ~50 mA of it.  Costs ~Csn*U^2*fs = 22 mW.
# None or (0, 0) leaves it out.
SNUBBER_DEFAULT = (47.0, 470e-12)
# inductor_saturation: the step in L at isat is found by the truncation-error control only.
# Ideal circuit: trtol 0.1 (ngspice's default is 7) resolves it to < 0.1 mV in vout and
# < 0.4 mA in il against the plant's exact crossings (tests/python/test_ngspice.py; 1.5 mV and
# 8 mA at the default).  The synchronous buck aborts with trtol <= 1 ("timestep too small" at
# the gate drive), so the real circuits keep their own; the crossings are then resolved to
# first order in the step, and they take T/400 (sync at T/100 was off by 11 mV in vout_avg and
# 48 mA in il_avg against T/1600; at T/400, sync and async: <= 2 mV, <= 10 mA; 300 PRBS
# periods, io = 2 A, isat = 2.3 A, 30 %).
SATURATION_TRTOL = 0.1
SATURATION_REAL_STEPS_PER_PERIOD = 400


def prbs_duty(n_periods, bit_periods=8, low=0.4, high=0.6, seed=1):
    """Per-period duty: a PRBS held for ``bit_periods`` periods per bit.

    Bits come from a maximal-length 15-bit Fibonacci LFSR (x^15 + x^14 + 1,
    period 32767 bits); ``seed`` is the initial register state (taken mod
    2^15, must be non-zero).  Bit 1 -> ``high``, bit 0 -> ``low``.
    """
    state = int(seed) & 0x7FFF
    if state == 0:
        raise ValueError("seed must be non-zero mod 2**15")
    n_bits = -(-int(n_periods) // int(bit_periods))
    bits = np.empty(n_bits, dtype=bool)
    for i in range(n_bits):
        new = ((state >> 14) ^ (state >> 13)) & 1
        state = ((state << 1) | new) & 0x7FFF
        bits[i] = new
    return np.where(np.repeat(bits, bit_periods)[:n_periods], high, low).astype(float)


def _num(x):
    """Float formatted for SPICE (repr is exact and never uses unit suffixes)."""
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite circuit value {x}")
    return repr(x)


def _switch_sources(duty, T, U, edge):
    """SPICE lines for the switch waveform: one PULSE current source per run of
    equal duty, all injecting into node x (summed by a 1 ohm resistor).

    Only PULSE sources with width < T are used: ngspice 39 chains the
    breakpoints of a PWL current source by a 3-ulp time comparison, which
    breaks when another source's (rounded) breakpoint lands on the same edge,
    and PULSE matches its corners with a tolerance of 1e-7*PW, which must stay
    well below the edge width.
    """
    specs = []

    def pulse(td, e, pw, per, count, tr=None):
        # PULSE(V1 V2 TD TR TF PW PER NP)
        specs.append(f"PULSE(0 {_num(U)} {_num(td)} {_num(e if tr is None else tr)} {_num(e)} "
                     f"{_num(pw)} {_num(per)} {count})")

    n, k0 = len(duty), 0
    while k0 < n:
        d, k1 = duty[k0], k0
        while k1 < n and duty[k1] == d:
            k1 += 1
        if d > 0:
            # Edge no wider than half the on- or off-time keeps PW > 0 (PW = 0
            # would make ngspice substitute its default) and the pulse < T.
            e = edge if d >= 1 else min(edge, d * T / 2, (1 - d) * T / 2)
            ks = k0
            if k0 == 0:
                # A pulse cannot start before t = 0: period 0 rises over
                # [0, e/2] and its fall is delayed by e/4, which restores the
                # area U*d*T (the lost U*e/4 is recovered before the fall).
                pulse(0.0, e, d * T - 3 * e / 4, 2 * T, 1, tr=e / 2)
                ks = 1
            if d < 1 and k1 > ks:
                pulse(ks * T - e / 2, e, d * T - e, T, k1 - ks)
            elif d >= 1:
                # Fully-on periods: each pulse's fall overlaps the next one's
                # rise (the sum stays U), so alternate two sources, PER = 2T.
                for j in range(ks, min(ks + 2, k1)):
                    pulse(j * T - e / 2, e, T - e, 2 * T, len(range(j, k1, 2)))
        k0 = k1
    return "\n".join(f"Isw{i} 0 x {spec}" for i, spec in enumerate(specs))


def _read_raw(path):
    """Parse an ngspice raw file (binary or ascii, real data) -> {name: array}."""
    with open(path, "rb") as f:
        blob = f.read()
    m = re.search(rb"^(Binary|Values):\r?\n", blob, re.M)
    if m is None:
        raise RuntimeError(f"{path}: no Binary:/Values: section")
    header = blob[: m.start()].decode("latin-1")
    hdr = {}
    names = []
    in_vars = False
    for line in header.splitlines():
        if in_vars and line.startswith(("\t", " ")):
            names.append(line.split()[1].lower())
            continue
        in_vars = line.startswith("Variables:")
        if ":" in line:
            k, v = line.split(":", 1)
            hdr[k.strip().lower()] = v.strip()
    nvar, npts = int(hdr["no. variables"]), int(hdr["no. points"])
    if "complex" in hdr.get("flags", "") or len(names) != nvar:
        raise RuntimeError(f"{path}: unexpected raw header {hdr}")
    if m.group(1) == b"Binary":
        data = np.frombuffer(blob, dtype="<f8", count=nvar * npts, offset=m.end())
    else:
        toks = blob[m.end():].split()
        # ascii layout: "<index> v0 v1 ... " per point
        data = np.array(toks, dtype=float).reshape(npts, nvar + 1)[:, 1:]
    data = data.reshape(npts, nvar)
    return {n: data[:, i].copy() for i, n in enumerate(names)}


def _period_reduce(t, y, T, n):
    """Values at k*T and exact averages over [k*T, (k+1)*T] of a sampled signal.

    ngspice's output is treated as piecewise linear between its own time
    points (which include every switching edge as a breakpoint): the integral
    is the trapezoid rule, the value at k*T is a linear interpolation.
    """
    tk = np.arange(n + 1) * T
    cum = np.concatenate(([0.0], np.cumsum(np.diff(t) * (y[1:] + y[:-1]) / 2)))
    i = np.clip(np.searchsorted(t, tk, side="right") - 1, 0, len(t) - 2)
    yk = y[i] + (y[i + 1] - y[i]) * (tk - t[i]) / (t[i + 1] - t[i])
    F = cum[i] + (tk - t[i]) * (y[i] + yk) / 2
    return yk[:n], np.diff(F) / T


def _model_card(name, kind, params):
    """A one-line .model card from a parameter dict (values via _num)."""
    return f".model {name} {kind}(" + " ".join(f"{k}={_num(v)}" for k, v in params.items()) + ")"


def mosfet_params(rds_on=10e-3, v_drive=10.0, mosfet=None):
    """VDMOS model parameters with an on-resistance of ``rds_on`` at Vgs = ``v_drive``.

    ngspice's VDMOS is the level-1 MOSFET plus series Rd and Rs; at small Vds
    its on-resistance is Rd + Rs + 1/(Kp*(Vgs - Vto)).  Here Rd = 0.3*rds_on,
    Rs = 0.1*rds_on and the channel takes the remaining 0.6*rds_on (the drain
    current's Vds/(2*(Vgs - Vto)) curvature adds 0.2 % at 3 A).  ``mosfet``
    overrides any parameter (then rds_on no longer holds if Kp/Rd/Rs/Vto are
    among them).  Note VDMOS's own ``Rds`` is a drain-source *shunt* resistance.
    """
    if not rds_on > 0:
        raise ValueError("rds_on must be > 0")
    p = dict(MOSFET_DEFAULTS)
    p.update(mosfet or {})
    if not v_drive > p["Vto"] + 1.0:
        raise ValueError(f"gate drive {v_drive} V too close to the threshold Vto = {p['Vto']} V")
    base = dict(Vto=p["Vto"], Kp=1.0 / (0.6 * rds_on * (v_drive - p["Vto"])),
                Rd=0.3 * rds_on, Rs=0.1 * rds_on)
    base.update(p)
    return base


def diode_params(diode=None):
    """Schottky model parameters: DIODE_DEFAULTS updated by ``diode``."""
    p = dict(DIODE_DEFAULTS)
    p.update(diode or {})
    return p


def diode_vf(i, params, temp=27.0):
    """Forward voltage of a SPICE diode (Is, N, Rs) carrying ``i`` amperes."""
    vt = 1.380649e-23 * (temp + 273.15) / 1.602176634e-19
    return params["N"] * vt * math.log1p(i / params["Is"]) + i * params.get("Rs", 0.0)


def _pwm_gate_intervals(duty, T, circuit, dead_time):
    """Gate on-intervals [(a, b), ...] in absolute time, per gate.

    The PWM signal is high on [k*T, k*T + d_k*T); touching intervals (d = 1)
    merge, so a gate stays on across periods instead of toggling.  async: the
    high side follows the PWM signal.  sync: dead-time insertion delays each
    turn-on by dead_time; the low side is on between the PWM intervals (from
    t = 0 if the PWM starts low, up to n*T after the last one).
    """
    n = len(duty)
    pwm = []
    for k, d in enumerate(duty):
        if d <= 0:
            continue
        a, b = k * T, k * T + d * T
        if pwm and abs(pwm[-1][1] - a) <= 1e-9 * T:
            pwm[-1][1] = b
        else:
            pwm.append([a, b])
    if circuit == "async":
        return {"hs": [tuple(iv) for iv in pwm]}
    hs = [(a + dead_time, b) for a, b in pwm]
    starts = [0.0] + [b + dead_time for _, b in pwm]
    ends = [a for a, _ in pwm] + [n * T]
    ls = list(zip(starts, ends))
    return {"hs": hs, "ls": ls}


# Breakpoint hygiene (ngspice 39, XSPICE build).  Every PULSE corner is a
# transient breakpoint, and so is the start of the pulse after a train's last
# one (NP reached) -- which is exactly where the next run's train starts.  Two
# breakpoints that coincide up to rounding (or exactly) make ngspice take a
# step of delmin = 1e-11*max_step, below the resolution of the time variable
# once t > ~0.5 ms; the Newton iteration of the nonlinear devices then fails
# and the run aborts with "timestep too small" (seen at random run
# boundaries after ~700 periods).  So each train is delayed, if needed, by a
# multiple of BREAK_SHIFT until all its corners are at least BREAK_MARGIN
# from every corner already placed.  BREAK_MARGIN exceeds ngspice's
# breakpoint merge distance (5e-5*max_step <= 1.5 ps for max_step <= T/100);
# the delay only moves whole pulses (widths unchanged) by tens of ps against
# 5 ns gate ramps.
BREAK_SHIFT = 10e-12
BREAK_MARGIN = 4e-12


def _gate_chains(intervals, ramp, T):
    """PULSE trains [start, width, spacing, count, tr, td] summing to a gate waveform.

    The waveform is on over each interval (a, b), with linear ramps of width
    ``ramp`` centred on a and b.  Intervals not longer than one ramp are
    dropped (the pulse is swallowed).  Intervals are cut at the period
    boundaries k*T (the falling ramp of one piece and the rising ramp of the
    next overlap and sum to the full drive), and the pieces are grouped
    greedily into trains of identical pieces spaced T apart (2T when a piece
    plus its ramp is longer than T, which then alternates between two
    sources): one source per run of equal duty, as in _switch_sources.
    """
    tol = 1e-9 * T
    pieces = []
    for a, b in intervals:
        if b - a <= ramp * (1 + 1e-9):
            continue
        cuts = [a]
        k = math.floor(a / T) + 1
        while k * T < b - ramp:
            if k * T > a + ramp:
                cuts.append(k * T)
            k += 1
        cuts.append(b)
        pieces += list(zip(cuts[:-1], cuts[1:]))
    pieces.sort()
    chains = []
    active = []
    for a, b in pieces:
        w = b - a
        td = a - ramp / 2
        if td < 0:
            # Cannot start before t = 0: ramp from 0 to the nominal ramp end.
            chains.append([a, w, T, 1, a + ramp / 2, 0.0])
            continue
        active = [c for c in active if c[0] + c[3] * c[2] >= a - tol]
        for c in active:
            if abs(c[1] - w) <= tol and abs(c[0] + c[3] * c[2] - a) <= 1e-6 * T:
                c[3] += 1
                break
        else:
            spacing = T * max(1, math.ceil((w + ramp) / T - 1e-9))
            c = [a, w, spacing, 1, ramp, td]
            chains.append(c)
            active.append(c)
    return chains


def _chain_corners(c, ramp):
    """Breakpoints of a train: its corners plus the start (and rise end) of
    the pulse after the last one, which ngspice 39 still schedules."""
    _, w, spacing, count, tr, td = c
    n = np.arange(count + 1) * spacing + td
    pw = w - ramp
    corners = [n, n[:-1] + tr, n[:-1] + tr + pw, n[:-1] + tr + pw + ramp, n[-1:] + tr]
    return np.concatenate(corners)


def _min_distance(x, sorted_ref):
    """Smallest |x_i - r_j| (inf if sorted_ref is empty)."""
    if len(sorted_ref) == 0:
        return math.inf
    i = np.searchsorted(sorted_ref, x)
    right = np.abs(sorted_ref[np.minimum(i, len(sorted_ref) - 1)] - x)
    left = np.abs(sorted_ref[np.maximum(i - 1, 0)] - x)
    return float(np.min(np.minimum(left, right)))


def _separate_breakpoints(chain_lists, ramp):
    """Delay trains (in start order) until no two breakpoints nearly coincide."""
    placed = np.empty(0)
    for c in sorted((c for cl in chain_lists for c in cl), key=lambda c: c[5]):
        base = _chain_corners(c, ramp)
        shift = 0.0
        if c[5] > 0:
            for j in range(100):
                shift = j * BREAK_SHIFT
                if _min_distance(base + shift, placed) >= BREAK_MARGIN:
                    break
            else:
                raise RuntimeError("could not separate the gate-drive breakpoints")
            c[5] += shift
        placed = np.sort(np.concatenate((placed, base + shift)))


def _chain_sources(chains, amp, ramp, prefix, node):
    """SPICE lines: one PULSE current source into ``node`` per train."""
    lines = []
    for i, (_, w, spacing, count, tr, td) in enumerate(chains):
        # PULSE(V1 V2 TD TR TF PW PER NP)
        lines.append(f"I{prefix}{i} 0 {node} PULSE(0 {_num(amp)} {_num(td)} {_num(tr)} "
                     f"{_num(ramp)} {_num(w - ramp)} {_num(spacing)} {count})")
    if not lines:
        # The node must exist; an always-off gate is a zero source.
        lines.append(f"I{prefix}0 0 {node} DC 0")
    return "\n".join(lines)


def _gate_sources(gates, amp, ramp, T):
    """{"hs": lines, "ls": lines} for the gate intervals of _pwm_gate_intervals."""
    chains = {g: _gate_chains(iv, ramp, T) for g, iv in gates.items()}
    _separate_breakpoints(list(chains.values()), ramp)
    nodes = {"hs": ("gh", "xh"), "ls": ("gl", "xl")}
    return {g: _chain_sources(c, amp, ramp, *nodes[g]) for g, c in chains.items()}


def dc_point(circuit, d, *, L=3.3e-6, RL=0.1, fs=330e3, U=12.0, io=1.0, dead_time=30e-9,
             rds_on=10e-3, diode=None, mosfet=None):
    """Approximate periodic steady state at constant duty d, at the period start.

    Returns (il, vc, vo, vsw): inductor current at the period start (ripple
    valley), capacitor voltages (the mean output voltage), switch-node
    voltage.  ideal: u_sw averages d*U.  sync: plus the Rds_on drop and the
    dead-time loss (-(dead_time/T)*(U + 2*Vbd) for il > 0 in both dead times).
    async: CCM with the diode drop Vf(io), or, when io is below half the
    ripple, DCM (il = 0 at the period start; constant-Vf volt-second balance).
    Good to a few mV-tens of mV: meant as a start point before a warm-up.
    """
    T = 1.0 / fs
    if circuit == "ideal":
        vo = d * U - RL * io
        return io - (U - vo) * d * T / (2 * L), vo, vo, 0.0
    if circuit == "sync":
        body = mosfet_params(rds_on, mosfet=mosfet)
        vbd = diode_vf(max(abs(io), 0.1), dict(Is=body["Is"], N=body["N"], Rs=body["Rb"]))
        loss = dead_time / T * (U + 2 * vbd) if io > 0 else 0.0
        vo = d * U - (RL + rds_on) * io - loss
        il = io - (U - vo) * d * T / (2 * L)
        return il, vo, vo, -vbd if il > 0 else U
    dp = diode_params(diode)
    vf = diode_vf(max(io, 1e-3), dp)
    vo = d * U - (1 - d) * vf - (RL + d * rds_on) * io
    ripple = (U - vo) * d * T / L
    if io >= ripple / 2 or d >= 1:
        return io - ripple / 2, vo, vo, -vf
    # DCM: on-time d*T, current peak ip = (U - vo)*d*T/L, fall time
    # t2 = ip*L/(vo + vf); the period average ip*(d*T + t2)/(2T) must be io.
    lo, hi = 0.0, U
    for _ in range(100):
        vo = (lo + hi) / 2
        ip = (U - vo) * d * T / L
        vf = diode_vf(ip / 2, dp)
        avg = ip * (d * T + ip * L / (vo + vf)) / (2 * T)
        lo, hi = (vo, hi) if avg > io else (lo, vo)
    return 0.0, vo, vo, vo


def _run_ngspice(netlist, workdir, n, T):
    """Run a netlist in workdir (a temporary directory if None) -> raw vectors."""
    exe = shutil.which("ngspice")
    if exe is None:
        raise RuntimeError("ngspice not found on PATH")
    tmp = None
    if workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="buck_spice_")
        workdir = tmp.name
    os.makedirs(workdir, exist_ok=True)
    try:
        cir, raw = os.path.join(workdir, "buck.cir"), os.path.join(workdir, "buck.raw")
        if os.path.exists(raw):
            os.remove(raw)
        with open(cir, "w") as f:
            f.write(netlist)
        proc = subprocess.run([exe, "-b", cir], cwd=workdir, capture_output=True, text=True)
        log = proc.stdout + proc.stderr
        with open(os.path.join(workdir, "ngspice.log"), "w") as f:
            f.write(log)
        vec = _read_raw(raw) if proc.returncode == 0 and os.path.exists(raw) else None
    finally:
        if tmp is not None:
            tmp.cleanup()
    # ngspice -b can exit 0 after aborting the transient ("timestep too
    # small"), so also require the run to have reached tstop.
    if vec is None or abs(vec["time"][-1] - n * T) > 1e-6 * T:
        tail = "\n".join((proc.stderr.strip() or log.strip()).splitlines()[-20:])
        raise RuntimeError(f"ngspice failed (exit {proc.returncode}); output tail:\n{tail}")
    return vec


# inductor_saturation and cap_dc_bias: an incremental L(il) and Cl(v) (v = L(il)*dil/dt,
# i = Cl(v)*dv/dt), as in the plant.
#
# The inductor has the structure ngspice-39 gives `L1 sw nl L='expr'`, written out: a linear
# inductor carrying il (a CCCS copies i(Vam) into it) whose voltage a B source scales by
# L(il)/L.  Written out because that expansion drops IC= (the runs start from a state, uic);
# scaled to L instead of ngspice's 1 H so that its node is in volts.  The step at isat is taken as it is, no
# smoothing (a tanh of width 0.2 % of isat made the synchronous buck abort): see SATURATION_TRTOL.
#
# The capacitor is the linear Cl (unchanged, with its IC) in parallel with the charge it loses,
# Cl*dc_bias*g(v) with g'(v) = min((v/rated_voltage)^2, 1): a B source holds g(v) on a
# capacitor of Cl*dc_bias and a CCCS returns that capacitor's current to the node, so
# i = Cl*(1 - dc_bias*g'(v))*dv/dt = Cl(v)*dv/dt.  Not ngspice's `C='expr'` (a B source
# i = Cl(v) times the current of a 1 F copy of v), nor Q(v) on a 1 F capacitor: from the DC
# start (dv/dt = 0) ngspice-39 then creeps on at ~1e-19 s steps or aborts ("timestep too
# small") for some Cl, io and rated voltages; with the linear part carrying most of the
# current it ran every case tried (Cl 1-100 uF, io 0.5-3 A, dc_bias 0.3-0.6, rated 6.3-16 V;
# all three circuits).


def _inductor(L, il0, saturation, isat, trtol=None):
    """The inductor sw -> nl carrying il = i(Vam); with `saturation` > 0 its incremental
    inductance is L*(1 - saturation) while |il| > isat (`trtol`: the transient's, if given)."""
    if saturation == 0:
        return f"L1    sw  nl   {_num(L)}  IC={_num(il0)}"
    lines = [
        "FL1   0   l1i  Vam 1",
        f"LL1   l1i 0    {_num(L)}  IC={_num(il0)}",
        f"BL1   sw  nl   V = v(l1i)*(abs(i(Vam)) > {_num(isat)} ? {_num(1 - saturation)} : 1)",
    ]
    if trtol is not None:
        lines.append(f".options trtol={_num(trtol)}")
    return "\n".join(lines)


def _load_capacitor(node, Cl, vo0, dc_bias, rated_voltage):
    """Cl from `node` to ground; with `dc_bias` > 0 its incremental capacitance is
    Cl*(1 - dc_bias*min((v/rated_voltage)^2, 1)), v = v(node) the voltage across Cl itself."""
    if dc_bias == 0:
        return f"Cl1   {node} 0    {_num(Cl)} IC={_num(vo0)}"

    v = f"v({node})"
    vc = f"max(min({v}, {_num(rated_voltage)}), {_num(-rated_voltage)})"
    vc0 = max(min(vo0, rated_voltage), -rated_voltage)
    # g(v) [V]: the lost charge over Cl*dc_bias, g'(v) = min((v/rated_voltage)^2, 1).
    g = f"{v} - {vc} + {vc}*{vc}*{vc}/{_num(3 * rated_voltage ** 2)}"
    g0 = vo0 - vc0 + vc0 ** 3 / (3 * rated_voltage ** 2)
    return "\n".join([
        f"Cl1   {node} 0    {_num(Cl)} IC={_num(vo0)}",
        f"BCl1  gcl 0    V = {g}",
        f"CCl1  gcl ngcl {_num(Cl * dc_bias)} IC={_num(g0)}",
        "VCl1  ngcl 0   0",
        f"FCl1  0   {node} VCl1 1",
    ])


def _output_network(C, Rc, Cl, load_esr, esl, vc0, vo0, cap_dc_bias=0.0, cap_rated_voltage=16.0,
                    rload=0.0):
    """The output capacitors: C with its ESR Rc (and ESL) to node vc, Cl (with its ESR and its
    DC-bias loss) at out; a load resistor rload from out to 0 beside Iload (0: none)."""
    lines = []
    if esl > 0:
        lines += [f"Rc1   out nrc  {_num(Rc)}", f"Lc    nrc vc   {_num(esl)} IC=0"]
    else:
        lines.append(f"Rc1   out vc   {_num(Rc)}")
    lines.append(f"C1    vc  0    {_num(C)}  IC={_num(vc0)}")
    node = "out"
    if load_esr > 0:
        lines.append(f"Rcl   out ncl  {_num(load_esr)}")
        node = "ncl"
    lines.append(_load_capacitor(node, Cl, vo0, cap_dc_bias, cap_rated_voltage))
    if rload > 0:
        lines.append(f"Rload out 0    {_num(rload)}")
    return "\n".join(lines)


def simulate(duty, *, L=3.3e-6, RL=0.1, C=100e-6, Rc=0.1, Cl=10e-6, fs=330e3, U=12.0,
             io=1.0, x0=None, workdir=None, max_step=None, edge=10e-12, circuit="ideal",
             dead_time=30e-9, rds_on=10e-3, gate_rise=5e-9, v_drive=10.0, mosfet=None,
             diode=None, snubber=SNUBBER_DEFAULT, warmup=0, solver=None, load_esr=0.0, esl=0.0,
             inductor_saturation=0.0, isat=10.0, cap_dc_bias=0.0, cap_rated_voltage=16.0,
             rload=0.0, pulse_width_distortion=0.0, raw=None):
    """Simulate a buck converter in ngspice for len(duty) periods.

    raw: a dict to receive the raw transient vectors (time, v(out), i(vam), ...),
    e.g. for write_capture().

    duty: per-period duty d_k in [0, 1].  circuit: "ideal" (ideal switch
    node; the default, unchanged), "sync" (VDMOS high and low side, body
    diodes, dead time) or "async" (VDMOS high side, Schottky diode).
    x0: initial (il, vc, vo); default: ideal -- the averaged DC steady state
    of d_0 (il = io, vc = vo = d_0*U - RL*io); sync/async -- dc_point() (the
    ripple valley and the approximate mean output, DCM included).
    warmup: periods simulated at duty[0] before the sequence and dropped
    (time 0 of the result is the end of the warm-up).
    workdir: keep netlist/raw/log there (default: a temporary directory).
    max_step: ngspice max time step (default T/100; async, and sync with
    inductor_saturation, T/400, see REAL_SOLVER_OPTIONS and SATURATION_TRTOL).
    edge: ideal switch edge width (keep it well above 5e-5*max_step, ngspice's
    minimum breakpoint spacing).

    load_esr: series resistance of Cl; esl: series inductance of the C branch
    (any circuit; 0 leaves the element out).  inductor_saturation: fraction of L
    lost while |il| > isat; cap_dc_bias: fraction of Cl lost at cap_rated_voltage,
    Cl(v) = Cl*(1 - cap_dc_bias*min((v/cap_rated_voltage)^2, 1)) with v across Cl
    itself; both incremental, as in the plant's Params (any circuit; 0 leaves the
    linear element).  rload: load resistance from out to 0 beside Iload [ohm]
    (0 leaves it out; the start point accounts for its current).
    pulse_width_distortion: the switch's on-time beyond d*T [s], signed (a gate
    drive's turn-off delay minus its turn-on delay), held within [0, T], no
    pulse made at d = 0 (ideal circuit only: the real circuits' gate drives
    have delays of their own).

    Real circuits only: dead_time (sync: both gates off before each turn-on),
    rds_on (MOSFET on-resistance at Vgs = v_drive, see mosfet_params),
    gate_rise (gate ramp width), v_drive (gate drive voltage), mosfet / diode
    (dicts overriding MOSFET_DEFAULTS / DIODE_DEFAULTS), snubber (async
    switch-node RC (R, C), None to omit), solver (dict overriding
    REAL_SOLVER_OPTIONS).

    Returns dict of numpy arrays (length N = len(duty)): time (= k*T), duty,
    vout_start, il_start, vc_start (values at t = k*T), vout_avg, il_avg
    (averages over [k*T, (k+1)*T]); sync/async also vsw_avg (switch node).
    Raises RuntimeError if ngspice is missing or fails.
    """
    if circuit not in CIRCUITS:
        raise ValueError(f"circuit must be one of {CIRCUITS}, not {circuit!r}")
    duty = np.asarray(duty, dtype=float).ravel()
    warmup = int(warmup)
    if len(duty) == 0 or not np.all((duty >= 0) & (duty <= 1)):
        raise ValueError("duty must be a non-empty sequence of values in [0, 1]")
    if warmup < 0:
        raise ValueError("warmup must be >= 0")
    if min(L, C, Rc, Cl, fs, edge) <= 0 or min(RL, load_esr, esl, rload) < 0:
        raise ValueError("L, C, Rc, Cl, fs, edge must be > 0 and RL, load_esr, esl, rload >= 0")
    if not (0 <= inductor_saturation < 1 and isat > 0):
        raise ValueError("inductor_saturation must be in [0, 1) and isat > 0")
    if not (0 <= cap_dc_bias < 1 and cap_rated_voltage > 0):
        raise ValueError("cap_dc_bias must be in [0, 1) and cap_rated_voltage > 0")
    n_out = len(duty)
    if warmup:
        duty = np.concatenate((np.full(warmup, duty[0]), duty))
    n = len(duty)
    T = 1.0 / fs
    real = circuit != "ideal"
    if pulse_width_distortion and real:
        raise ValueError("pulse_width_distortion applies to the ideal circuit only")
    # The share of each period the switch conducts: the duty's pulse stretched or shortened.
    on_share = np.where((duty > 0) & (duty < 1), np.clip(duty + pulse_width_distortion * fs, 0, 1), duty)
    if max_step is None:
        steps = REAL_STEPS_PER_PERIOD[circuit] if real else DEFAULT_STEPS_PER_PERIOD
        if real and inductor_saturation:
            steps = max(steps, SATURATION_REAL_STEPS_PER_PERIOD)
        max_step = T / steps
    vsw0 = 0.0
    if x0 is None:
        if real:
            # A load resistor draws vo/rload more: a few fixed-point passes on the output.
            io_dc = io
            for _ in range(4 if rload > 0 else 1):
                il0, vc0, vo0, vsw0 = dc_point(circuit, duty[0], L=L, RL=RL, fs=fs, U=U, io=io_dc,
                                               dead_time=dead_time, rds_on=rds_on, diode=diode,
                                               mosfet=mosfet)
                io_dc = io + (vo0 / rload if rload > 0 else 0.0)
        elif rload > 0:
            v0 = (on_share[0] * U - RL * io) * rload / (rload + RL)
            il0, vc0, vo0 = io + v0 / rload, v0, v0
        else:
            v0 = on_share[0] * U - RL * io
            il0, vc0, vo0 = io, v0, v0
    else:
        il0, vc0, vo0 = x0
        if real:
            vsw0 = vo0 if il0 == 0 else (-0.5 if il0 > 0 else U)

    with open(TEMPLATES[circuit]) as f:
        template = string.Template(f.read())
    # trtol: tighter truncation-error control finds the saturation crossings (ideal circuit;
    # the synchronous one aborts with "timestep too small" at its gate drive, see _inductor).
    inductor = _inductor(L, il0, inductor_saturation, isat, None if real else SATURATION_TRTOL)
    common = dict(inductor=inductor, RL=_num(RL), io=_num(io),
                  output_network=_output_network(C, Rc, Cl, load_esr, esl, vc0, vo0, cap_dc_bias,
                                                 cap_rated_voltage, rload),
                  max_step=_num(max_step), tstop=_num(n * T), rawfile="buck.raw")
    if not real:
        netlist = template.substitute(
            switch_sources=_switch_sources(on_share, T, U, edge), **common,
            **{k: (v if isinstance(v, str) else _num(v)) for k, v in SOLVER_OPTIONS.items()})
    else:
        if not (gate_rise > 0 and dead_time >= 0 and v_drive > 0):
            raise ValueError("gate_rise and v_drive must be > 0, dead_time >= 0")
        opts = dict(REAL_SOLVER_OPTIONS)
        opts.update(solver or {})
        sources = _gate_sources(_pwm_gate_intervals(duty, T, circuit, dead_time),
                                v_drive, gate_rise, T)
        fields = dict(common, U=_num(U), vsw0=_num(vsw0), hs_sources=sources["hs"],
                      mosfet_model=_model_card("NMOS_SW", "VDMOS",
                                               mosfet_params(rds_on, v_drive, mosfet)),
                      write_vectors="v(out) v(vc) i(vam) v(sw)",
                      **{k: (v if isinstance(v, (str, int)) else _num(v)) for k, v in opts.items()})
        if circuit == "sync":
            fields["ls_sources"] = sources["ls"]
        else:
            fields["diode_model"] = _model_card("DSCHOTTKY", "D", diode_params(diode))
            if snubber and snubber[0] > 0 and snubber[1] > 0:
                fields["snubber"] = (f"Rsn   sw  nsn  {_num(snubber[0])}\n"
                                     f"Csn   nsn 0    {_num(snubber[1])}")
            else:
                fields["snubber"] = "* (no snubber)"
        netlist = template.substitute(fields)
    vec = _run_ngspice(netlist, workdir, n, T)
    if raw is not None:
        raw.update(vec, warmup_time=warmup * T)
    t = vec["time"]

    out = {"time": np.arange(n) * T, "duty": duty}
    probes = [("vout", "v(out)"), ("il", "i(vam)"), ("vc", "v(vc)")]
    if real:
        probes.append(("vsw", "v(sw)"))
    for key, name in probes:
        start, avg = _period_reduce(t, vec[name], T, n)
        if key != "vsw":
            out[key + "_start"] = start
        if key != "vc":
            out[key + "_avg"] = avg
    # The t = 0 sample is the initial condition by definition (ngspice's stored
    # uic point can be off by float noise, seen ~2e-6 A on il).
    out["il_start"][0], out["vc_start"][0], out["vout_start"][0] = il0, vc0, vo0
    if warmup:
        out = {k: v[warmup:] for k, v in out.items()}
        out["time"] = np.arange(n_out) * T
    return out


def write_capture(path, raw, rate, noise_v=5e-3, noise_i=5e-3, seed=1):
    """An oscilloscope capture of the raw transient: v(out), i(vam) and (real circuits) v(sw)
    resampled at `rate` [S/s] (a clock unrelated to fs; the first sample at a random phase),
    with seeded white noise on each channel (σ noise_v [V] on the voltages, noise_i [A] on il).
    Time 0 is the end of the warm-up, as in the per-period data file."""
    rng = np.random.default_rng(seed)
    t = raw["time"] - raw["warmup_time"]
    ts = np.arange(max(t[0], 0.0) + rng.uniform(0, 1 / rate), t[-1], 1 / rate)
    cols = [("time", ts)]
    for key, name, sigma in (("vout", "v(out)", noise_v), ("il", "i(vam)", noise_i), ("sw", "v(sw)", noise_v)):
        if name in raw:
            cols.append((key, np.interp(ts, t, raw[name]) + rng.normal(0, sigma, len(ts))))
    lines = [f"# capture_rate = {rate!r}", f"# noise_v = {noise_v!r}", f"# noise_i = {noise_i!r}",
             ",".join(c for c, _ in cols)]
    lines += [",".join(f"{x:.9g}" for x in row) for row in np.column_stack([v for _, v in cols])]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def _ngspice_version():
    """"ngspice-39" from `ngspice -v` (or "ngspice" if it cannot be told)."""
    try:
        out = subprocess.run(["ngspice", "-v"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return "ngspice"
    m = re.search(r"ngspice-[\w.+-]+", out)
    return m.group(0) if m else "ngspice"


def truth(circuit, *, duty0=0.5, L=3.3e-6, RL=0.1, fs=330e3, U=12.0, io=1.0, dead_time=30e-9,
          rds_on=10e-3, gate_rise=5e-9, v_drive=10.0, mosfet=None, diode=None,
          snubber=SNUBBER_DEFAULT):
    """The non-ideal effects built into a circuit (names as in the design table).

    For the --truth sidecar only: the data file itself must not tell the
    diagnosis which effect is present.
    """
    t = {"circuit": circuit, "effects": {}}
    if circuit == "ideal":
        return t
    T = 1.0 / fs
    mp = mosfet_params(rds_on, v_drive, mosfet)
    body = dict(Is=mp["Is"], N=mp["N"], Rs=mp["Rb"])
    t["models"] = {"NMOS_SW": {"type": "VDMOS", **mp}}
    t["gate_drive"] = {"v_drive": v_drive, "gate_rise": gate_rise}
    eff = t["effects"]
    if circuit == "sync":
        eff["switch_resistance"] = {"rds_on_high": rds_on, "rds_on_low": rds_on,
                                    "series_total": rds_on}
        eff["dead_time"] = {"t_dead": dead_time, "edges": 2,
                            "body_diode_vf_at_io": diode_vf(max(abs(io), 1e-3), body),
                            "duty_loss_approx": dead_time / T}
    else:
        dp = diode_params(diode)
        t["models"]["DSCHOTTKY"] = {"type": "D", **dp}
        t["snubber"] = list(snubber) if snubber else None
        il0, _, vo, _ = dc_point("async", duty0, L=L, RL=RL, fs=fs, U=U, io=io, rds_on=rds_on,
                                 diode=diode)
        eff["switch_resistance"] = {"rds_on_high": rds_on, "series_total_at_duty": duty0 * rds_on}
        eff["diode_drop"] = {"vf_at_io": diode_vf(max(io, 1e-3), dp),
                             "vf_at_1A": diode_vf(1.0, dp), "vf_at_3A": diode_vf(3.0, dp)}
        # CCM/DCM boundary at duty0: io = ripple/2 with the CCM output voltage.
        vf = diode_vf(max(io, 1e-3), dp)
        v_ccm = duty0 * U - (1 - duty0) * vf - (RL + duty0 * rds_on) * io
        boundary = (U - v_ccm) * duty0 * T / (2 * L)
        eff["dcm"] = {"active_at_duty0": bool(io < boundary), "duty0": duty0,
                      "io_boundary_at_duty0": boundary, "vout_estimate_at_duty0": vo}
    return t


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--circuit", choices=CIRCUITS, default="ideal")
    p.add_argument("--periods", type=int, default=3001)
    p.add_argument("--warmup", type=int, default=0,
                   help="periods simulated at the first duty before the data and dropped")
    p.add_argument("--seed", type=int, default=1, help="PRBS LFSR seed")
    p.add_argument("--bit-periods", type=int, default=8)
    p.add_argument("--duty-file", help="duty sequence, one value per line (overrides PRBS)")
    p.add_argument("--cl", type=float, default=10e-6)
    p.add_argument("--io", type=float, default=1.0)
    p.add_argument("--L", type=float, default=3.3e-6)
    p.add_argument("--RL", type=float, default=0.1)
    p.add_argument("--C", type=float, default=100e-6)
    p.add_argument("--Rc", type=float, default=0.1)
    p.add_argument("--fs", type=float, default=330e3)
    p.add_argument("--U", type=float, default=12.0)
    p.add_argument("--load-esr", type=float, default=0.0, help="series resistance of Cl [ohm]")
    p.add_argument("--esl", type=float, default=0.0, help="series inductance of the C branch [H]")
    p.add_argument("--rload", type=float, default=0.0,
                   help="load resistance from out to 0 beside the load current [ohm] (0 = none)")
    p.add_argument("--inductor-saturation", type=float, default=0.0,
                   help="fraction of L lost while |il| > isat")
    p.add_argument("--isat", type=float, default=10.0,
                   help="saturation current of the inductor [A] (the plant's default)")
    p.add_argument("--cap-dc-bias", type=float, default=0.0,
                   help="fraction of Cl lost at the rated voltage (quadratic in the voltage)")
    p.add_argument("--cap-rated-voltage", type=float, default=16.0, help="rated voltage of Cl [V]")
    p.add_argument("--pulse-width-distortion", type=float, default=0.0,
                   help="the switch's on-time beyond d*T, signed [s] (ideal circuit only)")
    p.add_argument("--noise", type=float, nargs=2, default=[0.0, 0.0], metavar=("V", "A"),
                   help="white noise σ added to the vout [V] and il [A] readings (seeded by --seed)")
    p.add_argument("--dead-time", type=float, default=30e-9, help="sync only [s]")
    p.add_argument("--rds-on", type=float, default=10e-3, help="MOSFET on-resistance [ohm]")
    p.add_argument("--gate-rise", type=float, default=5e-9, help="gate ramp width [s]")
    p.add_argument("--max-step", type=float, default=None)
    p.add_argument("--workdir", help="keep netlist, raw file and log here")
    p.add_argument("--out", default="-", help="CSV output file ('-' = stdout)")
    p.add_argument("--truth", help="write the circuit's non-ideal effects (JSON sidecar) here")
    p.add_argument("--time", action="store_true", help="print ngspice wall time to stderr")
    p.add_argument("--capture", help="also write an oscilloscope capture (raw transient resampled) here")
    p.add_argument("--capture-rate", type=float, default=97.3e6, help="capture sample rate [S/s]")
    p.add_argument("--capture-noise", type=float, nargs=2, default=[5e-3, 5e-3],
                   metavar=("V", "A"), help="noise σ of the captured voltages [V] and current [A]")
    a = p.parse_args(argv)

    if a.duty_file:
        duty = np.loadtxt(a.duty_file, ndmin=1)
    else:
        duty = prbs_duty(a.periods, a.bit_periods, seed=a.seed)
    params = dict(L=a.L, RL=a.RL, C=a.C, Rc=a.Rc, Cl=a.cl, fs=a.fs, U=a.U, io=a.io)
    real = dict(dead_time=a.dead_time, rds_on=a.rds_on, gate_rise=a.gate_rise)
    t0 = _time.perf_counter()
    raw = {} if a.capture else None
    r = simulate(duty, max_step=a.max_step, workdir=a.workdir, circuit=a.circuit, raw=raw,
                 warmup=a.warmup, load_esr=a.load_esr, esl=a.esl,
                 inductor_saturation=a.inductor_saturation, isat=a.isat, cap_dc_bias=a.cap_dc_bias,
                 cap_rated_voltage=a.cap_rated_voltage, rload=a.rload,
                 pulse_width_distortion=a.pulse_width_distortion, **real, **params)
    if a.time:
        print(f"wall time (ngspice + parsing): {_time.perf_counter() - t0:.3f} s "
              f"for {len(duty)} + {a.warmup} warm-up periods ({a.circuit})", file=sys.stderr)

    n = len(duty)
    # The readings' noise (a measurement's), seeded; the averages stay exact.
    rng = np.random.default_rng(a.seed)
    vout_read = r["vout_start"] + (rng.normal(0.0, a.noise[0], n) if a.noise[0] > 0 else 0.0)
    il_read = r["il_start"] + (rng.normal(0.0, a.noise[1], n) if a.noise[1] > 0 else 0.0)
    cols = [("time", r["time"]), ("duty", r["duty"]), ("vin", np.full(n, a.U)),
            ("io", np.full(n, a.io)), ("vout", vout_read), ("il", il_read),
            ("vc", r["vc_start"]), ("vout_avg", r["vout_avg"]), ("il_avg", r["il_avg"])]
    lines = [f"# {k} = {params[k]!r}" for k in ("fs", "L", "RL", "C", "Rc", "Cl", "U", "io")]
    if a.rload > 0:
        lines.append(f"# rload = {a.rload!r}")
    lines.append(f"# circuit = {a.circuit}")
    if a.circuit == "ideal":
        lines.append("# source = ngspice ideal switch")
    else:
        kind = {"sync": "MOSFET synchronous buck", "async": "MOSFET + Schottky diode buck"}
        lines.append(f"# source = {_ngspice_version()} {kind[a.circuit]}")
    lines.append(",".join(c for c, _ in cols))
    data = np.column_stack([v for _, v in cols])
    lines += [",".join(repr(float(x)) for x in row) for row in data]
    text = "\n".join(lines) + "\n"
    if a.out == "-":
        sys.stdout.write(text)
    else:
        with open(a.out, "w") as f:
            f.write(text)
    if a.capture:
        write_capture(a.capture, raw, a.capture_rate, *a.capture_noise, seed=a.seed)
    if a.truth:
        t = truth(a.circuit, duty0=float(duty[0]), L=a.L, RL=a.RL, fs=a.fs, U=a.U, io=a.io, **real)
        t["warmup"] = a.warmup
        if a.pulse_width_distortion:
            t["effects"]["pulse_width_distortion"] = {"seconds": a.pulse_width_distortion}
        if any(a.noise):
            t["noise"] = {"vout": a.noise[0], "il": a.noise[1]}
        # The circuit values simulated, Cl included: the answer an identification is checked against.
        t["params"] = dict(params, **({"rload": a.rload} if a.rload > 0 else {}))
        with open(a.truth, "w") as f:
            json.dump(t, f, indent=2)
            f.write("\n")


if __name__ == "__main__":
    main()
