"""The FMU in switched mode against ngspice (an independent circuit simulator) on the ideal-switch
buck: 3001 periods of a PRBS duty (0.4/0.6, 8 periods per bit) when ngspice is installed, and
the 500-period ideal fixture (scripts/spice/spice_fixtures.py: a live run when ngspice is
installed, else the committed tests/fixtures/spice/ideal.csv) always.

Tolerances (issue 2): period-averaged `vout` within 1 mV and `il` within 10 mA. The ngspice run
itself is accurate to a few µV and ~10 µA at its T/100 maximum step (see
scripts/spice/buck_spice.py), so a real model error of a fraction of the tolerance shows. The
period-start samples are compared too (the digital controller's view), with the same bounds.
The nonlinear effects (inductor_saturation, cap_dc_bias) state their own, from the agreement
measured and what limits it.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from fmu_harness import SWITCHED, drive, open_slave

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts" / "spice"))
import buck_spice  # noqa: E402
import spice_fixtures  # noqa: E402

needs_ngspice = pytest.mark.skipif(shutil.which("ngspice") is None, reason="ngspice is not installed")

PERIODS = 3001


@needs_ngspice
@pytest.mark.parametrize("cl", [0.2e-6, 100e-6])
def test_fmu_matches_ngspice_over_3001_prbs_periods(fmu_dir, model_description, cl):
    io = 1.0
    duty = buck_spice.prbs_duty(PERIODS, bit_periods=8, low=0.4, high=0.6, seed=1)
    spice = buck_spice.simulate(duty, Cl=cl, io=io)
    assert_fmu_matches(fmu_dir, model_description, f"vs-ngspice-{cl}", duty, cl, io, spice)


@needs_ngspice
@pytest.mark.parametrize("effect", [{"load_esr": 0.02}, {"esl": 1.5e-9}, {"load_esr": 0.01, "esl": 1e-9}])
def test_fmu_output_network_effects_match_ngspice(fmu_dir, model_description, effect):
    # load_esr (a resistor in series with Cl) and esl (an inductor in series with C and Rc) in
    # the netlist against the same parameters of the FMU; 600 PRBS periods at Cl = 4.7 µF, where
    # Cl shares the switching ripple with C and both elements shape the response.
    io, cl = 1.0, 4.7e-6
    duty = buck_spice.prbs_duty(600, bit_periods=8, low=0.4, high=0.6, seed=3)
    spice = buck_spice.simulate(duty, Cl=cl, io=io, **effect)
    plain = buck_spice.simulate(duty, Cl=cl, io=io)
    assert_fmu_matches(fmu_dir, model_description, f"vs-ngspice-{sorted(effect)}", duty, cl, io, spice, effect)
    # Not vacuous: the element moves the period-start vout by more than the tolerance.
    assert np.abs(spice["vout_start"] - plain["vout_start"]).max() > 1.5e-3


@needs_ngspice
@pytest.mark.parametrize("pwd", [30e-9, -30e-9])
def test_fmu_pulse_width_distortion_matches_ngspice(fmu_dir, model_description, pwd):
    # The switch's on-time stretched (or shortened) by 30 ns, 1 % of the period, in the netlist's
    # switch waveform against the FMU's `pulse_width_distortion`: 600 PRBS periods at Cl = 4.7 µF.
    io, cl = 1.0, 4.7e-6
    duty = buck_spice.prbs_duty(600, bit_periods=8, low=0.4, high=0.6, seed=3)
    spice = buck_spice.simulate(duty, Cl=cl, io=io, pulse_width_distortion=pwd)
    plain = buck_spice.simulate(duty, Cl=cl, io=io)
    assert_fmu_matches(fmu_dir, model_description, f"vs-ngspice-pwd-{pwd}", duty, cl, io, spice,
                       {"pulse_width_distortion": pwd})
    # Not vacuous: the stretch moves the output by U·δ/T = 119 mV.
    shift = np.mean(spice["vout_avg"][100:] - plain["vout_avg"][100:])
    assert abs(shift - 12.0 * pwd * 330e3) < 2e-3, shift


@needs_ngspice
@pytest.mark.parametrize("cl, effect", [
    (0.47e-6, {"rload": 2.0}),
    (47e-6, {"rload": 10.0}),
    (4.7e-6, {"rload": 5.0, "load_esr": 0.02}),
    (4.7e-6, {"rload": 3.0, "load_esr": 0.01, "esl": 1e-9}),
])
def test_fmu_resistive_load_matches_ngspice(fmu_dir, model_description, cl, effect):
    # A load resistor from out to 0 beside Iload (io = 0.5 A) in the netlist against the FMU's
    # `rload` (with load_esr it sits at the node, across the series Cl + ESR branch, in both);
    # 600 PRBS periods, both starting at the averaged DC point with the resistor.
    io = 0.5
    duty = buck_spice.prbs_duty(600, bit_periods=8, low=0.4, high=0.6, seed=3)
    spice = buck_spice.simulate(duty, Cl=cl, io=io, **effect)
    plain = buck_spice.simulate(duty, Cl=cl, io=io, **{k: v for k, v in effect.items() if k != "rload"})
    assert_fmu_matches(fmu_dir, model_description, f"vs-ngspice-rload-{cl}-{sorted(effect)}", duty, cl, io,
                       spice, effect)
    # Not vacuous: the resistor's current moves the output by far more than the tolerance.
    assert np.abs(spice["vout_avg"] - plain["vout_avg"]).max() > 0.05


@needs_ngspice
@pytest.mark.parametrize("effect, vout_tol, il_tol", [
    # isat = io + 0.3 A: the PRBS swings il from -8.8 A to +7.4 A, through both +-isat, so
    # both inductances are visited every few periods. The netlist's step in L is found by
    # ngspice's truncation-error control (buck_spice.SATURATION_TRTOL), the plant's to 1e-15*T:
    # 72 uV in vout, 0.39 mA in il (max over both samples).
    ({"inductor_saturation": 0.3, "isat": 1.3}, 0.2e-3, 1e-3),
    # The netlist's Cl(v) follows v continuously (ngspice agrees with an RK4 integration to
    # 10 uV); the plant holds Cl over each period at its value for the mid-period voltage,
    # extrapolated from the last two period starts. The extrapolation misses in the first period
    # after each PRBS step: 0.40 mV in the period-start vout, 0.08 mV averaged, 0.10 mA in il
    # (holding the start value instead: 0.51 mV, 0.19 mV, 0.93 mA).
    ({"cap_dc_bias": 0.5}, 0.6e-3, 0.3e-3),
])
def test_fmu_nonlinear_effects_match_ngspice(fmu_dir, model_description, effect, vout_tol, il_tol):
    # inductor_saturation (incremental L*(1 - s) above isat) and cap_dc_bias (incremental
    # Cl*(1 - b*min((v/16 V)^2, 1)), v across Cl) as behavioural elements of the netlist against
    # the same parameters of the FMU; 600 PRBS periods at Cl = 4.7 uF.
    io, cl = 1.0, 4.7e-6
    duty = buck_spice.prbs_duty(600, bit_periods=8, low=0.4, high=0.6, seed=3)
    spice = buck_spice.simulate(duty, Cl=cl, io=io, **effect)
    plain = buck_spice.simulate(duty, Cl=cl, io=io)
    assert_fmu_matches(fmu_dir, model_description, f"vs-ngspice-{sorted(effect)}", duty, cl, io, spice,
                       effect, vout_tol=vout_tol, il_tol=il_tol)
    # Not vacuous: the effect moves the period-start vout by several tolerances.
    assert np.abs(spice["vout_start"] - plain["vout_start"]).max() > 5 * vout_tol
    if "isat" in effect:
        assert spice["il_start"].min() < -effect["isat"] and spice["il_start"].max() > effect["isat"]


def test_fmu_matches_the_ngspice_fixture(fmu_dir, model_description):
    # The fixture starts at the averaged DC point of its first duty (no warm-up), like the FMU.
    f = spice_fixtures.load("ideal")
    assert f.truth["warmup"] == 0
    c = f.columns
    spice = {"vout_avg": c["vout_avg"], "il_avg": c["il_avg"],
             "vout_start": c["vout"], "il_start": c["il"]}
    assert_fmu_matches(fmu_dir, model_description, "vs-ngspice-fixture", c["duty"],
                       f.num("Cl"), f.num("io"), spice)


def assert_fmu_matches(fmu_dir, model_description, name, duty, cl, io, spice, effects=None,
                       vout_tol=1e-3, il_tol=10e-3):
    """Drives the FMU in switched mode (with the parameters `effects`) with `duty` and compares
    it with the ngspice run, within `vout_tol` [V] and `il_tol` [A]."""
    start = {"mode": SWITCHED, "Cl": cl, "io": io, "duty": float(duty[0]), **(effects or {})}
    with open_slave(fmu_dir, model_description, name, start=start) as fmu:
        rows = drive(fmu, model_description, duty)  # period ends: vout, il, vc, vout_avg, il_avg
    vout_avg_err = np.abs(rows[:, 3] - spice["vout_avg"]).max()
    il_avg_err = np.abs(rows[:, 4] - spice["il_avg"]).max()
    assert vout_avg_err < vout_tol, f"period-averaged vout differs by {vout_avg_err:.3e} V"
    assert il_avg_err < il_tol, f"period-averaged il differs by {il_avg_err:.3e} A"
    # Period-start samples: row k ends period k, i.e. the start of period k+1.
    vout_start_err = np.abs(rows[:-1, 0] - spice["vout_start"][1:]).max()
    il_start_err = np.abs(rows[:-1, 1] - spice["il_start"][1:]).max()
    assert vout_start_err < vout_tol, f"period-start vout differs by {vout_start_err:.3e} V"
    assert il_start_err < il_tol, f"period-start il differs by {il_start_err:.3e} A"
    # The comparison is not vacuous: the PRBS moves the output by volts.
    assert np.ptp(spice["vout_avg"]) > 1.0


@needs_ngspice
@pytest.mark.parametrize("io, snubber", [(0.3, (30.0, 4.7e-9)), (0.5, (60.0, 2.2e-9))], ids=["30ohm-4n7", "60ohm-2n2"])
def test_fmu_snubbed_diode_buck_in_dcm_matches_ngspice(fmu_dir, model_description, io, snubber):
    """ngspice's diode buck (VDMOS high side, Schottky, buck_async.cir) with an RC snubber on
    its switch node, at a load light enough that every period ends in DCM, against the FMU with
    the same diode (0.3 V and 25 mOhm: the Schottky's drop at a few hundred mA) and the snubber
    as the node's capacitance behind its resistance (`switch_node_capacitance` = Csn,
    `switch_node_damping` = Rsn, `switch_node_ring`). Both settle 3000 periods at the first
    duty (the output's time constant in DCM is a thousand periods), then 400 PRBS periods.

    Once the diode blocks, the inductor draws the snubber's charge from the output through a
    damped ring: modelled so, the period-start vout misses ngspice's by at most 0.6 of the miss
    without any node capacitance, and by at most half the miss with the same capacitance
    ringing undamped (measured: 22.1 mV RMS against 73.6 and 58.8 for 30 Ohm / 4.7 nF, 12.1
    against 24.5 and 171 for 60 Ohm / 2.2 nF); the period-start il within 12 mA (8.8, 8.6). What is left
    is the junction's and the MOSFET's capacitances, not modelled, and not the diode's
    exponential law: the FMU's (`diode_emission`) with the card's own Is, N and Rs leaves 17.3 mV
    at 60 Ohm / 2.2 nF, mostly a mean offset (test_fmu_diode_on_its_exponential_law_...)."""
    rsn, csn = snubber
    cl, warm = 4.7e-6, 3000
    duty = buck_spice.prbs_duty(400, bit_periods=8, low=0.4, high=0.6, seed=3)
    spice = buck_spice.simulate(duty, Cl=cl, io=io, circuit="async", snubber=snubber, warmup=warm)
    assert spice["il_start"].max() < 0.05, "the periods do not all end in DCM"
    diode = {"dcm": True, "diode_drop": 0.3, "diode_resistance": 0.025, "switch_resistance": 0.01}

    def misses(node: dict) -> tuple[float, float]:
        start = {"mode": SWITCHED, "Cl": cl, "io": io, "duty": float(duty[0]), **diode, **node}
        with open_slave(fmu_dir, model_description, f"snubber-{sorted(node)}", start=start) as fmu:
            drive(fmu, model_description, np.full(warm, duty[0]))
            rows = drive(fmu, model_description, duty, k0=warm)
        # Row k ends period k: the start of period k+1. The first 50 periods let both settle
        # from their warm-ups' last sample.
        dv = rows[50:-1, 0] - spice["vout_start"][51:]
        di = rows[50:-1, 1] - spice["il_start"][51:]
        return float(np.sqrt(np.mean(dv**2))), float(np.abs(di).max())

    snubbed, il_miss = misses({"switch_node_capacitance": csn, "switch_node_ring": True, "switch_node_damping": rsn})
    bare, _ = misses({})
    undamped, _ = misses({"switch_node_capacitance": csn, "switch_node_ring": True})
    assert snubbed < 0.6 * bare and snubbed < 0.5 * undamped, (snubbed, bare, undamped)
    assert il_miss < 12e-3, f"period-start il misses by {il_miss * 1e3:.1f} mA"


@needs_ngspice
def test_fmu_diode_on_its_exponential_law_follows_ngspices_schottky(fmu_dir, model_description):
    """ngspice's diode buck (buck_async.cir, its Schottky card Is = 5 uA, N = 1.1, Rs = 25 mOhm)
    at io = 1.5 A, where each off-time takes the diode from about 3 A down to zero, the
    boundary of CCM and DCM: over those decades its drop bends along the logarithm of its
    current. The FMU is given the card
    itself: `diode_emission` = N*Vt, `diode_drop` its drop at 1 A, `diode_resistance` = Rs, the
    snubber as the node's damped capacitance. Against it, the straight lines a datasheet
    gives for the same diode: its tangent at the operating current (the best line of the
    two) and at 1 A, each with its slope `Rs + N*Vt/I` as `diode_resistance`.

    The law misses the period-start vout by at most 0.7 of the tangent's miss and il by at most
    half (measured: 12.5 mV RMS against 20.2, 4.9 mA against 13.0; the tangent at 1 A 28.4 mV
    and 25.9 mA). What is left is mostly a mean offset of -12 mV: the junction's and the
    MOSFET's capacitances, not modelled."""
    io, (rsn, csn), cl, warm = 1.5, (60.0, 2.2e-9), 4.7e-6, 300
    duty = buck_spice.prbs_duty(400, bit_periods=8, low=0.4, high=0.6, seed=3)
    spice = buck_spice.simulate(duty, Cl=cl, io=io, circuit="async", snubber=(rsn, csn), warmup=warm)
    assert np.median(np.abs(spice["il_start"])) < 0.05, "the off-times must end near zero current"
    card = buck_spice.diode_params()
    nvt = card["N"] * 1.380649e-23 * 300.15 / 1.602176634e-19

    def misses(diode: dict) -> tuple[float, float]:
        start = {"mode": SWITCHED, "Cl": cl, "io": io, "duty": float(duty[0]), "dcm": True, "switch_resistance": 0.01,
                 "switch_node_capacitance": csn, "switch_node_ring": True, "switch_node_damping": rsn, **diode}
        with open_slave(fmu_dir, model_description, f"law-{sorted(diode)}-{diode['diode_drop']}", start=start) as fmu:
            drive(fmu, model_description, np.full(warm, duty[0]))
            rows = drive(fmu, model_description, duty, k0=warm)
        dv = rows[50:-1, 0] - spice["vout_start"][51:]
        di = rows[50:-1, 1] - spice["il_start"][51:]
        return float(np.sqrt(np.mean(dv**2))), float(np.sqrt(np.mean(di**2)))

    def tangent(i: float) -> dict:
        slope = card["Rs"] + nvt / i
        return {"diode_drop": buck_spice.diode_vf(i, card) - slope * i, "diode_resistance": slope}

    law = misses({"diode_drop": buck_spice.diode_vf(1.0, card) - card["Rs"], "diode_resistance": card["Rs"], "diode_emission": nvt})
    at_io, at_1a = misses(tangent(io)), misses(tangent(1.0))
    assert law[0] < 0.7 * at_io[0] and law[1] < 0.5 * at_io[1], (law, at_io)
    assert law[0] < 0.5 * at_1a[0] and law[1] < 0.5 * at_1a[1], (law, at_1a)
