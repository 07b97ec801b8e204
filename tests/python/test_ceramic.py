"""A point-of-load board from the third ngspice generator (scripts/spice/third: 5 V, 1.6 uH,
170 uF polymer, 875 kHz, 5 A) whose output rings after each PRBS step, from 0.7 V to 5 V: its
34 uF ceramic (53.5 uF at 0 V, `Cl0/sqrt(1 + (v/V0)^2)`, V0 = 1.65 V) is swung across most of
its bias law. The `cap_dc_bias` candidate, fitted under the model's concave quadratic law
alone, predicted the held-out data worse than the nominal: the verdict was `none` and Cl not
identified. Started under either of the model's shapes, it goes on in the reciprocal one: the
effect is named, the JSON says which law, and Cl holds.
"""

from __future__ import annotations

from conftest import third_diagnosis


def test_a_ceramic_swung_across_its_law_is_found_under_the_shape_it_follows(buckid_bin, tmp_path):
    truth, dx, _ = third_diagnosis(buckid_bin, tmp_path, "--family", "pol", "--case", "single", "--effect", "cap_dc_bias",
                                   "--seed", "4302", "--periods", "3001")
    data = (tmp_path / "third.csv").read_text().splitlines()
    vout = [float(line.split(",")[4]) for line in data if line[:1].isdigit()]
    assert min(vout) < 1.0 and max(vout) > 4.5, "the output must swing across the law"
    names = [e["name"] for e in dx["selected"]]
    assert names[:1] == ["cap_dc_bias"], (names, dx["selection_ended"])
    assert dx["selected"][0]["params"].get("cap_bias_law_reciprocal") == 1.0, dx["selected"][0]["params"]
    final = dx["selected"][-1]["cl"]
    assert final["ci95"][0] <= truth["cl_true"] <= final["ci95"][1], (final["estimate"], final["ci95"], truth["cl_true"])
