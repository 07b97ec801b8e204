"""A bench capture read through imperfect probes, from the independent ngspice harness
(scripts/spice/harness): a synchronous buck sampled 92 ns late, its current probe 2 % high with
a 40 mA zero error, its voltage probe 10 mV high. `buckid diagnose`, told nothing, finds the
late reading at the instant the same capture without the probes shows, with the current
probe's errors beside it (a nuisance, reported), names the voltage probe's offset with an
interval that holds it, and keeps Cl inside its final CI95.

Before the probes' calibration was modelled, the same capture through the 10 mV offset alone
had the late reading "close -1117 % of the gap" and Cl's interval spanning 3.2-6.7 uF.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from captures import generate

REPO = Path(__file__).resolve().parents[2]
HARNESS = REPO / "scripts" / "spice" / "harness" / "harness.py"

needs_ngspice = pytest.mark.skipif(shutil.which("ngspice") is None, reason="ngspice is not installed")

CL = 4.7e-6
VOUT_OFFSET = 0.010
IL_GAIN, IL_OFFSET = 0.02, 0.040


def _diagnosis(buckid_bin, data):
    """`buckid diagnose --nominal switched`'s JSON for the data file `data`."""
    out = data.with_suffix(".json")
    proc = subprocess.run([str(buckid_bin), "diagnose", "--data", str(data), "--nominal", "switched", "--json", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads(out.read_text())


def _diagnose(buckid_bin, tmp_path, name, *options):
    """`buckid diagnose`'s JSON for a harness capture with further harness `options` (its probes'
    errors; an `--adc-delay` or `--dead-time` of their own, which override the defaults here)."""
    data = tmp_path / f"{name}.csv"
    generate(HARNESS, ["--topology", "sync", "--cl", str(CL), "--io", "3", "--periods", "2000", "--adc-delay", "92e-9",
                       "--noise-vout", "2e-3", "--noise-il", "20e-3", *options], {"--out": data})
    return _diagnosis(buckid_bin, data)


def test_probe_errors_on_a_harness_capture_are_found_and_cl_holds(buckid_bin, tmp_path):
    plain = _diagnose(buckid_bin, tmp_path, "plain")
    dx = _diagnose(buckid_bin, tmp_path, "probed", "--vout-offset", str(VOUT_OFFSET), "--il-gain", str(IL_GAIN),
                   "--il-offset", str(IL_OFFSET))
    selected = {e["name"]: e for e in dx["selected"]}
    assert "sample_delay" in selected and "sensor_offset" in selected, (list(selected), dx["selection_ended"])
    # The instant the plain capture shows (the harness's ADC behind its gate ramps), unmoved.
    instant = next(e for e in plain["selected"] if e["name"] == "sample_delay")["ci95"]["sample_delay"]
    late = selected["sample_delay"]
    assert instant[0] <= late["params"]["sample_delay"] <= instant[1], (late, instant)
    assert abs(late["params"]["il_gain_error"] - IL_GAIN) < 0.005, late
    assert abs(late["params"]["il_offset"] - IL_OFFSET) < 0.02, late
    lo, hi = selected["sensor_offset"]["ci95"]["vout_offset"]
    assert lo <= VOUT_OFFSET <= hi, selected["sensor_offset"]
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= CL <= final["ci95"][1], final


def test_a_reading_in_the_off_time_of_a_harness_capture_is_found_and_cl_holds(buckid_bin, tmp_path):
    """The harness's ADC at 0.9 of the period, in the off-time at either duty, as a controller
    that samples clear of the edges reads. `sample_delay` alone explains it, within 1 % of the
    instant (the harness's instant is its ADC's, behind nothing here: no dead time), and Cl holds.
    With the instant capped at half the period it was taken for the readings a period late
    with a gain error and three drifts, Cl 6.21 [6.09, 6.31] uF against 4.7 uF."""
    period = 1 / 330e3
    dx = _diagnose(buckid_bin, tmp_path, "late", "--adc-delay", str(0.9 * period))
    names = [e["name"] for e in dx["selected"]]
    assert names == ["sample_delay"], (names, dx["selection_ended"])
    instant = dx["selected"][0]["params"]["sample_delay"]
    assert abs(instant / (0.9 * period) - 1) < 0.01, instant
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= CL <= final["ci95"][1], final


@pytest.mark.parametrize("fraction", [0.65, 0.85])
def test_a_reading_in_the_off_time_behind_a_dead_time_is_found_and_cl_holds(buckid_bin, tmp_path, fraction):
    """The harness's sync buck with 30 ns of dead time, its ADC at 0.65 or 0.85 of the period.
    The first step takes the readings for a period late (the dead time missing, the instant
    within the period fits worse); the path from the instant (`select::rival`) finds it with the
    dead time and ends at the floor. Before: C and Rc drifts with Cl 20.6 uF not identified
    (0.65), a gain error and L -1.3 % with Cl 7.5 [6.1, 8.3] uF (0.85), against 4.7 uF."""
    period = 1 / 330e3
    dx = _diagnose(buckid_bin, tmp_path, "late", "--adc-delay", str(fraction * period), "--dead-time", "30e-9")
    selected = {e["name"]: e for e in dx["selected"]}
    assert "sample_delay" in selected and "dead_time" in selected, (list(selected), dx["selection_ended"])
    assert abs(selected["sample_delay"]["params"]["sample_delay"] / (fraction * period) - 1) < 0.01, selected["sample_delay"]
    lo, hi = selected["dead_time"]["ci95"]["dead_time"]
    assert 25e-9 < lo < hi < 35e-9, selected["dead_time"]
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= CL <= final["ci95"][1], final


def test_a_reading_locked_to_the_pwm_of_a_harness_capture_is_found_and_cl_holds(buckid_bin, tmp_path):
    """The harness's sync buck with its ADC triggered in the middle of each on-time (`--adc-delay
    0 --adc-share 0.5`, the instant D*T/2): the lock is found (`sample_duty_share` 1/2, the
    instant at half duty within 2 % of T/4), nothing else is named, and Cl holds. With a fixed
    instant only it was a 66 mV `sensor_offset`, Cl not identified."""
    dx = _diagnose(buckid_bin, tmp_path, "mid_on", "--adc-delay", "0", "--adc-share", "0.5")
    assert [e["name"] for e in dx["selected"]] == ["sample_delay"], dx["selection_ended"]
    late = dx["selected"][0]["params"]
    assert late.get("sample_duty_share") == 0.5, late
    assert abs(late["sample_delay"] * 330e3 / 0.25 - 1) < 0.02, late
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= CL <= final["ci95"][1], final


THIRD = REPO / "scripts" / "spice" / "third" / "third.py"


def test_a_reading_through_an_anti_alias_filter_is_found_and_cl_holds(buckid_bin, tmp_path):
    """The third generator's thesis stage (seed 501, Cl 51.9 uF), its vout read through an RC
    anti-alias filter with the corner at half the switching frequency (tau = T/pi, 0.96 us):
    `sensor_filter` alone explains it, its tau within 3 %, and Cl holds. Without the effect the
    same stage read through tau = 0.3 T was diagnosed as C -13 %, Rc +38 % and a 4 mV sensor
    offset, Cl 72 [69, 74] uF."""
    period = 1 / 330e3
    data = tmp_path / "filtered.csv"
    generate(THIRD, ["--family", "thesis", "--case", "clean", "--seed", "501", "--aa-tau", str(1 / 3.141592653589793),
                     "--periods", "2000"],
             {"--out": data, "--truth": tmp_path / "truth.json"})
    truth = json.loads((tmp_path / "truth.json").read_text())
    dx = _diagnosis(buckid_bin, data)
    names = [e["name"] for e in dx["selected"]]
    assert names == ["sensor_filter"], (names, dx["selection_ended"])
    tau = dx["selected"][0]["params"]["vout_filter"]
    assert abs(tau / (period / 3.141592653589793) - 1) < 0.03, tau
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= truth["cl_true"] <= final["ci95"][1], (final, truth["cl_true"])



def test_a_late_reading_through_an_anti_alias_filter_is_found_with_its_instant(buckid_bin, tmp_path):
    """The third generator's thesis stage with C's ESR 5.4 % high (seed 604, Cl 2.21 uF), its ADC
    sampling 288 ns after the switch node rises, behind an RC filter of 0.2 T (606 ns): vout lags
    more than il. The drift is named first, then the filter with the instant il pins, each value
    within 3 %, and Cl holds. Before the filter could be read late, the two lags were taken for
    an inductor's saturation, Cl 5.6 [4.9, 7.5] uF."""
    data = tmp_path / "late_filtered.csv"
    generate(THIRD, ["--family", "thesis", "--case", "single", "--seed", "604", "--aa-tau", "0.2", "--periods", "2000"],
             {"--out": data, "--truth": tmp_path / "truth.json"})
    truth = json.loads((tmp_path / "truth.json").read_text())
    dx = _diagnosis(buckid_bin, data)
    names = [e["name"] for e in dx["selected"]]
    assert names == ["param_drift", "sensor_filter"], (names, dx["selection_ended"])
    drift, late = (e["params"] for e in dx["selected"])
    instant = truth["acq"]["adc_delay"] - truth["switch_node_rise_offset"]
    for fitted, true in [(drift["Rc"], truth["circuit"]["Rc"]), (late["vout_filter"], truth["acq"]["aa_tau"]),
                         (late["sample_delay"], instant)]:
        assert abs(fitted / true - 1) < 0.03, (drift, late, truth["circuit"]["Rc"], truth["acq"], instant)
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= truth["cl_true"] <= final["ci95"][1], (final, truth["cl_true"])


def test_a_filter_read_late_replaces_the_offset_that_stood_in_for_it(buckid_bin, tmp_path):
    """The third generator's clean point-of-load board (seed 702, 665 kHz, Cl 4.22 uF), its ADC
    at a quarter of the period (357 ns after the switch node rises) behind an RC filter of 0.2 T
    (301 ns). The first step takes a probe's offset for the lags; the filter read late, found in
    il, displaces it and is swapped in: it alone is named, tau and the instant within 3 %, and Cl
    holds. Before the swap, the offset stayed, with L -20 %, C -4 % and il's gain -20 % beside
    the late reading, Cl not identified."""
    data = tmp_path / "late_pol.csv"
    generate(THIRD, ["--family", "pol", "--case", "clean", "--seed", "702", "--aa-tau", "0.2", "--adc-delay", "0.25",
                     "--periods", "2000"],
             {"--out": data, "--truth": tmp_path / "truth.json"})
    truth = json.loads((tmp_path / "truth.json").read_text())
    dx = _diagnosis(buckid_bin, data)
    names = [e["name"] for e in dx["selected"]]
    assert names == ["sensor_filter"], (names, dx["selection_ended"])
    assert "replaced sensor_offset" in dx["selection_ended"], dx["selection_ended"]
    late = dx["selected"][0]["params"]
    instant = truth["acq"]["adc_delay"] - truth["switch_node_rise_offset"]
    for fitted, true in [(late["vout_filter"], truth["acq"]["aa_tau"]), (late["sample_delay"], instant)]:
        assert abs(fitted / true - 1) < 0.03, (late, truth["acq"], instant)
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= truth["cl_true"] <= final["ci95"][1], (final, truth["cl_true"])

@pytest.fixture(scope="session")
def own_capture(tmp_path_factory):
    """Our own ngspice sync buck (10 mOhm MOSFETs, 30 ns dead time, Cl 10 uF, 2 A), 3001 PRBS
    periods and its scope capture: `(metadata lines, period rows, capture [time, vout, il])`."""
    import numpy as np
    spice = REPO / "scripts" / "spice" / "buck_spice.py"
    # Live, not recorded (captures.py): the scope capture is 17 MB even compressed. Simulated
    # once per session: pytest-xdist's workers share their session's base directory and take
    # turns under a lock (`--dist loadgroup` would not group them under pytest 9.2,
    # pytest-xdist#1386).
    shared = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = shared.parent
    work = shared / "own_capture"
    work.mkdir(exist_ok=True)
    base, capture = work / "base.csv", work / "capture.csv"
    with open(work / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (work / "done").exists():
            subprocess.run([sys.executable, str(spice), "--circuit", "sync", "--periods", "3001", "--warmup", "100",
                            "--cl", "10e-6", "--io", "2.0", "--dead-time", "30e-9", "--out", str(base),
                            "--capture", str(capture), "--capture-noise", "0", "0"],
                           check=True, capture_output=True, timeout=600)
            (work / "done").touch()
    lines = base.read_text().splitlines()
    meta = [line for line in lines if line.startswith("#") and not line.startswith("# Cl")]
    rows = np.loadtxt([line for line in lines if not line.startswith("#")][1:], delimiter=",")
    return meta, rows, np.loadtxt(capture, delimiter=",", comments="#", skiprows=4)


def _low_pass(t, x, tau):
    """`x` sampled at the uniform times `t` through `tau*y' = x - y`, exactly for a line between
    samples, from rest at `x[0]`."""
    import numpy as np
    from scipy.signal import lfilter, lfilter_zi
    a = np.exp(-(t[1] - t[0]) / tau)
    c = tau * (1 - a) / (t[1] - t[0])
    b = [1 - c, c - a]
    return lfilter(b, [1, -a], x, zi=lfilter_zi(b, [1, -a]) * x[0])[0]


def _read_at(own_capture, buckid_bin, tmp_path, instant, taus=(0.0, 0.0), il_instant=None):
    """`buckid diagnose`'s JSON for the capture read `instant(duty)` periods after each period
    start (2 mV and 10 mA of noise), il at `il_instant(duty)` if given, each channel through a
    first-order low-pass of its time constant in `taus` (vout, il; 0: none)."""
    import numpy as np
    meta, rows, cap = own_capture
    at = rows[:, 0] + instant(rows[:, 1]) / 330e3
    il_at = rows[:, 0] + (il_instant or instant)(rows[:, 1]) / 330e3
    keep = np.maximum(at, il_at) < cap[-1, 0]
    rng = np.random.default_rng(7)
    vout, il = (_low_pass(cap[:, 0], cap[:, c], tau) if tau > 0 else cap[:, c] for c, tau in zip((1, 2), taus))
    vout = np.interp(at, cap[:, 0], vout) + rng.normal(0, 2e-3, len(at))
    il = np.interp(il_at, cap[:, 0], il) + rng.normal(0, 10e-3, len(at))
    body = [f"{t!r},{d!r},{u!r},{i!r},{v:.7g},{c:.6g}" for (t, d, u, i, *_), v, c, k in zip(rows.tolist(), vout, il, keep) if k]
    data = tmp_path / "late.csv"
    data.write_text("\n".join(meta + ["time,duty,vin,io,vout,il"] + body) + "\n")
    return _diagnosis(buckid_bin, data)


@needs_ngspice
def test_a_stuck_path_is_left_for_the_next_first_step(own_capture, buckid_bin, tmp_path):
    """Our own ngspice sync buck read at 0.75 of the period, off its scope capture. The best
    first step is C +21 %, and the path from it stops 27 noise floors above the noise with Rc
    +23 % (Cl not identified); the path from the dead time (`select::STUCK_FLOORS`) finds the
    instant, the switches and the node's charge, and Cl holds."""
    dx = _read_at(own_capture, buckid_bin, tmp_path, lambda duty: 0.75)
    selected = {e["name"]: e for e in dx["selected"]}
    assert {"dead_time", "sample_delay", "switch_resistance"} <= set(selected), (list(selected), dx["selection_ended"])
    assert "param_drift" not in selected, (list(selected), dx["selection_ended"])
    assert abs(selected["sample_delay"]["params"]["sample_delay"] * 330e3 / 0.75 - 1) < 0.01, selected["sample_delay"]
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= 10e-6 <= final["ci95"][1], final


@needs_ngspice
@pytest.mark.parametrize("at_half_duty", [0.25, 0.75], ids=["mid-on", "mid-off"])
def test_a_reading_locked_to_the_pwm_is_found_and_cl_holds(own_capture, buckid_bin, tmp_path, at_half_duty):
    """The same capture read in the middle of the on-time (D/2 of the period) or of the
    off-time ((1 + D)/2), as a controller triggering its ADC from the PWM does: the instant moves
    with the duty. The lock is found (`sample_duty_share` 1/2, the instant at half duty within
    1 %) beside the dead time, and Cl holds. With a fixed instant only, Cl was 5.9 [3.8, 14] uF
    (mid-on) and 18 [12, 36] uF (mid-off), both widened for a model that still missed."""
    dx = _read_at(own_capture, buckid_bin, tmp_path, lambda duty: at_half_duty + (duty - 0.5) / 2)
    selected = {e["name"]: e for e in dx["selected"]}
    assert {"dead_time", "sample_delay"} <= set(selected), (list(selected), dx["selection_ended"])
    late = selected["sample_delay"]["params"]
    assert late.get("sample_duty_share") == 0.5, late
    assert abs(late["sample_delay"] * 330e3 / at_half_duty - 1) < 0.01, late
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= 10e-6 <= final["ci95"][1], final


def test_a_gate_drive_that_stretches_each_pulse_is_named_and_cl_holds(buckid_bin, tmp_path):
    """The harness's sync buck (level-1 MOSFETs behind their drivers, body diodes, 200 pF on the
    node) with the high side's gate held on 25 ns past d*T, a drive whose turn-off is slower
    than its turn-on, read at the period start: `pulse_width_distortion` is named near 25 ns,
    the reading's offset (the same level, U*25 ns/T = 99 mV) said alike, and Cl holds: 25.30
    ns, Cl 4.725 [4.637, 4.773] uF. Before the candidate it was a 100.1 mV `sensor_offset` with
    Cl 4.814 [4.756, 4.862] uF, the truth outside. (Read 100 ns late, the offset still comes
    first: without the instant in the model it fits the level better.)"""
    dx = _diagnose(buckid_bin, tmp_path, "stretched", "--adc-delay", "0", "--pulse-stretch", "25e-9", "--seed", "3")
    names = [e["name"] for e in dx["selected"]]
    assert names == ["pulse_width_distortion"], (names, dx["selection_ended"])
    stretch = dx["selected"][0]["params"]["pulse_width_distortion"]
    assert 22e-9 < stretch < 28e-9, stretch
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= CL <= final["ci95"][1], final


@needs_ngspice
def test_filters_on_both_channels_are_found_and_cl_holds(own_capture, buckid_bin, tmp_path):
    """The same capture read 40 ns after each period start through a first-order low-pass on
    each channel, as a controller with an anti-alias RC at each ADC input reads (tau = T/pi, the
    corner at half the switching frequency; il's integrated exactly on the capture's 97 MS/s).
    The filter on both channels is found, each time constant within 5 %, and Cl holds: 963.5 and
    964.4 ns for 964.6, beside the dead time, the switches, the node's charge and the instant
    (41 ns for 40), Cl 10.0 [9.70, 10.4] uF. With the filter on vout alone in the model, the
    lags were taken for Rc +15 %, C -7 % and a gain error of the reading beside the dead time
    and the switches: Cl 22.2 [20.0, 27.0] uF for 10."""
    tau = 1 / (math.pi * 330e3)
    dx = _read_at(own_capture, buckid_bin, tmp_path, lambda duty: 40e-9 * 330e3, taus=(tau, tau))
    selected = {e["name"]: e for e in dx["selected"]}
    assert "sensor_filter" in selected, (list(selected), dx["selection_ended"])
    for name in ("vout_filter", "il_filter"):
        assert abs(selected["sensor_filter"]["params"][name] / tau - 1) < 0.05, selected["sensor_filter"]["params"]
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= 10e-6 <= final["ci95"][1], final


@needs_ngspice
def test_a_filter_on_il_alone_is_found_from_il_and_cl_holds(own_capture, buckid_bin, tmp_path):
    """The same capture read 40 ns after each period start, vout directly and il through a
    first-order low-pass (tau = T/pi: a current-sense amplifier's bandwidth). The filter has no
    evidence in vout; il shows it, and it is found on il alone, its time constant within 5 %,
    with no filter on vout, and Cl holds. Before, a load ESR stood in for il's lag."""
    tau = 1 / (math.pi * 330e3)
    dx = _read_at(own_capture, buckid_bin, tmp_path, lambda duty: 40e-9 * 330e3, taus=(0.0, tau))
    filters = [e for e in dx["selected"] if e["name"] == "sensor_filter"]
    assert [sorted(e["params"]) for e in filters] == [["il_filter"]], ([e["name"] for e in dx["selected"]], dx["selection_ended"])
    assert abs(filters[0]["params"]["il_filter"] / tau - 1) < 0.05, filters[0]["params"]
    assert "load_esr" not in [e["name"] for e in dx["selected"]], dx["selection_ended"]
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= 10e-6 <= final["ci95"][1], final


@needs_ngspice
def test_channels_read_at_their_own_instants_are_found_and_cl_holds(own_capture, buckid_bin, tmp_path):
    """The same capture with il read 40 ns after each period start and vout 600 ns, as a
    multiplexed ADC converts one channel after the other. `channel_skew` is found, il's instant
    within 10 ns and vout's skew from it within 10 %, and Cl holds: 42.0 and 605.9 ns for 40 and
    560, Cl 10.3 [9.36, 11.3] uF. With one instant for both channels, a load ESR and the drifts
    of C, L and Rc stood in, Cl 7.0 [1.5, 12.1] uF."""
    vout_at, il_at = 600e-9, 40e-9
    dx = _read_at(own_capture, buckid_bin, tmp_path, lambda duty: vout_at * 330e3, il_instant=lambda duty: il_at * 330e3)
    skews = [e for e in dx["selected"] if e["name"] == "channel_skew"]
    assert len(skews) == 1, ([e["name"] for e in dx["selected"]], dx["selection_ended"])
    params = skews[0]["params"]
    assert abs(params["sample_delay"] - il_at) < 10e-9, params
    assert abs(params["vout_skew"] / (vout_at - il_at) - 1) < 0.1, params
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= 10e-6 <= final["ci95"][1], final
