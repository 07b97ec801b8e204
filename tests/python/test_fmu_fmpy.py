"""The BuckConverter FMU driven by fmpy: compliance checks, settling onto the analytic DC point,
an independent exact reference (scipy `expm`), the in-process Rust model, communication-step
independence, instance isolation, reset and FMU states, and error handling.

Every row compared below is taken at a switching-period end and holds
`[vout, il, vc, vout_avg, il_avg]` (see `OUTPUTS`).
"""

from __future__ import annotations

import math
import re
import subprocess

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import fmi2Error
from fmpy.validation import validate_fmu

from conftest import assert_fmutool_clean
from fmu_harness import (
    OUTPUTS,
    AVERAGED,
    SWITCHED,
    L,
    RL,
    C,
    RC,
    FS,
    U,
    T,
    messages,
    set_values,
    vr,
    open_slave,
    initialize_slave,
    period,
    drive,
    prbs_duty,
    reference,
)


# ---- Compliance -------------------------------------------------------------------------------
def test_fmpy_validate_fmu_finds_no_problem(fmu_path):
    assert validate_fmu(str(fmu_path)) == []


def test_fmutool_check_is_clean(fmu_path, fmutool):
    assert_fmutool_clean(fmu_path, fmutool)


def test_start_values_are_the_documented_ones(model_description):
    """The module constants used by the reference are the FMU's start values (else the reference
    would compare two different circuits)."""
    start = {v.name: v.start for v in model_description.modelVariables}
    assert {k: float(start[k]) for k in ("L", "RL", "C", "Rc", "fs", "vin")} == {
        "L": L, "RL": RL, "C": C, "Rc": RC, "fs": FS, "vin": U}
    assert float(model_description.defaultExperiment.stepSize) == pytest.approx(T, rel=1e-15)


# ---- Settling onto the analytic DC point (fmpy's own master loop) ----------------------------
@pytest.mark.parametrize("mode", [AVERAGED, SWITCHED], ids=["averaged", "switched"])
def test_simulate_fmu_settles_on_dc_point(fmu_path, mode):
    """From zero state, 30 ms (≈ 900 time constants of the slowest pole, ~33 µs) of `simulate_fmu`
    with a step that is no multiple of T (1 µs) must end on the CCM DC point
    `vout = d·U − RL·io`, `il = io`. In switched mode the exact period averages hit it exactly in
    periodic steady state (volt-second and charge balance), so the same 1 mV / 1 mA bound holds
    for `vout_avg` / `il_avg` (observed: 1e-14). The instantaneous vout ripple (0.16 V p-p here)
    would not fit in it, and its presence (> 10 mV over the last 100 µs) shows that switched mode
    really is in force (averaged: flat to < 1 µV)."""
    duty, io = 0.42, 2.0
    expected = duty * U - RL * io  # 4.84 V
    res = simulate_fmu(
        str(fmu_path), stop_time=0.03, step_size=1e-6, output_interval=1e-6,
        start_values={"mode": mode, "Cl": 4.7e-6, "duty": duty, "io": io,
                      "start_at_steady_state": False},
        output=list(OUTPUTS),
    )
    assert res["vout"][0] == 0.0 and res["il"][0] == 0.0, "must start from zero, not at the DC point"
    last = res[-1]
    if mode == AVERAGED:
        assert abs(last["vout"] - expected) < 1e-3
        assert abs(last["il"] - io) < 1e-3
    assert abs(last["vout_avg"] - expected) < 1e-3
    assert abs(last["il_avg"] - io) < 1e-3
    ripple = np.ptp(res["vout"][-100:])
    assert ripple > 1e-2 if mode == SWITCHED else ripple < 1e-6, f"vout ripple {ripple} V"
    assert res["time"][-1] == pytest.approx(0.03)


# ---- Exactness against the independent reference and the in-process Rust model ----------------
N_PERIODS = 600


@pytest.fixture(scope="module")
def duties() -> np.ndarray:
    d = prbs_duty(N_PERIODS)
    assert set(np.unique(d)) == {0.4, 0.6}
    return d


@pytest.mark.parametrize("cl", [0.2e-6, 47e-6], ids=["Cl=0.2u", "Cl=47u"])
@pytest.mark.parametrize("mode", [SWITCHED, AVERAGED], ids=["switched", "averaged"])
def test_fmu_matches_expm_reference(fmu_dir, model_description, duties, cl, mode):
    """FMU through FMU2Slave (setReal duty, doStep(T), getReal) against `reference()`.

    Tolerance 1e-9·max(1, |ref|): both sides are exact solutions, so differences are only
    floating-point rounding of two independent expm implementations (nalgebra vs scipy Padé),
    propagated through a contracting system: observed ≤ 6e-12 (il, Cl = 0.2 µF, where the PRBS
    rings il over 15 A p-p), so the bound has a margin of > 100. It is still tight enough to see
    a 1 ppm error in Cl (1.7e-8 A); a duty latched one period late is off by 2.6 A, RL off by 1 %
    by 38 mA."""
    io = 1.0
    with open_slave(fmu_dir, model_description, "ref",
                    {"mode": mode, "Cl": cl, "io": io, "duty": duties[0]}) as fmu:
        got = drive(fmu, model_description, duties)
    ref = reference(duties, cl, io, mode)
    err = np.abs(got - ref) / np.maximum(1.0, np.abs(ref))
    worst = np.unravel_index(np.argmax(err), err.shape)
    assert err.max() < 1e-9, f"max rel-ish error {err.max():.3g} in {OUTPUTS[worst[1]]} at period {worst[0]}"
    # The PRBS must really move the converter, else the comparison proves little.
    assert np.ptp(ref[:, 3]) > 1.0


@pytest.mark.parametrize("cl", [0.2e-6, 47e-6], ids=["Cl=0.2u", "Cl=47u"])
@pytest.mark.parametrize("mode", [SWITCHED, AVERAGED], ids=["switched", "averaged"])
def test_fmu_matches_trajectory_binary(fmu_dir, model_description, trajectory_bin, duties, cl, mode):
    """The FMU and the in-process Rust model (`trajectory` example) run the same code on the same
    doubles, so they must agree to 1e-12 (observed: bit for bit; the CSV prints shortest
    round-trip floats)."""
    io = 1.5
    proc = subprocess.run(
        [str(trajectory_bin), "switched" if mode == SWITCHED else "averaged", repr(cl), repr(io)],
        input="".join(f"{float(d)!r}\n" for d in duties), capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    table = np.genfromtxt(proc.stdout.splitlines(), delimiter=",", names=True)
    rust = np.column_stack([table[n] for n in OUTPUTS])
    assert len(rust) == len(duties)
    np.testing.assert_allclose(table["time"], T * np.arange(1, len(duties) + 1), rtol=1e-12)
    with open_slave(fmu_dir, model_description, "traj",
                    {"mode": mode, "Cl": cl, "io": io, "duty": duties[0]}) as fmu:
        got = drive(fmu, model_description, duties)
    assert np.abs(got - rust).max() <= 1e-12


@pytest.mark.parametrize("mode", [SWITCHED, AVERAGED], ids=["switched", "averaged"])
def test_ragged_steps_give_the_same_period_ends(fmu_dir, model_description, duties, mode):
    """Steps of 0.37, 0.05, 0.18, 0.25, 0.15 T: the 0.4 T switching instant falls inside the 0.05 T
    step and the 0.6 T one on a step boundary (up to rounding). Period-end values must equal those
    of one step per period within 1e-9 (exact either way; only rounding of the split pieces,
    observed ≤ 5e-12)."""
    start = {"mode": mode, "Cl": 0.2e-6, "duty": duties[0]}
    with open_slave(fmu_dir, model_description, "whole", start) as fmu:
        whole = drive(fmu, model_description, duties)
    with open_slave(fmu_dir, model_description, "ragged", start) as fmu:
        ragged = drive(fmu, model_description, duties, steps=(0.37, 0.05, 0.18, 0.25, 0.15))
    assert np.abs(ragged - whole).max() < 1e-9


# ---- Instances, reset and FMU states ------------------------------------------------------------
SHORT = 120  # periods: enough to cross several PRBS bits


def test_two_interleaved_instances_do_not_interfere(fmu_dir, model_description, duties):
    """Two instances of the same loaded binary with different Cl, stepped alternately, must give
    exactly (bit for bit) what each gives alone: no shared mutable state in the FMU."""
    md, d = model_description, duties[:SHORT]
    a_start = {"mode": SWITCHED, "Cl": 0.2e-6, "duty": d[0]}
    b_start = {"mode": SWITCHED, "Cl": 47e-6, "duty": d[0]}
    with open_slave(fmu_dir, md, "alone_a", a_start) as fmu:
        alone_a = drive(fmu, md, d)
    with open_slave(fmu_dir, md, "alone_b", b_start) as fmu:
        alone_b = drive(fmu, md, d)
    with open_slave(fmu_dir, md, "a", a_start) as a, open_slave(fmu_dir, md, "b", b_start) as b:
        rows = [(period(a, md, k, x), period(b, md, k, x)) for k, x in enumerate(d)]
    both_a, both_b = (np.array(r) for r in zip(*rows))
    assert not np.array_equal(alone_a, alone_b), "different Cl must give different trajectories"
    np.testing.assert_array_equal(both_a, alone_a)
    np.testing.assert_array_equal(both_b, alone_b)


def test_reset_reproduces_bit_for_bit_and_restores_start_values(fmu_dir, model_description, duties):
    """fmi2Reset + the same set-up gives the identical run; after fmi2Reset without setting Cl, the
    run equals a fresh instance's default-Cl run (fmi2Reset returns to the start values)."""
    md, d = model_description, duties[:SHORT]
    start = {"mode": SWITCHED, "Cl": 0.2e-6, "duty": d[0]}
    with open_slave(fmu_dir, md, "fresh_default", {"mode": SWITCHED, "duty": d[0]}) as fmu:
        fresh_default = drive(fmu, md, d)
    with open_slave(fmu_dir, md, "reset", start) as fmu:
        first = drive(fmu, md, d)
        fmu.reset()
        set_values(fmu, md, start)
        initialize_slave(fmu)
        again = drive(fmu, md, d)
        fmu.reset()
        set_values(fmu, md, {"mode": SWITCHED, "duty": d[0]})
        initialize_slave(fmu)
        default_after_reset = drive(fmu, md, d)
    np.testing.assert_array_equal(again, first)
    np.testing.assert_array_equal(default_after_reset, fresh_default)
    assert not np.array_equal(first, fresh_default)


def test_get_set_fmu_state_round_trip(fmu_dir, model_description, duties):
    """Run N, save, run N more, restore, run the same N again → identical (bit for bit)."""
    md, n = model_description, SHORT // 2
    with open_slave(fmu_dir, md, "state", {"mode": SWITCHED, "Cl": 0.2e-6, "duty": duties[0]}) as fmu:
        drive(fmu, md, duties[:n])
        saved = fmu.getFMUstate()
        after = drive(fmu, md, duties[n:2 * n], k0=n)
        fmu.setFMUstate(saved)
        replay = drive(fmu, md, duties[n:2 * n], k0=n)
        fmu.freeFMUstate(saved)
    np.testing.assert_array_equal(replay, after)


def test_serialized_fmu_state_continues_in_another_instance(fmu_dir, model_description, duties):
    """Serialize the state after N periods, de-serialize it in the same and in a fresh instance
    (default Cl: everything must come from the bytes), continue N periods → identical."""
    md, n = model_description, SHORT // 2
    with open_slave(fmu_dir, md, "ser", {"mode": SWITCHED, "Cl": 0.2e-6, "duty": duties[0]}) as fmu:
        drive(fmu, md, duties[:n])
        state = fmu.getFMUstate()
        blob = fmu.serializeFMUstate(state)
        fmu.freeFMUstate(state)
        after = drive(fmu, md, duties[n:2 * n], k0=n)
        back = fmu.deSerializeFMUstate(blob)
        fmu.setFMUstate(back)
        fmu.freeFMUstate(back)
        replay_same = drive(fmu, md, duties[n:2 * n], k0=n)
    with open_slave(fmu_dir, md, "deser", {"mode": AVERAGED}) as other:
        state = other.deSerializeFMUstate(blob)
        other.setFMUstate(state)
        other.freeFMUstate(state)
        replay_other = drive(other, md, duties[n:2 * n], k0=n)
    np.testing.assert_array_equal(replay_same, after)
    np.testing.assert_array_equal(replay_other, after)


# ---- Bad input ---------------------------------------------------------------------------------
def _expect_error(name: str, call, *words: str) -> None:
    """`call()` must fail with fmi2Error (fmpy raises) and log a message containing `words`."""
    before = len(messages(name))
    with pytest.raises(FMICallException) as exc:
        call()
    assert exc.value.status == fmi2Error
    new = messages(name)[before:]
    assert any(all(w in m for w in words) for m in new), f"no log message with {words}: {new}"


# case: (set before initialization?, words the logged message must contain, the call)
BAD_INPUT = {
    "duty=1.5": (False, ("duty",), lambda f, md: f.setReal([vr(md, "duty")], [1.5])),
    "duty=NaN": (False, ("duty",), lambda f, md: f.setReal([vr(md, "duty")], [math.nan])),
    "Cl=0 before init": (True, ("Cl",), lambda f, md: f.setReal([vr(md, "Cl")], [0.0])),
    "Cl after init": (False, ("Cl",), lambda f, md: f.setReal([vr(md, "Cl")], [20e-6])),
    "mode=3": (True, ("mode",), lambda f, md: f.setInteger([vr(md, "mode")], [3])),
    "set output vout": (False, ("vout",), lambda f, md: f.setReal([vr(md, "vout")], [1.0])),
    "doStep 0": (False, ("fmi2DoStep", "communicationStepSize"), lambda f, md: f.doStep(0.0, 0.0)),
    "doStep -T": (False, ("fmi2DoStep", "communicationStepSize"), lambda f, md: f.doStep(0.0, -T)),
}


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_is_an_error_naming_the_variable(fmu_dir, model_description, case):
    """Each bad call returns fmi2Error (not fatal, not OK) and logs a message naming the culprit."""
    before_init, words, call = BAD_INPUT[case]
    name = "bad_" + re.sub(r"\W+", "_", case)
    with open_slave(fmu_dir, model_description, name, initialize=not before_init) as fmu:
        _expect_error(name, lambda: call(fmu, model_description), *words)


def test_error_state_refuses_calls_until_reset_or_set_state(fmu_dir, model_description, duties):
    """After an fmi2Error the instance is in the FMI error state: fmi2DoStep is refused; restoring
    a saved FMU state, and separately fmi2Reset, make it usable again with the same results."""
    md, n = model_description, 20
    start = {"mode": SWITCHED, "duty": duties[0]}
    with open_slave(fmu_dir, md, "err", start) as fmu:
        saved = fmu.getFMUstate()
        expected = drive(fmu, md, duties[:n])
        fmu.setFMUstate(saved)
        _expect_error("err", lambda: fmu.setReal([vr(md, "duty")], [-0.1]), "duty")
        _expect_error("err", lambda: fmu.doStep(0.0, T), "fmi2DoStep")
        fmu.setFMUstate(saved)
        fmu.freeFMUstate(saved)
        np.testing.assert_array_equal(drive(fmu, md, duties[:n]), expected)
        _expect_error("err", lambda: fmu.doStep(0.0, -1.0), "communicationStepSize")
        fmu.reset()
        set_values(fmu, md, start)
        initialize_slave(fmu)
        np.testing.assert_array_equal(drive(fmu, md, duties[:n]), expected)


def test_wrong_guid_gives_null_instance_and_a_message(fmu_dir, model_description):
    """fmi2Instantiate with a foreign GUID returns NULL (fmpy raises), logs why, and the process
    (and the binary) stay usable."""
    name = "wrong_guid"
    with pytest.raises(Exception, match="Failed to instantiate"):
        with open_slave(fmu_dir, model_description, name, guid="{00000000-0000-0000-0000-000000000000}"):
            pass
    assert any("GUID" in m for m in messages(name)), messages(name)
    with open_slave(fmu_dir, model_description, "after_wrong_guid") as fmu:
        row = period(fmu, model_description, 0, 0.5)
    assert abs(row[3] - (0.5 * U - RL * 1.0)) < 1e-9  # default start at the DC point: 5.9 V


# ---- The switch node's ring in DCM, set through fmi2SetBoolean ------------------------------
@pytest.mark.parametrize("ring", [True, False], ids=["ring", "held"])
def test_switch_node_ring_is_set_through_fmi(fmu_dir, model_description, ring):
    """A diode buck in DCM (0.2 duty, 0.5 A) with a 1 nF switch node: with `switch_node_ring`
    set by fmpy's `setBoolean`, il rings below zero after the diode blocks, by
    `(vout + Vf)·√(Csw/L)` (within 3 %, sampled every T/400); held (the default), il stays at
    zero until the next turn-on."""
    md, csw, vf = model_description, 1e-9, 0.4
    start = {"mode": SWITCHED, "diode_drop": vf, "switch_node_capacitance": csw,
             "switch_node_ring": ring, "duty": 0.2, "io": 0.5}
    with open_slave(fmu_dir, md, f"ring_{ring}", start) as fmu:
        drive(fmu, md, np.full(3000, 0.2))
        vout = fmu.getReal([vr(md, "vout")])[0]
        il = []
        for j in range(400):
            fmu.doStep(3000 * T + j * T / 400, T / 400)
            il.append(fmu.getReal([vr(md, "il")])[0])
    depth = (vout + vf) * math.sqrt(csw / L)
    if ring:
        assert -min(il) == pytest.approx(depth, rel=0.03), f"lobe depth {-min(il)} A vs {depth} A"
    else:
        assert min(il) == 0.0, f"il {min(il)} A below zero without the ring"
