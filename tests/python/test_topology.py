"""A diode buck from the third ngspice generator (scripts/spice/third: a 5 V, 911 kHz
point-of-load buck with a Schottky for its low side, a 9.8 mOhm high side, L 12 % below its
nominal and a light DCM share), which `buckid diagnose`, told nothing, must call a diode buck.

The first step decides the topology, and greedy forward selection cannot undo it: a dead time
closed 97.7 % of the gap, the diode 94.2 %, and the path from the dead time took a 9.8 %
"gain error" of the vout reading for the diode's `(U + Vf)/U` and ended at 2.7 noise floors.
Where the path from the first step still misses materially and the other topology's first step
came close, its path is followed too (`gap::select::topology_rival`) and kept if it closes a
material share of what is left.
"""

from __future__ import annotations

from conftest import third_diagnosis


def test_a_diode_buck_whose_best_first_step_is_a_dead_time_is_a_diode_buck(buckid_bin, tmp_path):
    truth, dx, _ = third_diagnosis(buckid_bin, tmp_path, "--family", "pol", "--case", "several", "--seed", "1101", "--periods", "3001")
    assert truth["topology"] == "async" and "diode_drop" in truth["effects"], truth["effects"]
    named = [e["name"] for e in dx["selected"]]
    assert named[0] == "diode_drop" and "dead_time" not in named, (named, dx["selection_ended"])
    assert "the other topology" in dx["selection_ended"], dx["selection_ended"]
    # The inductor's drift and the high side's resistance, near the generator's truth.
    values = {k: v for e in dx["selected"] for k, v in e["params"].items()}
    l_true = truth["circuit"]["L"]
    assert abs(values["L"] / l_true - 1) < 0.03, (values["L"], l_true)
    assert "switch_resistance" in named, named
    # At the noise floor: the final model misses vout by less than 1.2 floors.
    assert dx["selected"][-1]["rms_after"] < 1.2 * dx["where"]["noise_floor_rms"], dx["selected"][-1]["rms_after"]


def test_a_diode_buck_in_deep_dcm_whose_charge_the_model_misses_is_not_confidently_wrong(buckid_bin, tmp_path):
    """A Schottky point-of-load buck at 0.18 A (seed 1901: 6.24 uF on 70 uF, L 13 % above its
    nominal, a 24 Ohm / 14 nF snubber on the node) starts every period in DCM. The diode's drop
    takes the inductor's place (0.48 V for 0.29), and the fit's own interval, 31.9-33.3 uF, is
    confident and wrong. Cl shows only through each period's charge there, and the model's
    charge is not the converter's: the diode alone missed vout by 2.8 floors (Cl not identified
    for that, `deep_dcm_miss`); with the node's ring beside it, 1.35 floors, Cl's interval spans
    the output-error and the high-pass fits and is widened for the model error the residual
    still shows, too wide to identify Cl. Either way Cl is said not identified, never the fit's
    interval."""
    truth, dx, stdout = third_diagnosis(buckid_bin, tmp_path, "--family", "pol", "--case", "several", "--seed", "1901", "--periods", "3001")
    assert truth["topology"] == "async" and "dcm" in truth["effects"], truth["effects"]
    assert dx["selected"][0]["name"] == "diode_drop", dx["selection_ended"]
    assert dx["dcm_share"] >= 0.9, dx["dcm_share"]
    cl = dx["selected"][-1]["cl"]
    # What the model's own interval said, and the truth it left out.
    lo, hi = cl["check"]["model_ci95"]
    assert not lo <= truth["cl_true"] <= hi, (lo, hi, truth["cl_true"])
    # Reported: not identified, for the deep-DCM miss or for the width.
    lo, hi = cl["ci95"]
    assert hi is None or hi / lo >= 10, cl["ci95"]
    assert (hi is None) == ("deep_dcm_miss" in cl), cl
    assert "(not identified)" in next(line for line in stdout.splitlines() if line.startswith("Cl ")), stdout[-2000:]


def test_a_diode_buck_in_deep_dcm_with_its_inductor_off_nominal_gets_its_inductance(buckid_bin, tmp_path):
    """A thesis-stage Schottky buck at 0.61 A (seed 5302: L 18 % below its nominal, 27 uF on
    100 uF, a 69 Ohm / 2.7 nF snubber on the node) starts every period in DCM. The diode alone
    closes 38 % of the gap, with Cl run to 906 uF to hide the charge the nominal L misses; at
    that fit a 1 % probe of L promises nothing, and the screen of the next step passed nothing
    through. Where the model so far misses grossly and nothing screened is material, the drifts
    of L, C and Rc are fitted past the screen: L's closes the gap to the noise floor, and Cl
    comes out right. Before, the diagnosis ended at the diode, 140 floors above the noise."""
    truth, dx, _ = third_diagnosis(buckid_bin, tmp_path, "--family", "thesis", "--case", "several", "--seed", "5302", "--periods", "3001")
    assert truth["topology"] == "async" and truth["drifted"] == ["L"], (truth["topology"], truth["drifted"])
    named = [e["name"] for e in dx["selected"]]
    assert named[:2] == ["dcm", "param_drift"], (named, dx["selection_ended"])
    values = {k: v for e in dx["selected"] for k, v in e["params"].items()}
    l_true = truth["circuit"]["L"]
    assert abs(values["L"] / l_true - 1) < 0.03, (values["L"], l_true)
    # At the noise floor, and Cl inside its interval.
    assert dx["selected"][-1]["rms_after"] < 1.2 * dx["where"]["noise_floor_rms"], dx["selected"][-1]["rms_after"]
    lo, hi = dx["selected"][-1]["cl"]["ci95"]
    assert lo <= truth["cl_true"] <= hi and hi / lo < 1.5, (lo, hi, truth["cl_true"])
    # The late reading's current probe, whose gain the generator leaves exact, takes a gain
    # error far beyond a probe's: said to stand in for a current the model does not match.
    assert truth["acq"]["il_gain"] == 0.0, truth["acq"]
    for e in dx["selected"]:
        beyond = abs(e["params"].get("il_gain_error", 0.0)) > 0.1
        assert beyond == ("probe's tolerance" in (e.get("stand_in") or "")), e


def test_a_diode_buck_is_not_named_a_gain_error_of_its_reading(buckid_bin, tmp_path):
    """A thesis-stage Schottky buck at 0.76 A (seed 5902: L 13 % above its nominal, a
    110 Ohm / 1.6 nF snubber) starts every period in DCM. Its diode's fit closes 99 % of the
    gap with the drop run to its 5 V bound, and a 21 % gain error of the vout reading closed 79 %:
    that was the verdict. No divider or probe is 21 % off (beyond 10 % a reading is scaled
    wrong, not miscalibrated): the gain is no finding, and the verdict says what is known,
    the diode's fit on its bound."""
    truth, dx, _ = third_diagnosis(buckid_bin, tmp_path, "--family", "thesis", "--case", "several", "--seed", "5902", "--periods", "3001")
    assert truth["topology"] == "async" and truth["acq"]["vout_gain"] == 0.0, (truth["topology"], truth["acq"])
    gain = next(e for e in dx["effects"] if e["name"] == "sensor_gain")
    assert abs(gain["params"]["vout_gain_error"]) > 0.1 and not gain["finding"] and gain["at_bound"], gain
    assert all(e["name"] != "sensor_gain" for e in dx["selected"] or []), dx["selection_ended"]
    assert "diode_drop closes" in dx["selection_ended"] and "ends on a bound" in dx["selection_ended"], dx["selection_ended"]


def test_two_first_steps_that_end_at_the_floor_alike_both_hold_cl(buckid_bin, tmp_path):
    """A point-of-load buck (seed 6102) whose load capacitor carries a 3.5 mOhm ESR, its ADC
    reading 100 ns late. An inductance 5.9 % high closes 79.2 % of the gap, the ESR 78.0 %: the
    path from L ended at the floor with the late reading and a filter, Cl 18.8 [18.6, 19.0] uF
    for 23.2. The path from the ESR ends at the floor too, with fewer effects and less left
    held out: it is taken, and Cl's interval spans the other model's Cl, which the data does
    not tell apart (`gap::select::twin`)."""
    truth, dx, out = third_diagnosis(buckid_bin, tmp_path, "--family", "pol", "--case", "single", "--seed", "6102", "--periods", "3001")
    assert truth["single_effect"] == "load_esr", truth["single_effect"]
    named = [e["name"] for e in dx["selected"]]
    assert named == ["load_esr", "sample_delay"], (named, dx["selection_ended"])
    esr = dx["selected"][0]["params"]["load_esr"]
    assert abs(esr / truth["circuit"]["rcl"] - 1) < 0.05, (esr, truth["circuit"]["rcl"])
    cl = dx["selected"][-1]["cl"]
    twin = cl["twins"][0]
    assert twin["selected"][0] == "param_drift (L)", twin
    lo, hi = cl["ci95"]
    assert lo <= twin["cl"] <= hi and lo <= truth["cl_true"] <= hi, (lo, hi, twin["cl"], truth["cl_true"])
    assert abs(cl["estimate"] / truth["cl_true"] - 1) < 0.02, (cl["estimate"], truth["cl_true"])
    assert "does not tell them apart" in out, out
