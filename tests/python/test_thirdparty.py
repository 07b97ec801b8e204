"""Blind targets made by other tools: `buckid identify` must find a load capacitance it cannot
read from the FMU.

- `BuckPy.fmu` (pythonfmu): pure-Python averaged buck, exact ZOH steps of any length, hidden
  Cl = 4.7 µF, variables named its own way (D, Iload, Vin → Vout, IL).
- `BuckQ.fmu` (qfmu): plain-C state space whose one-Euler-step-per-doStep equals the exact ZOH
  discretization at T = 1/330 kHz, hidden Cl = 2.2 µF, variables u1, u2 → y1, y2.

Both are built from `tests/thirdparty/` by `tests/thirdparty/build.sh` (a session fixture runs it:
a failing build fails the tests; only a missing C compiler skips the qfmu FMU). Sources and the
quirks of both tools are documented in the files under `tests/thirdparty/`.
"""

from __future__ import annotations

import json
import re
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from conftest import assert_fmutool_clean
from fmu_harness import AVERAGED, CALLBACKS, RL, T, U, prbs_duty, reference

REPO = Path(__file__).resolve().parents[2]
THIRDPARTY = REPO / "tests" / "thirdparty"
BUILD = THIRDPARTY / "build.sh"


def _hidden_cl(source: Path) -> float:
    """The `CL = ...` constant of a model source: the single place the hidden value is written."""
    match = re.search(r"^CL = ([0-9.eE+-]+)", source.read_text(), re.MULTILINE)
    assert match, f"no `CL = ...` line in {source}"
    return float(match.group(1))


# kind → (FMU file, source with the hidden CL, CLI role mapping, input names duty/io/vin, outputs vout/il)
TARGETS = {
    "pythonfmu": {
        "fmu": "BuckPy.fmu",
        "source": THIRDPARTY / "pythonfmu" / "buck_py.py",
        "map": {"duty": "D", "io": "Iload", "vin": "Vin", "vout": "Vout", "il": "IL"},
    },
    "qfmu": {
        "fmu": "BuckQ.fmu",
        "source": THIRDPARTY / "qfmu" / "build_buckq.py",
        "map": {"duty": "u1", "io": "u2", "vout": "y1", "il": "y2"},
    },
}
KINDS = list(TARGETS)


# ---- Fixtures -----------------------------------------------------------------------------------
@pytest.fixture(scope="session")
def thirdparty_build() -> str:
    """Runs the build script once per session (quick when the FMUs are up to date)."""
    proc = subprocess.run(["bash", str(BUILD)], cwd=REPO, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        pytest.fail(f"{BUILD.relative_to(REPO)} failed ({proc.returncode}):\n{proc.stderr[-4000:]}")
    return proc.stderr


@pytest.fixture(scope="session", params=KINDS)
def kind(request) -> str:
    return request.param


def _fmu(kind: str, build_log: str) -> Path:
    path = REPO / "target" / "thirdparty" / TARGETS[kind]["fmu"]
    if not path.is_file():
        skip = [line for line in build_log.splitlines() if "SKIP" in line]
        if skip:
            pytest.skip("; ".join(skip))
        pytest.fail(f"the build script succeeded but wrote no {path}:\n{build_log[-2000:]}")
    return path


@pytest.fixture(scope="session")
def buckpy(thirdparty_build) -> Path:
    return _fmu("pythonfmu", thirdparty_build)


@pytest.fixture(scope="session")
def buckq(thirdparty_build) -> Path:
    return _fmu("qfmu", thirdparty_build)


@pytest.fixture(scope="session")
def target(kind, thirdparty_build) -> Path:
    return _fmu(kind, thirdparty_build)


@pytest.fixture(scope="session")
def extracted(tmp_path_factory):
    """FMU path → extracted folder, once per session."""
    cache: dict[Path, Path] = {}

    def get(path: Path) -> Path:
        if path not in cache:
            cache[path] = Path(extract(str(path), unzipdir=str(tmp_path_factory.mktemp(path.stem))))
        return cache[path]

    return get



# ---- Driving with fmpy ----------------------------------------------------------------------------
class Slave:
    """One FMU2Slave of a third-party FMU, initialized with `start` values set before
    initialization; inputs and outputs by name."""

    def __init__(self, path: Path, folder: Path, name: str, start: dict | None = None):
        self.md = read_model_description(str(path))
        self.vrs = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=str(folder),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=CALLBACKS)
        self.t = 0.0
        self.fmu.setupExperiment(startTime=0.0)
        if start:
            self.set(start)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def set(self, values: dict) -> None:
        self.fmu.setReal([self.vrs[n] for n in values], list(values.values()))

    def get(self, *names: str) -> list[float]:
        return self.fmu.getReal([self.vrs[n] for n in names])

    def step(self, h: float) -> None:
        self.fmu.doStep(self.t, h)
        self.t += h

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def run_periods(slave: Slave, duty_name: str, outputs: tuple[str, str], duties, steps=(1.0,)) -> np.ndarray:
    """One switching period per duty, split into doSteps of the fractions `steps` of T; rows are
    the outputs (vout, il) at each period end."""
    rows = []
    for d in duties:
        slave.set({duty_name: float(d)})
        for frac in steps:
            slave.step(frac * T)
        rows.append(slave.get(*outputs))
    return np.array(rows)


def duty_sequence(n: int) -> np.ndarray:
    """A PRBS between 0.4 and 0.6 behind one period at 0.5 (the qfmu FMU's fixed start point)."""
    return np.concatenate([[0.5], prbs_duty(n - 1)])


# ---- Build --------------------------------------------------------------------------------------
def test_build_script_is_idempotent_and_quick(thirdparty_build):
    """A second run with nothing changed rebuilds nothing and takes seconds."""
    t0 = time.monotonic()
    proc = subprocess.run(["bash", str(BUILD)], cwd=REPO, capture_output=True, text=True, check=False)
    elapsed = time.monotonic() - t0
    assert proc.returncode == 0, proc.stderr
    assert "building" not in proc.stderr, proc.stderr
    assert elapsed < 20, f"an up-to-date build took {elapsed:.1f} s"
    listed = [Path(line) for line in proc.stdout.splitlines() if line.strip()]
    assert all(p.is_file() and p.parent == REPO / "target" / "thirdparty" for p in listed), listed


# ---- Compliance and the DC point -------------------------------------------------------------------
def test_fmpy_validate_finds_no_problem(target):
    assert validate_fmu(str(target)) == []


def test_fmutool_check_is_clean(target, fmutool):
    assert_fmutool_clean(target, fmutool)


def test_cl_is_hidden(target, kind):
    """The identification is blind: no variable carries the load capacitance."""
    names = [v.name for v in read_model_description(str(target)).modelVariables]
    assert not [n for n in names if "cl" == n.lower() or n.lower().startswith("cl_")], names
    for role, name in TARGETS[kind]["map"].items():
        assert name in names, (role, name, names)


def test_buckpy_starts_and_stays_at_the_dc_point_of_its_start_inputs(buckpy):
    """il = Iload, vo = D·Vin − RL·Iload, for the inputs set before initialization."""
    for d, io, vin in [(0.5, 1.0, 12.0), (0.4, 2.0, 10.0), (0.7, 0.3, 5.0)]:
        res = simulate_fmu(str(buckpy), stop_time=200 * T, step_size=T, output_interval=T,
                           start_values={"D": d, "Iload": io, "Vin": vin}, output=["Vout", "IL"])
        want = d * vin - RL * io
        assert np.max(np.abs(res["Vout"] - want)) < 1e-9, (d, io, vin, res["Vout"][[0, -1]])
        assert np.max(np.abs(res["IL"] - io)) < 1e-9


def test_buckq_starts_and_stays_at_its_dc_point(buckq):
    """qfmu's start state is x*_start = (1, 5.9, 5.9), the DC point of u*_start = (0.5, 1 A);
    other start points go through those parameters (inputs set before initialization are
    overwritten by u*_start, a qfmu quirk)."""
    res = simulate_fmu(str(buckq), stop_time=200 * T, step_size=T, output_interval=T, output=["y1", "y2"])
    assert np.max(np.abs(res["y1"] - (0.5 * U - RL * 1.0))) < 1e-9, res["y1"][[0, -1]]
    assert np.max(np.abs(res["y2"] - 1.0)) < 1e-9
    vo = 0.4 * U - RL * 2.0
    start = {"u1_start": 0.4, "u2_start": 2.0, "x1_start": 2.0, "x2_start": vo, "x3_start": vo}
    res = simulate_fmu(str(buckq), stop_time=200 * T, step_size=T, output_interval=T,
                       start_values=start, output=["y1", "y2"])
    assert np.max(np.abs(res["y1"] - vo)) < 1e-8, res["y1"][[0, -1]]
    assert np.max(np.abs(res["y2"] - 2.0)) < 1e-8


# ---- Exactness against an independent reference (scipy expm) --------------------------------------
@pytest.mark.parametrize("steps", [(1.0,), (0.25, 0.25, 0.5), (0.1,) * 10], ids=["T", "ragged", "tenths"])
def test_buckpy_is_the_exact_averaged_model_for_any_step(buckpy, extracted, steps):
    cl = _hidden_cl(TARGETS["pythonfmu"]["source"])
    duties = duty_sequence(400)
    want = reference(duties, cl, 1.0, AVERAGED)[:, :2]
    with Slave(buckpy, extracted(buckpy), "exact", {"D": duties[0]}) as s:
        got = run_periods(s, "D", ("Vout", "IL"), duties, steps)
    assert np.max(np.abs(got[:, 0] - want[:, 0])) < 1e-9
    assert np.max(np.abs(got[:, 1] - want[:, 1])) < 1e-8


def test_buckpy_long_steps_cross_many_periods(buckpy, extracted):
    """One doStep over a whole PRBS bit (8 periods at constant duty) equals 8 period steps."""
    cl = _hidden_cl(TARGETS["pythonfmu"]["source"])
    duties = duty_sequence(8 * 40 + 1)[1:]
    want = reference(duties, cl, 1.0, AVERAGED)[7::8, :2]
    with Slave(buckpy, extracted(buckpy), "long", {"D": duties[0]}) as s:
        got = []
        for d in duties[::8]:
            s.set({"D": float(d)})
            s.step(8 * T)
            got.append(s.get("Vout", "IL"))
    assert np.max(np.abs(np.array(got) - want)) < 1e-8


def test_buckq_samples_are_the_exact_averaged_model(buckq, extracted):
    """At doStep(T) the qfmu FMU is the exact ZOH discretization of the averaged model."""
    cl = _hidden_cl(TARGETS["qfmu"]["source"])
    duties = duty_sequence(400)
    want = reference(duties, cl, 1.0, AVERAGED)[:, :2]
    with Slave(buckq, extracted(buckq), "exact") as s:
        got = run_periods(s, "u1", ("y1", "y2"), duties)
    assert np.max(np.abs(got[:, 0] - want[:, 0])) < 1e-8
    assert np.max(np.abs(got[:, 1] - want[:, 1])) < 1e-7


# ---- The CLI against the blind targets ------------------------------------------------------------
def _identify(buckid: Path, fmu: Path, kind: str, out: Path, **remap: str) -> subprocess.CompletedProcess:
    cmd = [str(buckid), "identify", "--fmu", str(fmu), "--model", "averaged", "--seed", "7",
           "--noise-vout", "2e-3", "--noise-il", "20e-3", "--json", str(out)]
    for role, name in {**TARGETS[kind]["map"], **remap}.items():
        cmd += ["--map", f"{role}={name}"]
    return subprocess.run(cmd, capture_output=True, text=True, check=False, timeout=900)


def test_identify_finds_the_hidden_cl(buckid_bin, target, kind, tmp_path):
    cl = _hidden_cl(TARGETS[kind]["source"])
    out = tmp_path / "out.json"
    proc = _identify(buckid_bin, target, kind, out)
    assert proc.returncode == 0, f"stdout:\n{proc.stdout}\nstderr:\n{proc.stderr[-4000:]}"
    result = json.loads(out.read_text())
    lo, hi = result["cl"]["ci95"]
    estimate = result["cl"]["estimate"]
    assert lo <= estimate <= hi, result["cl"]
    assert lo <= cl <= hi, f"true Cl {cl:g} outside the 95 % interval [{lo:g}, {hi:g}] (estimate {estimate:g})"
    assert result["fit_percent"]["simulation"] > 90, result["fit_percent"]
    assert result["model"] == "averaged", result["model"]


def test_unknown_variable_is_an_error_listing_the_fmus_variables(buckid_bin, target, kind, tmp_path):
    proc = _identify(buckid_bin, target, kind, tmp_path / "out.json", vout="NoSuchVar")
    assert proc.returncode != 0, proc.stdout
    assert "NoSuchVar" in proc.stderr, proc.stderr
    names = [v.name for v in read_model_description(str(target)).modelVariables]
    missing = [n for n in names if n not in proc.stderr]
    assert not missing, f"stderr does not list {missing}:\n{proc.stderr}"
    assert not (tmp_path / "out.json").exists()


# ---- An FMU without an inductor current (issue 15) -------------------------------------------------
# BuckPy mapped without `il`: exactly a third-party buck that exposes duty, load current and vout
# only. The inductor current is optional in the data contract and must be for an FMU too.
VOUT_ONLY = {"duty": "D", "io": "Iload", "vin": "Vin", "vout": "Vout"}


def _identify_buckpy(buckid: Path, fmu: Path, out: Path, mapping: dict, *extra: str,
                     model: str = "averaged") -> subprocess.CompletedProcess:
    cmd = [str(buckid), "identify", "--fmu", str(fmu), "--model", model, "--seed", "7",
           "--noise-vout", "2e-3", "--noise-il", "20e-3", "--json", str(out), *extra]
    for role, name in mapping.items():
        cmd += ["--map", f"{role}={name}"]
    return subprocess.run(cmd, capture_output=True, text=True, check=False, timeout=900)


def test_identify_from_vout_alone_when_the_fmu_has_no_il(buckid_bin, buckpy, tmp_path):
    cl = _hidden_cl(TARGETS["pythonfmu"]["source"])
    out, data = tmp_path / "out.json", tmp_path / "data.csv"
    proc = _identify_buckpy(buckid_bin, buckpy, out, VOUT_ONLY, "--save-data", str(data))
    assert proc.returncode == 0, f"stdout:\n{proc.stdout}\nstderr:\n{proc.stderr[-4000:]}"
    result = json.loads(out.read_text())
    lo, hi = result["cl"]["ci95"]
    assert lo <= cl <= hi, f"true Cl {cl:g} outside [{lo:g}, {hi:g}]"
    assert result["outputs"] == ["vout"], result["outputs"]
    header = next(line for line in data.read_text().splitlines() if not line.startswith("#"))
    assert header.split(",") == ["time", "duty", "vin", "io", "vout"], header

    # With il measured (σ = 20 mA) and fitted, the data tells more: the interval is narrower.
    with_il = tmp_path / "with_il.json"
    proc = _identify_buckpy(buckid_bin, buckpy, with_il, {**VOUT_ONLY, "il": "IL"}, "--with-il")
    assert proc.returncode == 0, proc.stderr[-4000:]
    both = json.loads(with_il.read_text())
    assert both["outputs"] == ["vout", "il"], both["outputs"]
    assert both["cl"]["ci95"][0] <= cl <= both["cl"]["ci95"][1], both["cl"]
    assert both["cl"]["rel_std"] < result["cl"]["rel_std"], (both["cl"], result["cl"])

    # The data file it saved (no il column) diagnoses from vout alone.
    dx = tmp_path / "dx.json"
    proc = subprocess.run([str(buckid_bin), "diagnose", "--data", str(data), "--json", str(dx)],
                          capture_output=True, text=True, check=False, timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert json.loads(dx.read_text())["verdict"] == "none"


@pytest.mark.parametrize("model, extra", [("averaged", ("--with-il",)), ("reduced", ())])
def test_a_model_needing_il_names_the_missing_role(buckid_bin, buckpy, tmp_path, model, extra):
    out = tmp_path / "out.json"
    proc = _identify_buckpy(buckid_bin, buckpy, out, VOUT_ONLY, "--samples", "200", *extra, model=model)
    assert proc.returncode != 0, proc.stdout
    assert "no `il`" in proc.stderr and "--map il=NAME" in proc.stderr, proc.stderr
    assert "NaN" not in proc.stderr and "panicked" not in proc.stderr, proc.stderr
    assert not out.exists()
