"""Analytic sanity checks of the ngspice buck circuits: ideal switch, synchronous MOSFET, diode."""

import json
import os
import shutil
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import buck_spice  # noqa: E402

L, FS, U, IO, RL, D = 3.3e-6, 330e3, 12.0, 1.0, 0.1, 0.5
N, TAIL = 300, 50  # the start-up transient has decayed below 1e-7 V by period 160


@pytest.fixture(scope="module")
def settled():
    if shutil.which("ngspice") is None:
        pytest.skip("ngspice not on PATH")
    r = buck_spice.simulate(np.full(N, D), L=L, RL=RL, fs=FS, U=U, io=IO)
    return {k: v[-TAIL:] for k, v in r.items()}


def test_period_averages_match_dc_steady_state(settled):
    assert np.max(np.abs(settled["vout_avg"] - (D * U - RL * IO))) < 1e-3
    assert np.max(np.abs(settled["il_avg"] - IO)) < 1e-3


def test_period_start_current_is_ripple_valley(settled):
    # Trailing-edge PWM: period start = end of off-time = current minimum.
    # The textbook valley neglects the RL drop and output ripple (~6 mA here).
    valley = IO - U * D * (1 - D) / (2 * L * FS)
    assert np.max(np.abs(settled["il_start"] - valley)) < 0.02


# --------------------------------------------------------------------------
# Real circuits: synchronous MOSFET buck and asynchronous (Schottky) buck.
# Constant duty from the approximate DC point (buck_spice.dc_point); the
# output has settled to < 10 uV per period over the last TAIL periods.

REAL_N = 200
T = 1.0 / FS


def _needs_ngspice():
    if shutil.which("ngspice") is None:
        pytest.skip("ngspice not on PATH")


def _tail(r, n=TAIL):
    return {k: v[-n:] for k, v in r.items()}


def _body_diode_vf(i):
    p = buck_spice.mosfet_params()
    return buck_spice.diode_vf(i, dict(Is=p["Is"], N=p["N"], Rs=p["Rb"]))


@pytest.fixture(scope="module")
def sync_runs():
    _needs_ngspice()
    d = np.full(REAL_N, D)
    return {
        # defaults: 30 ns dead time, 5 ns gate ramps, Rds_on = 10 mOhm
        "default": _tail(buck_spice.simulate(d, circuit="sync", io=2.0)),
        "td30": _tail(buck_spice.simulate(d, circuit="sync", io=2.0, gate_rise=1e-9)),
        "td1": _tail(buck_spice.simulate(d, circuit="sync", io=2.0, dead_time=1e-9,
                                         gate_rise=1e-9)),
    }


def test_sync_buck_rds_on_drop(sync_runs):
    # Dead time ~ 0 (1 ns, 1 ns gate ramps): only the conduction drop of the
    # MOSFETs (equal Rds_on high and low side, so it simply adds to RL).
    # The gate ramps cross the threshold within +-0.5 ns of the nominal
    # instants: +-(0.5 ns/T)*U = 2 mV per edge, hence 5 mV.
    r, io, ron = sync_runs["td1"], 2.0, 10e-3
    assert np.max(np.abs(r["il_avg"] - io)) < 1e-3
    assert np.max(np.abs(r["vout_avg"] - (D * U - (RL + ron) * io))) < 5e-3


def test_sync_buck_dead_time_loss(sync_runs):
    # With il > 0 through both dead times the body diode of the low side
    # conducts: the switch node sits at -Vbd instead of U before the high side
    # turns on (loss td*(U + Vbd)) and at -Vbd instead of ~0 before the low
    # side turns on (loss td*Vbd), so
    #     vout = d*U - (RL + Rds_on)*io - (td/T)*(U + Vbd(i_valley) + Vbd(i_peak)),
    # Vbd from the VDMOS body-diode model at the ripple valley and peak
    # (0.72 V, 0.81 V).  The edges shorten the effective dead time by ~1-2 ns
    # each (threshold crossings vs ramp midpoints, a few ns of switch-node slew
    # at turn-off): +-2 edges*2 ns*(U + Vbd)/T = 17 mV, hence 20 mV on the
    # difference; 30 mV on the absolute value (defaults, 5 ns gate ramps).
    io, ron = 2.0, 10e-3
    ripple = (U - D * U) * D * T / L
    vbd = _body_diode_vf(io - ripple / 2) + _body_diode_vf(io + ripple / 2)
    loss = lambda td: td / T * (U + vbd)  # noqa: E731
    v1, v30 = sync_runs["td1"]["vout_avg"].mean(), sync_runs["td30"]["vout_avg"].mean()
    delta = v30 - v1
    assert -0.15 < delta < -0.09, f"dead-time effect {delta * 1e3:.1f} mV"
    assert abs(delta + loss(30e-9 - 1e-9)) < 20e-3
    v_default = sync_runs["default"]["vout_avg"]
    assert np.max(np.abs(v_default - (D * U - (RL + ron) * io - loss(30e-9)))) < 30e-3


def test_async_buck_ccm_diode_drop():
    # CCM (io = 3 A > ripple/2 = 0.69 A): the Schottky conducts for (1-d)*T,
    #     vout = d*U - (1-d)*Vf(io) - RL*io - d*Rds_on*io,
    # Vf(3 A) = 0.454 V from the diode model.  Neglected: Vf's curvature over
    # the ripple (-1 mV), the switching edges (the high side starts conducting
    # ~1 ns before the ramp midpoint and stops ~1 ns after; the node falls
    # over a few ns at turn-off: ~+10 mV), the snubber; hence 30 mV.
    _needs_ngspice()
    io, d, ron = 3.0, 0.5, 10e-3
    r = _tail(buck_spice.simulate(np.full(REAL_N, d), circuit="async", io=io))
    vf = buck_spice.diode_vf(io, buck_spice.diode_params())
    assert 0.43 < vf < 0.48
    expected = d * U - (1 - d) * vf - RL * io - d * ron * io
    assert np.max(np.abs(r["il_avg"] - io)) < 1e-3
    assert np.max(np.abs(r["vout_avg"] - expected)) < 30e-3
    assert np.all(r["il_start"] > 1.0)  # the current never reaches zero


def test_async_buck_dcm_raises_gain_and_current_stops_at_zero():
    # io = 0.1 A < ripple/2: the inductor current falls to zero before the
    # period ends, the diode stops and the switch node rings (damped by the
    # RC snubber) around vout.  The CCM formula d*U - (1-d)*Vf = 3.35 V no
    # longer holds: the DCM volt-second balance (buck_spice.dc_point, lossless
    # but for the diode) gives 9.98 V; snubber, ringing and conduction losses
    # (~2-3 % of the 1 W output) pull the simulation slightly below it.
    _needs_ngspice()
    io, d = 0.1, 0.3
    vf = buck_spice.diode_vf(io, buck_spice.diode_params())
    v_ccm = d * U - (1 - d) * vf - RL * io
    v_dcm = buck_spice.dc_point("async", d, io=io)[2]
    # From the DCM estimate: it holds (a CCM circuit would fall to v_ccm
    # within ~150 periods), and the period starts with il = 0.
    r = _tail(buck_spice.simulate(np.full(300, d), circuit="async", io=io))
    assert np.all(r["vout_avg"] > v_ccm + 3.0)
    assert np.all((r["vout_avg"] > v_dcm - 0.25) & (r["vout_avg"] < v_dcm + 0.02))
    assert np.max(np.abs(r["il_start"])) < 5e-3
    # From the CCM operating point: the output climbs away from it (the slow
    # DCM pole, ~600 periods at this load).
    r = buck_spice.simulate(np.full(300, d), circuit="async", io=io, x0=(io, v_ccm, v_ccm))
    v = r["vout_avg"]
    assert v[100] > v[0] + 1.0 and v[-1] > v[100] + 1.0 and v[-1] > v_ccm + 3.0


def test_long_prbs_run_survives_run_boundaries():
    # Regression: without buck_spice._separate_breakpoints this aborted with
    # "timestep too small" at period 880 (a train's phantom breakpoint
    # coinciding with the next run's first corner, t > 0.5 ms).
    _needs_ngspice()
    r = buck_spice.simulate(buck_spice.prbs_duty(700, seed=1), circuit="async", io=1.0,
                            warmup=200)
    assert len(r["vout_avg"]) == 700 and np.all(np.isfinite(r["vout_avg"]))


def test_gate_breakpoints_are_separated():
    duty = np.r_[buck_spice.prbs_duty(400, seed=3), np.full(5, 1.0), np.full(5, 0.0),
                 buck_spice.prbs_duty(20, bit_periods=1, low=0.1, high=0.9)]
    for circuit, td in (("sync", 30e-9), ("sync", 0.0), ("async", 30e-9)):
        gates = buck_spice._pwm_gate_intervals(duty, T, circuit, td)
        chains = {g: buck_spice._gate_chains(iv, 5e-9, T) for g, iv in gates.items()}
        buck_spice._separate_breakpoints(list(chains.values()), 5e-9)
        corners = np.sort(np.concatenate([buck_spice._chain_corners(c, 5e-9)
                                          for cl in chains.values() for c in cl]))
        assert np.min(np.diff(corners)) >= buck_spice.BREAK_MARGIN * (1 - 1e-6)


def test_warmup_drops_leading_periods():
    _needs_ngspice()
    duty = buck_spice.prbs_duty(60, seed=9)
    full = buck_spice.simulate(np.r_[np.full(20, duty[0]), duty])
    part = buck_spice.simulate(duty, warmup=20)
    np.testing.assert_array_equal(part["time"], np.arange(60) * T)
    for k in ("vout_avg", "il_avg"):
        np.testing.assert_array_equal(part[k], full[k][20:])
    for k in ("vout_start", "il_start", "vc_start"):
        np.testing.assert_array_equal(part[k], full[k][20:])


def test_cli_real_circuit_metadata_and_truth(tmp_path):
    _needs_ngspice()
    out, truth = tmp_path / "sync.csv", tmp_path / "sync.json"
    buck_spice.main(["--circuit", "sync", "--periods", "30", "--warmup", "10",
                     "--out", str(out), "--truth", str(truth)])
    lines = out.read_text().splitlines()
    meta = dict(line[1:].split("=", 1) for line in lines if line.startswith("#"))
    meta = {k.strip(): v.strip() for k, v in meta.items()}
    assert meta["circuit"] == "sync" and meta["source"].startswith("ngspice")
    for k in ("fs", "L", "RL", "C", "Rc", "U", "io"):
        float(meta[k])
    # The data must not name the effect; the sidecar does.
    head = "\n".join(line for line in lines if line.startswith("#")).lower()
    assert "dead" not in head and "rds" not in head
    assert len(lines) == len(meta) + 1 + 30
    t = json.loads(truth.read_text())
    assert t["circuit"] == "sync" and t["effects"]["dead_time"]["t_dead"] == 30e-9
    assert t["effects"]["switch_resistance"]["rds_on_high"] == 10e-3


# --------------------------------------------------------------------------
# inductor_saturation and cap_dc_bias: behavioural L(il) and Cl(v) in any circuit (the FMU
# against them: tests/python/test_ngspice.py).


def test_nonlinear_effects_off_leave_the_linear_elements():
    # Off, the netlists are what they were before the options existed (the fixtures and every
    # earlier data set stay valid).
    assert buck_spice._inductor(3.3e-6, 1.0, 0.0, 1.3) == "L1    sw  nl   3.3e-06  IC=1.0"
    net = buck_spice._output_network(100e-6, 0.1, 4.7e-6, 0.0, 0.0, 4.7, 4.8)
    assert net.splitlines() == ["Rc1   out vc   0.1", "C1    vc  0    0.0001  IC=4.7",
                                "Cl1   out 0    4.7e-06 IC=4.8"]
    assert "Cl1   ncl 0    4.7e-06 IC=4.8" in buck_spice._output_network(
        100e-6, 0.1, 4.7e-6, 0.02, 0.0, 4.7, 4.8, cap_dc_bias=0.0)


def _rk4_cap_dc_bias(duty, cl, io, b, vr, nsub=100):
    """The ideal buck with a continuous Cl(v) = cl*(1 - b*min((v/vr)^2, 1)) by RK4 (nsub steps
    per on- and off-interval): period-start vout and il, from the averaged DC point."""
    C, Rc = 100e-6, 0.1
    v0 = duty[0] * U - RL * io
    x = np.array([io, v0, v0])
    starts = []

    def f(x, usw):
        il, vc, vo = x
        ic = (vo - vc) / Rc
        return np.array([(usw - RL * il - vo) / L, ic / C,
                         (il - io - ic) / (cl * (1 - b * min((vo / vr) ** 2, 1.0)))])

    for d in duty:
        starts.append((x[2], x[0]))
        for usw, tau in ((U, d * T), (0.0, (1 - d) * T)):
            h = tau / nsub
            for _ in range(nsub):
                k1 = f(x, usw)
                k2 = f(x + h / 2 * k1, usw)
                k3 = f(x + h / 2 * k2, usw)
                k4 = f(x + h * k3, usw)
                x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return np.array(starts)


def test_cap_dc_bias_is_an_incremental_capacitance():
    # i = Cl(v)*dv/dt with v across Cl itself, continuous in v: the netlist against an RK4
    # integration of the same equations. Duty steps 0.6 -> 0.4 -> ... every 20 periods swing
    # vout between ~7.1 V and ~4.7 V, around the rated voltage of 6.3 V: both branches of min()
    # are visited. ngspice and RK4 (converged to 0.1 uV) agree to 7 uV and 9 uA, ngspice's own
    # accuracy at T/100 (buck_spice.SOLVER_OPTIONS); the effect itself is 74 mV.
    _needs_ngspice()
    duty = np.tile(np.repeat([0.6, 0.4], 20), 3)
    cl, io, b, vr = 4.7e-6, 1.0, 0.5, 6.3
    r = buck_spice.simulate(duty, Cl=cl, io=io, cap_dc_bias=b, cap_rated_voltage=vr)
    ref = _rk4_cap_dc_bias(duty, cl, io, b, vr)
    assert r["vout_start"].max() > vr > r["vout_start"].min()
    assert np.max(np.abs(r["vout_start"] - ref[:, 0])) < 50e-6
    assert np.max(np.abs(r["il_start"] - ref[:, 1])) < 50e-6
    plain = buck_spice.simulate(duty, Cl=cl, io=io)
    assert np.max(np.abs(r["vout_start"] - plain["vout_start"])) > 20e-3


def test_cli_passes_the_nonlinear_effects(tmp_path):
    # The blind bench asks for these data sets through the command line.
    _needs_ngspice()
    out = tmp_path / "data.csv"
    buck_spice.main(["--periods", "30", "--io", "1", "--cl", "4.7e-6", "--inductor-saturation", "0.3",
                     "--isat", "1.3", "--cap-dc-bias", "0.5", "--cap-rated-voltage", "10",
                     "--out", str(out)])
    lines = [line for line in out.read_text().splitlines() if not line.startswith("#")]
    cols = dict(zip(lines[0].split(","), np.array([[float(x) for x in line.split(",")]
                                                   for line in lines[1:]]).T))
    duty = buck_spice.prbs_duty(30, seed=1)
    r = buck_spice.simulate(duty, Cl=4.7e-6, io=1.0, inductor_saturation=0.3, isat=1.3,
                            cap_dc_bias=0.5, cap_rated_voltage=10.0)
    np.testing.assert_array_equal(cols["vout"], r["vout_start"])
    np.testing.assert_array_equal(cols["il"], r["il_start"])
    plain = buck_spice.simulate(duty, Cl=4.7e-6, io=1.0)
    assert np.max(np.abs(cols["vout"] - plain["vout_start"])) > 10e-3


# --------------------------------------------------------------------------
# The small data sets of the tests (scripts/spice/spice_fixtures.py): a live run of the
# generator when ngspice is on PATH, else the committed files under tests/fixtures/spice/, so
# these checks run on every machine. 500 PRBS periods (0.4/0.6), Cl = 4.7 uF; sync and async
# at io = 2 A. The PRBS swings il through zero (down to about -6 A): the effects show with
# both signs of the current.
#
# Per period k the inductor equation integrates exactly to the switch node's volt-second
# loss against the ideal PWM waveform,
#     loss_k = d_k*U - RL*il_avg_k - vout_avg_k - L*(il_{k+1} - il_k)/T,
# which the CSV gives (period-start il and exact period averages); it is what a dead time,
# a diode drop or Rds_on take from the switch node.

import spice_fixtures  # noqa: E402

RDS_ON = 10e-3  # the generator's default, also in the truth sidecar


def _fixture(circuit):
    return spice_fixtures.load(circuit)


def _loss(f):
    c = f.columns
    U, L, RL, T = f.num("U"), f.num("L"), f.num("RL"), 1.0 / f.num("fs")
    return (c["duty"][:-1] * U - RL * c["il_avg"][:-1] - c["vout_avg"][:-1]
            - L * np.diff(c["il"]) / T)


@pytest.mark.parametrize("circuit", list(spice_fixtures.FIXTURES))
def test_fixture_follows_the_data_contract(circuit):
    f = _fixture(circuit)
    assert f.header[:5] == ["time", "duty", "vin", "io", "vout"] and "il" in f.header
    for k in ("fs", "L", "RL", "C", "Rc", "U", "io"):
        assert np.isfinite(f.num(k)) and f.num(k) >= 0, k
    assert f.meta["circuit"] == circuit and f.meta["source"].startswith("ngspice")
    n = len(f.columns["time"])
    assert n == 500
    np.testing.assert_allclose(f.columns["time"], np.arange(n) / f.num("fs"), rtol=0, atol=1e-15)
    assert all(np.all(np.isfinite(v)) for v in f.columns.values())
    assert set(np.unique(f.columns["duty"])) == {0.4, 0.6}
    # The data carries no effect parameters (as in test_cli_real_circuit_metadata_and_truth);
    # the sidecar does, with the circuit values simulated.
    head = "\n".join(line for line in f.csv_text.splitlines() if line.startswith("#")).lower()
    for word in ("dead", "rds", "vf"):
        assert word not in head, word
    assert f.truth["circuit"] == circuit
    assert f.truth["params"]["Cl"] == f.num("Cl") == 4.7e-6
    expected = {"ideal": set(), "sync": {"switch_resistance", "dead_time"},
                "async": {"switch_resistance", "diode_drop", "dcm"}}[circuit]
    assert set(f.truth["effects"]) == expected


def test_ideal_fixture_loses_no_volt_seconds():
    # The ideal switch node's edges are exact in volt-seconds; the ngspice error (a few uV in
    # vout_avg, ~10 uA in il) bounds the loss far below 0.1 mV.
    loss = _loss(_fixture("ideal"))
    assert np.max(np.abs(loss)) < 1e-4


def test_sync_fixture_dead_time_loss_follows_the_sign_of_il():
    # Dead time before each turn-on, body diodes conducting: with il > 0 at both edges the
    # node sits at -Vbd (loss td*(U + Vbd) before the high side turns on, td*Vbd before the
    # low side); with il < 0 the high side's body diode holds it at U + Vbd (gains of td*Vbd
    # and td*(U + Vbd)). il at the edges: the period-start sample and, at the high side's
    # turn-off, that plus the on-time rise (U - vout)*d*T/L.
    # Rds_on (equal high and low side) adds RDS_ON*il_avg. Tolerance 30 mV as in
    # test_sync_buck_dead_time_loss (threshold crossings vs ramp midpoints, node slew).
    f = _fixture("sync")
    c, T, U, L = f.columns, 1.0 / f.num("fs"), f.num("U"), f.num("L")
    td = f.truth["effects"]["dead_time"]["t_dead"]
    d, il, va = c["duty"][:-1], c["il"], c["vout_avg"][:-1]
    valley, after = il[:-1], il[1:]
    peak = valley + (U - va) * d * T / L
    edge = lambda i: _body_diode_vf(abs(i))  # noqa: E731
    predicted = np.array([td / T * ((U + edge(a)) if a > 0 else -edge(a))
                          + td / T * (edge(b) if b > 0 else -(U + edge(b)))
                          for a, b in zip(valley, peak)])
    r = _loss(f) - RDS_ON * c["il_avg"][:-1]
    pos = (valley > 0.5) & (after > 0.5)
    neg = (peak < -0.5) & (after < -0.5)
    assert pos.sum() > 100 and neg.sum() > 10, (pos.sum(), neg.sum())
    assert np.max(np.abs((r - predicted)[pos | neg])) < 30e-3
    # The signature itself: ~ +td/T*(U + 2 Vbd) = +0.13 V with il > 0, the opposite with il < 0.
    assert 0.09 < r[pos].mean() < 0.16 and -0.16 < r[neg].mean() < -0.09


def test_async_fixture_diode_drop_and_dcm():
    # CCM periods (il > 0 throughout): the Schottky carries il for (1-d)*T,
    #     loss = (1-d)*Vf(il) + d*Rds_on*il  (30 mV, as in test_async_buck_ccm_diode_drop).
    # The diode blocks reverse current: where the synchronous buck swings il to -6 A, the
    # asynchronous one stops at zero (DCM) and rings (the snubber damps it; |il| < 0.1 A).
    f = _fixture("async")
    c = f.columns
    il, ia, d = c["il"], c["il_avg"][:-1], c["duty"][:-1]
    vf = np.array([buck_spice.diode_vf(max(i, 1e-3), buck_spice.diode_params()) for i in ia])
    predicted = (1 - d) * vf + d * RDS_ON * ia
    ccm = (il[:-1] > 0.3) & (il[1:] > 0.3)
    dcm = np.abs(il[1:]) < 0.1
    assert ccm.sum() > 100 and dcm.sum() > 100, (ccm.sum(), dcm.sum())
    assert np.max(np.abs((_loss(f) - predicted)[ccm])) < 30e-3
    assert il.min() > -0.1 and _fixture("sync").columns["il"].min() < -1.0


@pytest.mark.parametrize("circuit", list(spice_fixtures.FIXTURES))
def test_fixtures_are_current(circuit):
    # The committed fixture is what the generator makes now (else regenerate them with
    # `.venv/bin/python scripts/spice/spice_fixtures.py`). Another ngspice build may round
    # differently: 1 uV/uA on the linear ideal circuit, the solver's stated accuracy on the
    # nonlinear ones (0.25 mV, 0.6 mA; see REAL_SOLVER_OPTIONS).
    _needs_ngspice()
    live, committed = spice_fixtures.live(circuit), spice_fixtures.committed(circuit)
    assert live.header == committed.header
    assert {k: v for k, v in live.meta.items() if k != "source"} == \
        {k: v for k, v in committed.meta.items() if k != "source"}
    assert live.truth == committed.truth
    tol = 1e-6 if circuit == "ideal" else 1e-3
    for name in live.header:
        err = np.max(np.abs(live.columns[name] - committed.columns[name]))
        assert err < tol, f"{circuit} {name} differs by {err:.3e}: regenerate the fixtures"
