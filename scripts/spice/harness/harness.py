#!/usr/bin/env python3
"""Independent ngspice buck generator for the blind check (issue 11).

A second source of "real plant" data whose circuits differ from the project's own netlists
(``../buck_*.cir``) in every device while keeping the nominal passive network of the design
(L = 3.3 uH, RL = 100 mOhm, C = 100 uF behind Rc = 100 mOhm, Cl at the output, U = 12 V,
fs = 330 kHz, trailing-edge PWM latched per period):

* topology ``sw``: two ngspice ``SW`` switches with a smooth Ron/Roff transition, driven
  complementarily by one ramped gate waveform (centred on the ideal instants);
* topology ``sync``: two level-1 NMOS with driver resistance, explicit Cgs, separate pn body
  diodes and a dead time before each turn-on (gate ramps start at the command instants);
* topology ``async``: a level-1 NMOS high side and a freewheeling diode card of its own;
* a switch-node capacitance, the ADC sampling ``adc_delay`` after each period start
  (interpolated from the transient, with a time point forced there), or triggered from the
  PWM, a further ``adc_share`` of each period's on-time later (``--adc-delay 0 --adc-share
  0.5``: the middle of the on-time), seeded Gaussian measurement noise on vout and il;
* optional: resistor in series with Cl (``load_esr``), inductance in the C branch (``esl``),
  a smoothly saturating inductor (``sat``/``isat``), a load capacitor losing capacitance with
  voltage (``dcbias``/``vrated``), L/C/Rc off nominal (pass the changed value), a resistive
  load (``--rload``), probes with gain and zero errors (``--vout-gain``, ``--vout-offset``,
  ``--il-gain``, ``--il-offset``: each reading is ``(1 + gain)*signal + offset``, noise included).

The CSV carries only ``# fs`` and ``# U`` (and ``# rload`` for a resistive load): nothing that
names the circuit or its effects. ``--truth FILE.json`` writes everything the run used.
Needs numpy and ``ngspice`` on PATH.

Example:
    python scripts/spice/harness/harness.py --topology async --cl 2.2e-6 --io 1.5 \
        --seed 3 --out data.csv --truth truth.json
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

HERE = os.path.dirname(os.path.abspath(__file__))
TEMPLATE = os.path.join(HERE, "harness_buck.cir")
TOPOLOGIES = ("sw", "sync", "async")

# Longest an ngspice transient may run [s]: a case takes 30-110 s on two cores; seed 3434's
# sixth (an ESL on the two-switch stage) still ran after 23 min, and the bench waited on it.
NGSPICE_TIMEOUT = 900

# Gate drive amplitude [V] and the NMOS threshold [V] of the level-1 cards.
V_DRIVE = 10.0
V_TH = 2.0


def prbs(n, seed, bit_periods=8, low=0.4, high=0.6):
    """Per-period duty: PRBS11 (x^11 + x^9 + 1, Fibonacci), each bit held ``bit_periods``.

    ``seed`` picks the non-zero 11-bit start state (seed mod 2047, plus one).
    """
    state = int(seed) % 2047 + 1
    bits = []
    for _ in range(-(-int(n) // int(bit_periods))):
        new = ((state >> 10) ^ (state >> 8)) & 1
        state = ((state << 1) | new) & 0x7FF
        bits.append(new)
    return np.where(np.repeat(np.array(bits, bool), bit_periods)[:n], high, low).astype(float)


def f(x):
    """A number for the netlist (repr: exact, no SPICE unit suffixes)."""
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite circuit value {x}")
    return repr(x)


def runs(duty):
    """(first period, past-the-last period, duty) of each run of equal duty."""
    out, k0 = [], 0
    for k in range(1, len(duty) + 1):
        if k == len(duty) or duty[k] != duty[k0]:
            out.append((k0, k, float(duty[k0])))
            k0 = k
    return out


def gate_chain(prefix, node, duty, T, window, ramp, centred):
    """A gate waveform on ``node``: PULSE current sources (one per run of equal duty) summed
    into 1 ohm, so the node's voltage is their sum and the sources add no unknowns.

    ``window(d)`` gives the on-interval (start, end) relative to the period start; the gate
    ramps 0 -> V_DRIVE over ``ramp`` from the start (or centred on it) and back at the end.
    PULSE with a pulse count keeps every source O(1) per time point (a long PWL is scanned
    from its first corner at every evaluation: quadratic in the run length) and puts a
    breakpoint on every ramp corner. A ramp centred on t = 0 starts at 0 instead.
    """
    shift = ramp / 2 if centred else 0.0
    lines = []

    def source(name, td, tr, pw, per, count):
        lines.append(f"I{prefix}{name} 0 {node} PULSE(0 {f(V_DRIVE)} {f(td)} {f(tr)} {f(ramp)} "
                     f"{f(pw)} {f(per)} {count})")

    for j, (k0, k1, d) in enumerate(runs(duty)):
        a, b = window(d)
        a, b = a - shift, b - shift
        pw = b - a - ramp
        if pw <= 0:
            continue  # a pulse shorter than its ramp: the driver swallows it
        if b + ramp - a >= T:
            raise ValueError(f"duty {d}: the gate would not turn off within the period")
        if k0 == 0 and a < 0:
            # Period 0 rises from t = 0 (no earlier time exists), over the part of the ramp left.
            source(f"{j}a", 0.0, ramp + a, pw, 2 * T, 1)
            k0 = 1
        if k1 > k0:
            source(str(j), k0 * T + a, ramp, pw, T, k1 - k0)
    lines.append(f"R{prefix} {node} 0 1")
    return "\n".join(lines), node


def diode_card(name, p):
    return (f".model {name} D(IS={f(p['is'])} N={f(p['n'])} RS={f(p['rs'])} CJO={f(p['cjo'])} "
            f"VJ={f(p.get('vj', 0.6))} M={f(p.get('m', 0.45))} TT=0 BV=100)")


def diode_vf(i, p):
    """Static forward drop of a diode card at current i [A] (27 °C): N*Vt*ln(1 + i/Is) + Rs*i."""
    vt = 1.380649e-23 * 300.15 / 1.602176634e-19
    return p["n"] * vt * math.log1p(i / p["is"]) + p["rs"] * i


def nmos_card(name, ron):
    """Level-1 NMOS whose channel resistance at full drive is ``ron`` (W = L: beta = KP)."""
    kp = 1.0 / (ron * (V_DRIVE - V_TH))
    return f".model {name} NMOS(LEVEL=1 VTO={f(V_TH)} KP={f(kp)} LAMBDA=0 IS=1e-16)"


def power_stage(a, duty, T):
    """(gate-drive lines, power-stage lines) of topology ``a.topology``."""
    if a.topology == "sw":
        gate, g = gate_chain("g", "g", duty, T, lambda d: (0.0, d * T), a.ramp, True)
        vh = -0.3 * V_DRIVE  # negative VH: smooth log transition over VT +- |VH|
        stage = "\n".join([
            f"Shs   vin sw  {g} 0 SWHS",
            f"Sls   sw  0   0 {g} SWLS",
            f".model SWHS SW(VT={f(V_DRIVE / 2)} VH={f(vh)} RON={f(a.ron_hs)} ROFF=1e6)",
            f".model SWLS SW(VT={f(-V_DRIVE / 2)} VH={f(vh)} RON={f(a.ron_ls)} ROFF=1e6)",
        ])
        return gate, stage
    sync = a.topology == "sync"
    # sync: each turn-on waits for the other gate's ramp to end plus the dead time; async: the
    # ramps are centred on the PWM instants like the sw topology's.
    lag = a.ramp + a.dead_time if sync else 0.0
    # A drive whose turn-off is slower than its turn-on holds the high side's gate on past d*T.
    stretch = a.pulse_stretch
    gate_h, xh = gate_chain("xh", "xh", duty, T, lambda d: (lag, d * T + stretch), a.ramp, not sync)
    gates = [gate_h]
    stage = [
        f"Ehs   dh  sw  {xh} 0 1",
        f"Rgh   dh  gh  {f(a.rdrv)}",
        f"Cgh   gh  sw  {f(a.cgs)}",
        "Mhs   vin gh  sw sw NHS",
        nmos_card("NHS", a.ron_hs),
    ]
    dp = {"is": a.diode_is, "n": a.diode_n, "rs": a.diode_rs, "cjo": a.diode_cjo}
    if sync:
        gate_l, xl = gate_chain("xl", "xl", duty, T, lambda d: (d * T + stretch + lag, T), a.ramp, False)
        gates.append(gate_l)
        stage += [
            f"Els   dl  0   {xl} 0 1",
            f"Rgl   dl  gl  {f(a.rdrv)}",
            f"Cgl   gl  0   {f(a.cgs)}",
            "Mls   sw  gl  0  0 NLS",
            nmos_card("NLS", a.ron_ls),
            "Dhs   sw  vin DBODY",
            "Dls   0   sw  DBODY",
            diode_card("DBODY", dp),
        ]
    else:
        stage += ["Dfw   0   sw  DFW", diode_card("DFW", dp)]
    return "\n".join(gates), "\n".join(stage)


def dc_guess(a, d0):
    """Approximate DC point (vo, il) at duty d0 to start the warm-up from."""
    if a.rload:
        vo = d0 * a.U * a.rload / (a.rload + a.RL)
        return vo, vo / a.rload
    return d0 * a.U - a.io * a.RL, a.io


def netlist(a, duty, T, rawfile):
    vo0, il0 = dc_guess(a, duty[0])
    n = len(duty)
    gate, stage = power_stage(a, duty, T)
    if a.sat > 0:
        # Flux-controlled: node phi integrates the inductor voltage on a capacitor of L (so
        # v(phi) = flux/L, in amps) and a B source draws i(phi) = x + k*w*(sp((x - isat)/w) -
        # sp((-x - isat)/w)), sp the softplus, k = s/(1 - s): the incremental inductance falls
        # from L to L*(1 - s) over a knee of w = 5 % of isat, symmetric in the current's sign.
        w, k = 0.05 * a.isat, a.sat / (1 - a.sat)

        def sp(x):
            return f"(max({x},0)+ln(1+exp(-abs({x}))))"
        x = "v(phi)"
        inductor = "\n".join([
            "Gphi  0   phi sw nl 1",
            f"Cphi  phi 0   {f(a.L)} IC={f(il0)}",
            f"Bind  sw  nl  I = {x}+{f(k * w)}*({sp(f'({x}-{f(a.isat)})/{f(w)}')}"
            f"-{sp(f'(-{x}-{f(a.isat)})/{f(w)}')})",
        ])
    else:
        inductor = f"Lm    sw  nl  {f(a.L)} IC={f(il0)}"
    if a.esl > 0:
        main_cap = "\n".join([f"Rcm   out nrc {f(a.Rc)}", f"Lesl  nrc vc  {f(a.esl)}",
                              f"Cm    vc  0   {f(a.C)} IC={f(vo0)}"])
    else:
        main_cap = "\n".join([f"Rcm   out vc  {f(a.Rc)}", f"Cm    vc  0   {f(a.C)} IC={f(vo0)}"])
    # Without load_esr, Cl sits on the output node itself (no 0 V source in the LC loops).
    ncl = "ncl" if a.load_esr > 0 else "out"
    load_cap = [f"Rcl   out ncl {f(a.load_esr)}"] if a.load_esr > 0 else []
    if a.dcbias > 0:
        # Charge-controlled: node q integrates the branch current on a capacitor of Cl (so
        # v(q) = charge/Cl, in volts) and a B source holds v = h(q), the inverse of
        # q(v) = Cl*Vr/c*(1 - 1/(1 + c*v/Vr)): Cl(v) = Cl/(1 + c*v/Vr)^2, a loss of dcbias at
        # the rated voltage Vr for c = 1/sqrt(1 - dcbias) - 1.
        c = 1 / math.sqrt(1 - a.dcbias) - 1
        q0 = a.vrated / c * (1 - 1 / (1 + c * vo0 / a.vrated))
        load_cap += [
            f"Vclm  {ncl} ncv 0",
            "Fq    0   q   Vclm 1",
            f"Cq    q   0   {f(a.cl)} IC={f(q0)}",
            f"Bcv   ncv 0   V = {f(a.vrated / c)}*(1/(1-{f(c / a.vrated)}*v(q))-1)",
        ]
    else:
        load_cap.append(f"Clo   {ncl} 0   {f(a.cl)} IC={f(vo0)}")
    load = f"Rload out 0 {f(a.rload)}" if a.rload else f"Iload out 0 DC {f(a.io)}"
    # A triangle with corners at k*T + adc_delay: a time point at every ADC sample.
    adc = (f"Vadc  nadc 0 PULSE(0 1 {f(a.adc_delay)} {f(T / 2)} {f(T / 2 - 2e-12)} 1e-12 {f(T)} "
           f"{n + 1})")
    max_step = a.max_step or T / a.steps
    fields = dict(
        gate_drive=gate, power_stage=stage, U=f(a.U), csw=f(a.csw), inductor=inductor, RL=f(a.RL),
        main_cap=main_cap, load_cap="\n".join(load_cap), load=load, adc_clock=adc,
        reltol=f(a.reltol), tstep=f(max_step), tstop=f(n * T), max_step=f(max_step), rawfile=rawfile,
    )
    with open(TEMPLATE) as fh:
        return fh.read() % fields


def read_raw(path):
    """Binary ngspice raw file (real data) -> {variable name: array}."""
    with open(path, "rb") as fh:
        blob = fh.read()
    cut = blob.index(b"Binary:\n") + len(b"Binary:\n")
    head = blob[:cut].decode("latin-1").splitlines()
    nvar = npts = None
    names = []
    for i, line in enumerate(head):
        if line.startswith("No. Variables:"):
            nvar = int(line.split(":")[1])
        elif line.startswith("No. Points:"):
            npts = int(line.split(":")[1])
        elif line.startswith("Variables:"):
            names = [head[i + 1 + j].split()[1].lower() for j in range(nvar)]
    data = np.frombuffer(blob[cut:cut + 8 * nvar * npts], dtype="<f8").reshape(npts, nvar)
    return {name: data[:, j] for j, name in enumerate(names)}


def transient(a, duty):
    """Simulate ``duty`` after ``a.warmup`` periods at duty[0]: (t, vout, il) of ngspice's own
    time points, t measured from the first data period's start (the warm-up is at t < 0)."""
    if shutil.which("ngspice") is None:
        raise RuntimeError("ngspice not found on PATH")
    T = 1.0 / a.fs
    full = np.concatenate([np.full(a.warmup, duty[0]), duty])
    with tempfile.TemporaryDirectory(prefix="harness_") as tmp:
        work = os.path.abspath(a.workdir or tmp)
        os.makedirs(work, exist_ok=True)
        raw = os.path.join(work, "harness.raw")
        cir = os.path.join(work, "harness.cir")
        with open(cir, "w") as fh:
            fh.write(netlist(a, full, T, raw))
        try:
            proc = subprocess.run(["ngspice", "-b", cir], cwd=work, capture_output=True, text=True, timeout=NGSPICE_TIMEOUT)
        except subprocess.TimeoutExpired:
            raise RuntimeError(f"ngspice did not finish the transient within {NGSPICE_TIMEOUT} s") from None
        vec = read_raw(raw) if os.path.exists(raw) else None
        # ngspice -b may exit 0 after aborting the transient: require tstop reached.
        if vec is None or abs(vec["time"][-1] - len(full) * T) > 1e-6 * T:
            tail = "\n".join((proc.stdout + proc.stderr).strip().splitlines()[-15:])
            raise RuntimeError(f"ngspice failed (exit {proc.returncode}):\n{tail}")
    return vec["time"] - a.warmup * T, vec["v(out)"], vec["i(vam)"]


def transient_retrying(a, duty):
    """transient(), once more at reltol 1e-3 if ngspice gave up ("timestep too small" at some
    switching edge of the stiff MOSFET circuits); the tolerance used lands in the truth file."""
    try:
        return transient(a, duty)
    except RuntimeError as e:
        if a.reltol >= 1e-3 or "Timestep too small" not in str(e):
            raise
        print(f"harness: {str(e).splitlines()[-1]}; retrying at reltol 1e-3", file=sys.stderr)
        a.reltol = 1e-3
        return transient(a, duty)


def run(a, duty):
    """(vout, il) sampled ``a.adc_delay`` (plus ``a.adc_share`` of the on-time) after each data
    period's start, noise-free, and vout averaged in time over the data periods (the operating
    point a biased ceramic sits at)."""
    t, vout, il = transient_retrying(a, duty)
    ts = (np.arange(len(duty)) + a.adc_share * np.asarray(duty)) / a.fs + a.adc_delay
    return np.interp(ts, t, vout), np.interp(ts, t, il), time_mean(t, vout, 0.0, len(duty) / a.fs)


def time_mean(t, v, t0, t1):
    """Mean of the piecewise-linear ``v(t)`` over ``[t0, t1]`` (trapezoids on ngspice's own
    time points, the ends interpolated)."""
    inside = (t > t0) & (t < t1)
    tt = np.concatenate([[t0], t[inside], [t1]])
    vv = np.concatenate([[np.interp(t0, t, v)], v[inside], [np.interp(t1, t, v)]])
    return float(np.sum(0.5 * (vv[1:] + vv[:-1]) * np.diff(tt)) / (t1 - t0))


def parser():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add = p.add_argument
    add("--topology", choices=TOPOLOGIES, default="sw")
    add("--periods", type=int, default=3001)
    add("--warmup", type=int, default=150, help="periods at the first duty, simulated and dropped")
    add("--seed", type=int, default=1, help="PRBS start state and noise seed")
    add("--bit-periods", type=int, default=8)
    add("--cl", type=float, default=10e-6, help="load capacitance [F]")
    add("--io", type=float, default=1.0, help="load current [A] (current-source load)")
    add("--rload", type=float, default=None, help="resistive load [ohm] instead of --io")
    add("--L", type=float, default=3.3e-6)
    add("--RL", type=float, default=0.1)
    add("--C", type=float, default=100e-6)
    add("--Rc", type=float, default=0.1)
    add("--fs", type=float, default=330e3)
    add("--U", type=float, default=12.0)
    add("--ron-hs", type=float, default=2e-6, help="high-side on-resistance [ohm]")
    add("--ron-ls", type=float, default=2e-6, help="low-side on-resistance [ohm] (sw, sync)")
    add("--ramp", type=float, default=5e-9, help="gate ramp [s]")
    add("--rdrv", type=float, default=2.0, help="gate driver resistance [ohm] (sync, async)")
    add("--cgs", type=float, default=2e-9, help="gate-source capacitance [F] (sync, async)")
    add("--csw", type=float, default=200e-12, help="switch-node capacitance [F]")
    add("--dead-time", type=float, default=0.0, help="delay of each turn-on [s] (sync)")
    add("--pulse-stretch", type=float, default=0.0,
        help="the high side's gate held on this long past d*T, a drive's turn-off slower than its turn-on [s] (sync, async)")
    add("--diode-is", type=float, default=1e-11, help="diode saturation current [A]")
    add("--diode-n", type=float, default=1.2, help="diode emission coefficient")
    add("--diode-rs", type=float, default=15e-3, help="diode series resistance [ohm]")
    add("--diode-cjo", type=float, default=300e-12, help="diode zero-bias capacitance [F]")
    add("--load-esr", type=float, default=0.0, help="resistance in series with Cl [ohm]")
    add("--esl", type=float, default=0.0, help="inductance in series with the C branch [H]")
    add("--sat", type=float, default=0.0, help="fraction of L lost well above isat")
    add("--isat", type=float, default=10.0, help="saturation current [A]")
    add("--dcbias", type=float, default=0.0, help="fraction of Cl lost at the rated voltage")
    add("--vrated", type=float, default=10.0, help="rated voltage of Cl [V]")
    add("--adc-delay", type=float, default=100e-9, help="ADC sample delay after period start [s]")
    add("--adc-share", type=float, default=0.0, help="ADC triggered from the PWM: each sample a further share of the on-time D*T late")
    add("--noise-vout", type=float, default=2e-3, help="noise sigma on vout [V]")
    add("--noise-il", type=float, default=5e-3, help="noise sigma on il [A]")
    add("--vout-gain", type=float, default=0.0, help="gain error of the vout probe (vout read as (1+g)*vout + offset)")
    add("--vout-offset", type=float, default=0.0, help="zero error of the vout probe [V]")
    add("--il-gain", type=float, default=0.0, help="gain error of the current probe")
    add("--il-offset", type=float, default=0.0, help="zero error of the current probe [A]")
    add("--steps", type=int, default=100, help="max time step = T/steps")
    add("--max-step", type=float, default=None)
    add("--reltol", type=float, default=1e-4)
    add("--effects", default="", help="label(s) for the truth file only, e.g. dead_time,load_esr")
    add("--workdir", help="keep netlist and raw file here")
    add("--out", default="-", help="CSV file ('-' = stdout)")
    add("--truth", help="JSON file with everything the run used")
    return p


def generate(a):
    """(csv text, truth dict) for parsed arguments ``a``."""
    duty = prbs(a.periods, a.seed, a.bit_periods)
    clock = time.perf_counter()
    vout, il, vout_time_mean = run(a, duty)
    seconds = time.perf_counter() - clock
    rng = np.random.default_rng(a.seed)
    vout = vout + rng.normal(0.0, a.noise_vout, len(vout))
    il = il + rng.normal(0.0, a.noise_il, len(il))
    # The probes' calibration: what a scope or an ADC chain makes of the (noisy) signals.
    vout = (1.0 + a.vout_gain) * vout + a.vout_offset
    il = (1.0 + a.il_gain) * il + a.il_offset
    T = 1.0 / a.fs
    io = np.zeros(len(duty)) if a.rload else np.full(len(duty), a.io)
    meta = [f"# fs = {f(a.fs)}", f"# U = {f(a.U)}"]
    if a.rload:
        meta.append(f"# rload = {f(a.rload)}")
    # The true operating point (noise-free, before the probes), for scoring a biased ceramic's
    # Cl; the blind bench strips it before the diagnosis sees the data.
    meta.append(f"# vout_time_mean = {vout_time_mean!r}")
    rows = ["time,duty,vin,io,vout,il"]
    rows += [f"{k * T!r},{d!r},{a.U!r},{i!r},{v!r},{c!r}"
             for k, (d, i, v, c) in enumerate(zip(duty.tolist(), io.tolist(), vout.tolist(), il.tolist()))]
    truth = {k: v for k, v in vars(a).items() if k not in ("out", "truth", "workdir")}
    truth["effects"] = [e for e in a.effects.split(",") if e]
    truth["ngspice_seconds"] = seconds
    if a.topology in ("sync", "async"):
        dp = {"is": a.diode_is, "n": a.diode_n, "rs": a.diode_rs}
        truth["diode_vf_at_io"] = diode_vf(max(a.io, 1e-3), dp)
    return "\n".join(meta + rows) + "\n", truth


def main(argv=None):
    a = parser().parse_args(argv)
    text, truth = generate(a)
    if a.out == "-":
        sys.stdout.write(text)
    else:
        with open(a.out, "w") as fh:
            fh.write(text)
    if a.truth:
        with open(a.truth, "w") as fh:
            json.dump(truth, fh, indent=2)
            fh.write("\n")


if __name__ == "__main__":
    main()
