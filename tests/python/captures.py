"""The ngspice captures the diagnosis tests read, recorded once instead of simulated on every run.

A diagnosis test needs a transient of 2000-3001 switching periods from one of the ngspice
generators (`scripts/spice/buck_spice.py`, `harness/harness.py`, `third/third.py`): 20-85 s of
ngspice each, most of the pytest suite's time. `generate` keys a run on the generator's sources
(the script and the netlist templates beside it) and its arguments; a recorded run under
`tests/fixtures/captures/<key>/` is copied out, anything else is simulated live. The files are
the generator's own output, byte for byte (gzip-compressed); the diagnosis under test always
runs afresh. Editing a generator changes every key of its runs: `test_captures.py` then fails
until they are recorded again with

    BUCKID_RECORD_CAPTURES=1 .venv/bin/python -m pytest -n auto tests/python

which simulates each missing run and stores it (and leaves unused entries for `git rm`). The
Rust blind tests read the harness's runs from the same store under the same key
(`crates/blind/src/captures.rs`; record theirs with `BUCKID_RECORD_CAPTURES=1 cargo test -p blind
--test blind`).
"""

from __future__ import annotations

import gzip
import hashlib
import json
import os
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
STORE = REPO / "tests" / "fixtures" / "captures"
RECORD = os.environ.get("BUCKID_RECORD_CAPTURES") == "1"


def sources(generator: Path) -> list[Path]:
    """The files whose contents decide a generator's output: the script and its templates."""
    return [generator, *sorted(generator.parent.glob("*.cir"))]


def key(generator: Path, args: list[str]) -> str:
    """A run's key: SHA-256 of the generator's sources and its arguments (output paths apart)."""
    digest = hashlib.sha256()
    for path in sources(generator):
        digest.update(path.relative_to(REPO).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    digest.update(json.dumps(args).encode())
    return digest.hexdigest()[:20]


def generate(generator: Path, args: list[str], outputs: dict[str, Path], timeout: int = 900) -> None:
    """Run `generator` with `args`, its output files given as `{option: path}` (`--out`,
    `--truth`, `--capture`), from the record when there is one."""
    generator = generator.resolve()
    entry = STORE / key(generator, args)
    if entry.is_dir():
        for option, path in outputs.items():
            with gzip.open(entry / f"{option.lstrip('-')}.gz", "rb") as stored, open(path, "wb") as out:
                shutil.copyfileobj(stored, out)
        return
    if shutil.which("ngspice") is None:
        pytest.skip(f"ngspice is not installed and this run of {generator.name} is not recorded")
    if not RECORD:
        warnings.warn(f"{generator.name} {' '.join(args)}: not recorded, simulated live (see captures.py)", stacklevel=2)
    command = [sys.executable, str(generator), *args]
    for option, path in outputs.items():
        command += [option, str(path)]
    subprocess.run(command, check=True, capture_output=True, timeout=timeout)
    if RECORD:
        _store(entry, generator, args, outputs)


def _store(entry: Path, generator: Path, args: list[str], outputs: dict[str, Path]) -> None:
    """Write one run under `entry` (via a temporary name: pytest-xdist workers may race)."""
    staging = entry.with_name(entry.name + f".{os.getpid()}")
    staging.mkdir(parents=True, exist_ok=True)
    for option, path in outputs.items():
        with open(path, "rb") as out, gzip.GzipFile(staging / f"{option.lstrip('-')}.gz", "wb", mtime=0) as stored:
            shutil.copyfileobj(out, stored)
    ngspice = subprocess.run(["ngspice", "-v"], capture_output=True, text=True).stdout
    version = next((line.strip("* ") for line in ngspice.splitlines() if "ngspice-" in line), "unknown")
    manifest = {"generator": generator.relative_to(REPO).as_posix(), "args": args, "outputs": sorted(outputs),
                "ngspice": version}
    (staging / "run.json").write_text(json.dumps(manifest, indent=1) + "\n")
    try:
        staging.rename(entry)
    except OSError:  # another worker stored the same run first
        shutil.rmtree(staging)
