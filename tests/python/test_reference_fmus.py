"""The Modelica Association's Reference FMUs (FMI 2.0 Co-Simulation, linux64, in
`tests/fixtures/reference-fmus/`) driven through `buckid simulate`, against fmpy on the same FMU.

Each FMU loads, instantiates, initializes and steps over its default experiment; every recorded
value matches fmpy's `simulate_fmu(..., fmi_type="CoSimulation", output_interval=step)` at
every communication point to |ours − fmpy| ≤ 1e-9·|fmpy| + 1e-12 (the absolute floor only
matters for values at 0, e.g. the ball at rest; both tools call the same binary in the same
order, so in practice the results agree bit for bit). Covered: the state events of
BouncingBall, the time events and early termination of Stair, the resource file of Resource,
and Integer, Boolean and Enumeration variables and inputs of Feedthrough. fmpy records no
String variables; ours does (`fmi2GetString`), checked against the FMU's own feedthrough.
"""

from __future__ import annotations

import csv
import math
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.util import auto_interval

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "tests" / "fixtures" / "reference-fmus"
MODELS = ["BouncingBall", "Dahlquist", "Feedthrough", "Resource", "Stair", "VanDerPol"]
REL, ABS = 1e-9, 1e-12


def fmu(name: str) -> Path:
    path = FIXTURES / f"{name}.fmu"
    assert path.is_file(), f"missing fixture {path}"
    return path


def default_step(path: Path) -> tuple[float, float, float]:
    """(start, stop, step) of the default experiment as `buckid simulate` reads it: fmpy's
    defaults for start/stop, the stepSize, else fmpy's `auto_interval` of the span."""
    exp = read_model_description(str(path)).defaultExperiment

    def given(attr: str) -> float | None:
        value = getattr(exp, attr, None) if exp else None
        return None if value is None else float(value)  # fmpy keeps the XML's text

    start = given("startTime") or 0.0
    stop = given("stopTime") or start + 1.0
    step = given("stepSize") or float(auto_interval(stop - start))
    return start, stop, step


def simulate(buckid: Path, tmp: Path, *args: str) -> tuple[list[str], list[list[str]], str]:
    out = tmp / "result.csv"
    proc = subprocess.run([str(buckid), "simulate", *args, "--out", str(out)],
                          capture_output=True, text=True, check=False, timeout=300)
    assert proc.returncode == 0, proc.stderr
    with out.open(newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:], proc.stderr


def assert_matches_fmpy(header: list[str], rows: list[list[str]], ref: np.ndarray) -> None:
    """Every column fmpy recorded, at every communication point, within REL·|fmpy| + ABS."""
    assert len(rows) == len(ref), f"{len(rows)} rows, fmpy {len(ref)}"
    col = {name: i for i, name in enumerate(header)}
    assert header[0] == "time"
    missing = [n for n in ref.dtype.names if n not in col]
    assert not missing, f"columns {missing} missing from {header}"
    for name in ref.dtype.names:
        ours = np.array([float(r[col[name]]) for r in rows])
        theirs = ref[name].astype(float)
        err = np.abs(ours - theirs)
        bad = np.flatnonzero(err > REL * np.abs(theirs) + ABS)
        assert bad.size == 0, (
            f"{name}: {bad.size} points differ, first at t = {ref['time'][bad[0]]}: "
            f"ours {ours[bad[0]]!r}, fmpy {theirs[bad[0]]!r}")


# ---- Every Reference FMU over its default experiment ------------------------------------------------
@pytest.mark.parametrize("name", MODELS)
def test_default_experiment_matches_fmpy(buckid_bin, tmp_path, name):
    path = fmu(name)
    start, stop, step = default_step(path)
    header, rows, log = simulate(buckid_bin, tmp_path, "--fmu", str(path))
    ref = simulate_fmu(str(path), fmi_type="CoSimulation", output_interval=step)
    assert_matches_fmpy(header, rows, ref)
    # The communication points are start + k·step (the start included), up to the stop time or
    # to where the FMU terminated.
    times = np.array([float(r[0]) for r in rows])
    k = np.arange(len(times))
    assert np.allclose(times[:-1], start + k[:-1] * step, rtol=1e-12, atol=1e-12), times[:5]
    assert times[0] == start
    if name == "Stair":
        # It ends the simulation when its counter reaches 10 (at t = 9 s): fmi2Discard with
        # fmi2Terminated, recorded at the last successful time, as fmpy does.
        assert times[-1] == pytest.approx(9.0) and rows[-1][1] == "10", rows[-1]
        assert "ended the simulation at 9 s" in log, log
    else:
        assert math.isclose(times[-1], stop), times[-1]


def test_bouncing_ball_bounces(buckid_bin, tmp_path):
    """State events: the height never goes (materially) below 0 and the velocity flips sign."""
    header, rows, _ = simulate(buckid_bin, tmp_path, "--fmu", str(fmu("BouncingBall")))
    h = np.array([float(r[header.index("h")]) for r in rows])
    v = np.array([float(r[header.index("v")]) for r in rows])
    assert h.min() > -1e-3, h.min()
    assert np.sum((v[:-1] < 0) & (v[1:] > 0)) >= 3, "fewer than three bounces"


def test_resource_reads_its_file(buckid_bin, tmp_path):
    """Resource outputs the first byte of `resources/y.txt` as an Integer."""
    with zipfile.ZipFile(fmu("Resource")) as z:
        first = z.read("resources/y.txt")[0]
    header, rows, _ = simulate(buckid_bin, tmp_path, "--fmu", str(fmu("Resource")))
    assert header == ["time", "y"]
    assert {r[1] for r in rows} == {str(first)}


@pytest.mark.parametrize("name, start_values", [("Dahlquist", {"k": 2.5}), ("BouncingBall", {"e": 0.5, "g": -3.0})])
def test_start_values_match_fmpy(buckid_bin, tmp_path, name, start_values):
    path = fmu(name)
    _, _, step = default_step(path)
    sets = [a for k, v in start_values.items() for a in ("--set", f"{k}={v}")]
    header, rows, _ = simulate(buckid_bin, tmp_path, "--fmu", str(path), *sets)
    ref = simulate_fmu(str(path), fmi_type="CoSimulation", output_interval=step, start_values=start_values)
    assert_matches_fmpy(header, rows, ref)


def test_explicit_times_and_outputs_match_fmpy(buckid_bin, tmp_path):
    """--start/--stop/--step and --output of any causality (a parameter, a local derivative);
    a stop time off the grid ends with a shortened step, as in fmpy."""
    path = fmu("VanDerPol")
    outputs = ["x0", "der(x0)", "mu"]
    args = ["--fmu", str(path), "--start", "0.5", "--stop", "3.05", "--step", "0.1"]
    header, rows, _ = simulate(buckid_bin, tmp_path, *args, *[a for o in outputs for a in ("--output", o)])
    assert header == ["time", *outputs]
    ref = simulate_fmu(str(path), fmi_type="CoSimulation", start_time=0.5, stop_time=3.05, output_interval=0.1,
                       output=outputs)
    assert_matches_fmpy(header, rows, ref)
    assert float(rows[-1][0]) == pytest.approx(3.05)


# ---- Feedthrough: every variable type, stepped inputs -----------------------------------------------
FEED_INPUTS = ["Float64_continuous_input", "Float64_discrete_input", "Int32_input", "Boolean_input",
               "Enumeration_input"]
# time, then the inputs; the row at 0.5013 s is off the 0.004 s grid, so both tools add a
# communication point there.
FEED_ROWS = [
    (0.0, 0.5, -1.25, 3, True, 2),
    (0.3, -2.0, 7.5, -4, False, 1),
    (0.5013, 1e-3, 0.0, 2147483647, True, 2),
    (1.2, 3.25, 1.0, 0, False, 1),
]


def fmpy_steps(names: list[str], rows: list[tuple], types: list) -> np.ndarray:
    """The piecewise-constant table as fmpy input: each change written twice at its time (the
    old value, then the new), so fmpy treats it as an event instead of interpolating."""
    table = []
    for i, row in enumerate(rows):
        if i > 0:
            table.append((row[0], *rows[i - 1][1:]))
        table.append(row)
    table.append((10.0, *rows[-1][1:]))
    return np.array(table, dtype=[("time", np.float64), *zip(names, types)])


def test_feedthrough_stepped_inputs_of_every_type_match_fmpy(buckid_bin, tmp_path):
    path = fmu("Feedthrough")
    _, stop, step = default_step(path)
    table = tmp_path / "inputs.csv"
    with table.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", *FEED_INPUTS, "String_input"])
        for i, row in enumerate(FEED_ROWS):
            w.writerow([*row[:4], "true" if row[4] else "false", row[5], f"text {i}"])
    header, rows, _ = simulate(buckid_bin, tmp_path, "--fmu", str(path), "--input", str(table))
    signals = fmpy_steps(FEED_INPUTS, FEED_ROWS, [np.float64, np.float64, np.int32, np.bool_, np.int32])
    ref = simulate_fmu(str(path), fmi_type="CoSimulation", output_interval=step, input=signals)
    assert_matches_fmpy(header, rows, ref)

    # Each output equals the input of the row in force during the step before (feedthrough),
    # an Enumeration is its Integer, a Boolean 0/1, and a String is recorded as text.
    col = {n: i for i, n in enumerate(header)}
    times = [float(r[0]) for r in rows]
    assert any(math.isclose(t, 0.5013) for t in times), "no communication point at the input change"
    for t, r in zip(times[1:], rows[1:]):
        i = max(j for j, row in enumerate(FEED_ROWS) if row[0] < t and not math.isclose(row[0], t))
        want = FEED_ROWS[i]
        assert float(r[col["Float64_continuous_output"]]) == want[1], (t, r)
        assert r[col["Int32_output"]] == str(want[3]), (t, r)
        assert r[col["Boolean_output"]] == ("1" if want[4] else "0"), (t, r)
        assert r[col["Enumeration_output"]] == str(want[5]), (t, r)
        assert r[col["String_output"]] == f"text {i}", (t, r)
    assert math.isclose(times[-1], stop)


# ---- Clear errors ------------------------------------------------------------------------------------
def run_error(buckid: Path, *args: str) -> str:
    proc = subprocess.run([str(buckid), "simulate", *args], capture_output=True, text=True, check=False, timeout=60)
    assert proc.returncode != 0, proc.stdout
    assert "panicked" not in proc.stderr, proc.stderr
    return proc.stderr


def write_inputs(tmp: Path, text: str) -> str:
    path = tmp / "in.csv"
    path.write_text(text)
    return str(path)


def test_errors_name_the_problem(buckid_bin, tmp_path):
    feed = str(fmu("Feedthrough"))
    assert "does not exist" in run_error(buckid_bin, "--fmu", str(tmp_path / "nope.fmu"))
    err = run_error(buckid_bin, "--fmu", feed, "--output", "nosuch")
    assert '"nosuch"' in err and "Float64_continuous_output" in err, err
    assert '"k2"' in run_error(buckid_bin, "--fmu", str(fmu("Dahlquist")), "--set", "k2=1")
    assert "Int32_input" in run_error(buckid_bin, "--fmu", feed, "--set", "Int32_input=1.5")
    assert "must be positive" in run_error(buckid_bin, "--fmu", feed, "--step", "0")
    assert "must be positive" in run_error(buckid_bin, "--fmu", feed, "--step", "-0.1")
    assert "before the start time" in run_error(buckid_bin, "--fmu", feed, "--stop", "-1")
    assert "not a finite number" in run_error(buckid_bin, "--fmu", feed, "--step", "nan")
    err = run_error(buckid_bin, "--fmu", feed, "--input", write_inputs(tmp_path, "time,nosuch\n0,1\n"))
    assert "column `nosuch`" in err and '"nosuch"' in err, err
    err = run_error(buckid_bin, "--fmu", feed, "--input",
                    write_inputs(tmp_path, "time,Int32_input\n0,1\n0.5,2\n0.5,3\n"))
    assert "row 3: time 0.5 does not increase" in err, err
    err = run_error(buckid_bin, "--fmu", feed, "--input",
                    write_inputs(tmp_path, "time,Float64_continuous_input\n0,1\n0.5,NaN\n"))
    assert "line 3" in err and "NaN" in err and "Float64_continuous_input" in err, err
    err = run_error(buckid_bin, "--fmu", feed, "--input",
                    write_inputs(tmp_path, "time,Float64_fixed_parameter\n0,1\n"))
    assert "Float64_fixed_parameter" in err and "only inputs and tunable parameters" in err, err


def test_a_model_exchange_only_fmu_is_refused(buckid_bin, tmp_path):
    src = fmu("Dahlquist")
    dst = tmp_path / "DahlquistME.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item)
            if item.filename == "modelDescription.xml":
                text = data.decode()
                start = text.index("<CoSimulation")
                end = text.index("</CoSimulation>") + len("</CoSimulation>")
                data = (text[:start] + text[end:]).encode()
            zout.writestr(item, data)
    err = run_error(buckid_bin, "--fmu", str(dst))
    assert "no CoSimulation element" in err, err
