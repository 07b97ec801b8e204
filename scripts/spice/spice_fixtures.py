#!/usr/bin/env python3
"""Small ngspice data sets for the tests: one CSV (the data contract) and its ``--truth``
sidecar per circuit (ideal, sync, async), committed under ``tests/fixtures/spice/``.

Tests call :func:`load`: with ``ngspice`` on PATH it runs the generator live with the same
settings (so the tests exercise the current netlists), without it it reads the committed
files (so the same checks still run on a machine without ngspice). ``test_fixtures_are_current``
(tests/python/test_ngspice.py) fails when a live run no longer reproduces the committed files.

Regenerate them after changing a netlist or ``buck_spice.py``:

    .venv/bin/python scripts/spice/spice_fixtures.py          # all three
    .venv/bin/python scripts/spice/spice_fixtures.py sync     # one
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import buck_spice  # noqa: E402

DIR = Path(__file__).resolve().parents[2] / "tests" / "fixtures" / "spice"

# The generator's command line per fixture. 500 PRBS periods (0.4/0.6, 8 per bit), Cl = 4.7 uF.
# ideal: no warm-up, so the run starts at the averaged DC point of the first duty exactly like
# the FMU (start_at_steady_state). sync/async: io = 2 A keeps the inductor current positive at
# both duty levels (CCM: the ripple's half-height is at most 1.4 A), 200 periods of warm-up.
COMMON = ["--periods", "500", "--cl", "4.7e-6", "--seed", "1"]
FIXTURES = {
    "ideal": ["--circuit", "ideal", *COMMON, "--io", "1"],
    "sync": ["--circuit", "sync", *COMMON, "--io", "2", "--warmup", "200"],
    "async": ["--circuit", "async", *COMMON, "--io", "2", "--warmup", "200"],
}


@dataclass
class Fixture:
    """One data set: metadata, columns, truth sidecar and where it came from."""

    circuit: str
    meta: dict[str, str]
    columns: dict[str, np.ndarray]
    header: list[str]
    truth: dict
    csv_text: str
    live: bool

    def num(self, key: str) -> float:
        return float(self.meta[key])


def have_ngspice() -> bool:
    return shutil.which("ngspice") is not None


def paths(circuit: str, directory: Path = DIR) -> tuple[Path, Path]:
    return directory / f"{circuit}.csv", directory / f"{circuit}.truth.json"


def generate(circuit: str, directory: Path = DIR) -> tuple[Path, Path]:
    """Runs the generator for one fixture into ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    csv, truth = paths(circuit, directory)
    buck_spice.main([*FIXTURES[circuit], "--out", str(csv), "--truth", str(truth)])
    return csv, truth


def parse(circuit: str, csv_text: str, truth_text: str, live: bool) -> Fixture:
    lines = csv_text.splitlines()
    meta = {}
    i = 0
    while lines[i].startswith("#"):
        key, value = lines[i][1:].split("=", 1)
        meta[key.strip()] = value.strip()
        i += 1
    header = lines[i].split(",")
    data = np.array([[float(x) for x in line.split(",")] for line in lines[i + 1:]])
    columns = {name: data[:, j] for j, name in enumerate(header)}
    return Fixture(circuit, meta, columns, header, json.loads(truth_text), csv_text, live)


@functools.lru_cache(maxsize=None)
def committed(circuit: str) -> Fixture:
    """The committed fixture."""
    csv, truth = paths(circuit)
    return parse(circuit, csv.read_text(), truth.read_text(), live=False)


@functools.lru_cache(maxsize=None)
def live(circuit: str) -> Fixture:
    """A fresh run of the generator with the fixture's settings (needs ngspice)."""
    with tempfile.TemporaryDirectory(prefix="spice_fixture_") as tmp:
        csv, truth = generate(circuit, Path(tmp))
        return parse(circuit, csv.read_text(), truth.read_text(), live=True)


def load(circuit: str) -> Fixture:
    """The live run when ngspice is on PATH, else the committed fixture."""
    return live(circuit) if have_ngspice() else committed(circuit)


def main(argv: list[str] | None = None) -> None:
    circuits = (argv if argv is not None else sys.argv[1:]) or list(FIXTURES)
    unknown = [c for c in circuits if c not in FIXTURES]
    if unknown:
        sys.exit(f"unknown fixture(s) {unknown}; known: {list(FIXTURES)}")
    for circuit in circuits:
        for path in generate(circuit):
            print(f"{path} ({path.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
