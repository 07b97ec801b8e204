"""Session fixtures for the cross-tool tests of the BuckConverter FMU.

The FMU and the `trajectory` example are (re)built with cargo once per session, so the tests
always exercise the current sources; both builds are incremental (about a second when nothing
changed). Nothing here hard-codes the Python environment: tools are found next to
`sys.executable`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from captures import generate

REPO = Path(__file__).resolve().parents[2]


def _cargo() -> str:
    cargo = os.environ.get("CARGO") or shutil.which("cargo")
    if cargo is None:
        pytest.fail("cargo is not on PATH: it is needed to build the FMU under test")
    return cargo


def venv_tool(name: str) -> str | None:
    """A console script installed next to the running interpreter (the venv's bin dir), else PATH."""
    candidate = Path(sys.executable).parent / name
    if candidate.is_file() and os.access(candidate, os.X_OK):
        return str(candidate)
    return shutil.which(name)


@pytest.fixture(scope="session")
def fmutool() -> str:
    """fmu-manipulation-toolbox's `fmutool` command."""
    tool = venv_tool("fmutool")
    if tool is None:
        pytest.fail("fmutool (fmu-manipulation-toolbox) is not installed next to the interpreter nor on PATH")
    return tool


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


@pytest.fixture(scope="session")
def fmu_path() -> Path:
    """`cargo xtask fmu`: builds the release cdylib and packages it; prints the FMU's path."""
    proc = subprocess.run(
        [_cargo(), "xtask", "fmu"], cwd=REPO, capture_output=True, text=True, check=False
    )
    if proc.returncode != 0:
        pytest.fail(f"cargo xtask fmu failed ({proc.returncode}):\n{proc.stderr[-4000:]}")
    lines = [line for line in proc.stdout.splitlines() if line.strip()]
    path = Path(lines[-1].strip()) if lines else REPO / "fmu" / "BuckConverter.fmu"
    assert path.is_file(), f"cargo xtask fmu did not produce {path}"
    return path


def cargo_executable(package: str, target: str, *extra: str, release: bool = True) -> Path:
    """`cargo build` of one executable (a no-op when up to date), so a stale binary from an
    older checkout is never tested; `--release`, or the profile `cargo test` builds binaries in
    (its numerical crates optimised as fully). Its path comes from cargo's JSON messages, so a
    custom `CARGO_TARGET_DIR` works too."""
    profile = ["--release"] if release else []
    proc = subprocess.run(
        [_cargo(), "build", *profile, "-p", package, *extra, "--message-format=json"],
        cwd=REPO, capture_output=True, text=True, check=False,
    )
    if proc.returncode != 0:
        pytest.fail(f"building {target} failed:\n{proc.stderr[-4000:]}")
    for line in proc.stdout.splitlines():
        try:
            msg = json.loads(line)
        except json.JSONDecodeError:
            continue
        if (msg.get("reason") == "compiler-artifact" and msg.get("target", {}).get("name") == target
                and msg.get("executable")):
            return Path(msg["executable"])
    pytest.fail(f"cargo did not report the {target} executable")


@pytest.fixture(scope="session")
def trajectory_bin() -> Path:
    """The `trajectory` example of buck-model (the Rust model in-process, same code as the FMU)."""
    return cargo_executable("buck-model", "trajectory", "--example", "trajectory")


@pytest.fixture(scope="session")
def buckid_bin() -> Path:
    """The `buckid` command line, as `cargo test` built it for the CLI's tests (`scripts/test`
    runs those first): a release build of it cost the clean clone's CI 3 minutes."""
    return cargo_executable("buckid", "buckid", "--bin", "buckid", release=False)


def third_diagnosis(buckid_bin: Path, tmp_path: Path, *third_args: str):
    """A board from the third ngspice generator (`scripts/spice/third/third.py` with
    `third_args`, e.g. `--family pol --case several --seed 1901`), diagnosed by `buckid diagnose
    --nominal switched`: `(truth, diagnosis JSON, the CLI's stdout)`."""
    data, truth_file, out = tmp_path / "third.csv", tmp_path / "truth.json", tmp_path / "dx.json"
    generate(REPO / "scripts" / "spice" / "third" / "third.py", list(third_args), {"--out": data, "--truth": truth_file})
    proc = subprocess.run([str(buckid_bin), "diagnose", "--data", str(data), "--nominal", "switched", "--json", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads(truth_file.read_text()), json.loads(out.read_text()), proc.stdout


def assert_fmutool_clean(fmu: Path, fmutool: str) -> None:
    """`fmutool -input FMU -check` exits 0, prints no ERROR line, finds the FMU compliant with
    FMI 2.0 and reports no semantic error."""
    proc = subprocess.run([fmutool, "-input", str(fmu), "-check"], capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert not [line for line in out.splitlines() if "ERROR" in line], out
    assert "seems to be compliant with FMI-2.0" in out, out
    assert "No semantic error" in out, out


@pytest.fixture(scope="session")
def fmu_dir(fmu_path: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The FMU extracted once; every fmpy FMU2Slave of the session loads its binary from here."""
    from fmpy import extract

    return Path(extract(str(fmu_path), unzipdir=str(tmp_path_factory.mktemp("BuckConverter"))))


@pytest.fixture(scope="session")
def model_description(fmu_path: Path):
    from fmpy import read_model_description

    return read_model_description(str(fmu_path))
