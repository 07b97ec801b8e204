"""The FMU's digital voltage-mode loop (control = 2) driven by fmpy against the in-process Rust
model (`trajectory` example, NAME=VALUE settings): same inputs, same outputs. And identification
through the CLI while the loop regulates (`buckid identify --closed-loop`)."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from fmu_harness import SWITCHED, T, messages, open_slave, prbs_duty, vr

LOOP = {"control": 2, "delay": 1, "dpwm_bits": 10, "adc_noise": 2e-3, "noise_seed": 5, "vref": 5.0}


def fmu_closed_loop(fmu_dir, md, dither, cl):
    """One period per dither value through fmpy; rows: vout, il, vout_avg, duty_applied, vout_adc."""
    names = ["vout", "il", "vout_avg", "duty_applied", "vout_adc"]
    refs = [vr(md, n) for n in names]
    with open_slave(fmu_dir, md, f"cl-{cl}", start={**LOOP, "mode": SWITCHED, "Cl": cl, "duty_dither": float(dither[0])}) as fmu:
        rows = []
        for k, d in enumerate(dither):
            fmu.setReal([vr(md, "duty_dither")], [float(d)])
            fmu.doStep(k * T, T)
            rows.append(fmu.getReal(refs))
    return np.array(rows)


@pytest.mark.parametrize("cl", [2.2e-6, 47e-6])
def test_closed_loop_fmu_matches_rust_model(fmu_dir, model_description, trajectory_bin, cl):
    """Bit-for-bit agreement (1e-12) of the regulated output, the applied duty and the ADC
    reading between the FMU in fmpy and the Rust model in process; the loop regulates
    (vout_adc stays within 5 % of vref) and the dither reaches the switch."""
    dither = prbs_duty(600, lo=-0.02, hi=0.02)
    fmu = fmu_closed_loop(fmu_dir, model_description, dither, cl)
    args = [str(trajectory_bin), "switched", repr(cl), "1.0"] + [f"{k}={v}" for k, v in LOOP.items()]
    proc = subprocess.run(args, input="\n".join(repr(float(d)) for d in dither), capture_output=True, text=True, check=True)
    rust = np.genfromtxt(proc.stdout.splitlines(), delimiter=",", names=True)
    for i, name in enumerate(["vout", "il", "vout_avg", "duty_applied", "vout_adc"]):
        assert np.abs(fmu[:, i] - rust[name]).max() <= 1e-12, name
    assert np.abs(fmu[:, 4] - 5.0).max() < 0.25, "the loop does not regulate"
    assert np.ptp(fmu[:, 3]) > 0.03, "the dither does not reach the switch"


def test_cli_identifies_cl_in_closed_loop(fmu_path, buckid_bin, tmp_path):
    """`buckid identify --closed-loop` on our FMU (PID with one period of delay, 2 mV ADC noise in
    the loop, 0.2 A load disturbance): the true Cl lies in the CI95, the report names the
    excitation, and the Kalman predictor was used."""
    out = tmp_path / "cl.json"
    cl = 22e-6
    proc = subprocess.run(
        [str(buckid_bin), "identify", "--fmu", str(fmu_path), "--closed-loop",
         "--set", f"Cl={cl}", "--set", "delay=1", "--set", "adc_noise=2e-3", "--load-noise", "0.2",
         "--json", str(out)],
        capture_output=True, text=True, check=False,
    )
    assert proc.returncode == 0, proc.stderr
    result = json.loads(out.read_text())
    lo, hi = result["cl"]["ci95"]
    assert lo <= cl <= hi, result["cl"]
    assert result["noise_model"] == "innovations"
    assert result["excitation"] == {"closed_loop": True, "signal": "duty_dither", "levels": [-0.02, 0.02],
                                    "recorded_duty": "duty_applied", "load_noise": 0.2}
    assert "closed loop: PRBS -0.02/0.02 on duty_dither" in proc.stdout


def test_the_adc_reads_at_its_instant_within_the_period(fmu_dir, model_description):
    """`adc_delay`: the FMU's ADC reads vout and il a quarter period after each period start, so
    `vout_adc` and `il_adc` hold what fmpy reads from the instantaneous outputs there (to 1e-12),
    not the period start's il (the ramp in between); at the period start by default; an instant
    past the period is an error that names it."""
    md = model_description
    refs = [vr(md, n) for n in ("vout", "il", "vout_adc", "il_adc")]
    duty = prbs_duty(120)
    for delay in (T / 4, 0.0):
        with open_slave(fmu_dir, md, f"adc-{delay}", start={"mode": SWITCHED, "adc_delay": delay}) as fmu:
            starts, quarters, readings = [], [], []
            for k, d in enumerate(duty):
                fmu.setReal([vr(md, "duty")], [float(d)])
                starts.append(fmu.getReal(refs)[:2])
                fmu.doStep(k * T, T / 4)
                quarters.append(fmu.getReal(refs)[:2])
                fmu.doStep(k * T + T / 4, 3 * T / 4)
                readings.append(fmu.getReal(refs)[2:])
        seen = np.array(quarters if delay > 0 else starts[1:] + [starts[-1]])
        read = np.array(readings)
        assert np.abs(read[:-1] - seen[:-1]).max() <= 1e-12, delay
        # The inductor's ramp over a quarter period tells the two instants apart.
        assert np.abs(np.array(quarters)[:, 1] - np.array(starts)[:, 1]).min() > 0.05
    with open_slave(fmu_dir, md, "adc-late", start={"mode": SWITCHED, "adc_delay": 2 * T}) as fmu:
        with pytest.raises(Exception):
            fmu.doStep(0.0, T)
    assert any("adc_delay" in m for m in messages("adc-late")), messages("adc-late")


def test_the_adc_reads_each_channel_at_its_own_instant(fmu_dir, model_description):
    """`adc_vout_skew`: the FMU's ADC converts il at `adc_delay` and vout `adc_vout_skew` later
    (or earlier), so `il_adc` and `vout_adc` hold what fmpy reads from the instantaneous outputs
    at each channel's own instant (to 1e-12), in either order; a vout instant outside the period
    is an error that names the skew."""
    md = model_description
    refs = [vr(md, n) for n in ("vout", "il", "vout_adc", "il_adc")]
    duty = prbs_duty(120)
    for il_at, skew in ((T / 8, T / 2), (T / 2, -T / 4)):
        vout_at = il_at + skew
        first, second = sorted((il_at, vout_at))
        with open_slave(fmu_dir, md, f"skew-{skew}", start={"mode": SWITCHED, "Cl": 4.7e-6, "adc_delay": il_at, "adc_vout_skew": skew}) as fmu:
            seen, readings, moved = [], [], []
            for k, d in enumerate(duty):
                fmu.setReal([vr(md, "duty")], [float(d)])
                fmu.doStep(k * T, first)
                at_first = fmu.getReal(refs)[:2]
                fmu.doStep(k * T + first, second - first)
                at_second = fmu.getReal(refs)[:2]
                fmu.doStep(k * T + second, T - second)
                readings.append(fmu.getReal(refs)[2:])
                vout_read, il_read = (at_first, at_second) if vout_at < il_at else (at_second, at_first)
                seen.append((vout_read[0], il_read[1]))
                moved.append(abs(at_second[0] - at_first[0]))
        assert np.abs(np.array(readings) - np.array(seen)).max() <= 1e-12, (il_at, skew)
        # vout moves between the two instants by far more than that.
        assert min(moved) > 1e-4, (il_at, skew)
    with open_slave(fmu_dir, md, "skew-out", start={"mode": SWITCHED, "adc_delay": T / 4, "adc_vout_skew": -T / 2}) as fmu:
        with pytest.raises(Exception):
            fmu.doStep(0.0, T)
    assert any("adc_vout_skew" in m for m in messages("skew-out")), messages("skew-out")


def test_each_adc_channel_carries_its_own_white_noise(fmu_dir, model_description):
    """`adc_noise` on vout and `adc_il_noise` on il, one `noise_seed`: read at the period start,
    `vout_adc - vout` and `il_adc - il` (fmpy's instantaneous outputs) over 3000 periods have the
    set standard deviations and zero means (4-sigma bounds of the estimates), are uncorrelated
    with each other and from one period to the next (|r| < 4/sqrt(N)); a negative standard
    deviation is refused, naming it."""
    md = model_description
    refs = [vr(md, n) for n in ("vout", "il", "vout_adc", "il_adc")]
    n, sv, si = 3000, 3e-3, 20e-3
    duty = prbs_duty(n)
    with open_slave(fmu_dir, md, "il-noise", start={"mode": SWITCHED, "Cl": 4.7e-6, "adc_noise": sv, "adc_il_noise": si, "noise_seed": 11}) as fmu:
        errors = []
        for k, d in enumerate(duty):
            fmu.setReal([vr(md, "duty")], [float(d)])
            fmu.doStep(k * T, T)
            vout, il, vout_adc, il_adc = fmu.getReal(refs)
            errors.append((vout_adc - vout, il_adc - il))
    dv, di = np.array(errors).T
    for x, sigma in ((dv, sv), (di, si)):
        assert abs(x.mean()) < 4 * sigma / np.sqrt(n), (sigma, x.mean())
        assert abs(x.std() / sigma - 1) < 4 / np.sqrt(2 * n), (sigma, x.std())
        assert abs(np.corrcoef(x[1:], x[:-1])[0, 1]) < 4 / np.sqrt(n), sigma
    assert abs(np.corrcoef(dv, di)[0, 1]) < 4 / np.sqrt(n)
    with pytest.raises(Exception):
        with open_slave(fmu_dir, md, "il-noise-negative", start={"mode": SWITCHED, "adc_il_noise": -1e-3}):
            pass
    assert any("adc_il_noise" in m for m in messages("il-noise-negative")), messages("il-noise-negative")


def test_the_adc_reads_each_channel_through_its_own_filter(fmu_dir, model_description):
    """`adc_filter` and `adc_il_filter`: the ADC's vout channel reads through an RC low-pass of
    tau and its il channel through one of tau/2, so after each period `vout_adc` and `il_adc`
    hold the filters' outputs over the instantaneous vout and il fmpy reads on 400 steps a
    period (each filter integrated exactly for a line through each step: within 10 uV and
    10 uA, against a ripple and a lag of 150 mV and of amperes unfiltered)."""
    md = model_description
    refs = [vr(md, n) for n in ("vout", "il", "vout_adc", "il_adc")]
    tau, steps = T / np.pi, 400
    taus = np.array([tau, tau / 2])
    h = T / steps
    decay = np.exp(-h / taus)
    start = {"mode": SWITCHED, "adc_filter": tau, "adc_il_filter": tau / 2, "Cl": 4.7e-6}
    with open_slave(fmu_dir, md, "adc-filter", start=start) as fmu:
        filtered, worst, unfiltered = None, np.zeros(2), np.zeros(2)
        for k, d in enumerate(prbs_duty(40)):
            fmu.setReal([vr(md, "duty")], [float(d)])
            for s in range(steps):
                x0 = np.array(fmu.getReal(refs)[:2])
                filtered = x0 if filtered is None else filtered
                fmu.doStep((k * steps + s) * h, h)
                v1, il, vout_adc, il_adc = fmu.getReal(refs)
                x1 = np.array([v1, il])
                lag = (x1 - x0) / h * taus
                filtered = x1 - lag + (filtered - x0 + lag) * decay
            worst = np.maximum(worst, np.abs(np.array([vout_adc, il_adc]) - filtered))
            unfiltered = np.maximum(unfiltered, np.abs(x1 - filtered))
    assert np.all(worst < 1e-5), worst
    assert np.all(unfiltered > 20 * worst), unfiltered
