#!/usr/bin/env python3
"""Simulation speed, side by side in one run: 3001 switching periods of a PRBS duty (0.4/0.6,
8 periods per bit) in switched mode, Cl = 10 µF, by

  1. the Rust model in process (`trajectory` example; its own timer around the stepping loop),
  2. the FMU driven from Rust through our importer (`drive_fmu` example: set, doStep, get per period),
  3. the FMU driven from Python by fmpy (one setReal/doStep/getReal per period),
  4. ngspice on the same ideal-switch circuit (scripts/spice; wall time of the transient run).

Prints a Markdown table with the ratios against ngspice. Each figure is the best of `--repeat`
runs. Usage: .venv/bin/python scripts/bench_sim.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts" / "spice"))
sys.path.insert(0, str(REPO / "tests" / "python"))

import buck_spice  # noqa: E402
from fmpy import extract, read_model_description  # noqa: E402
from fmu_harness import SWITCHED, drive, open_slave  # noqa: E402

PERIODS, CL, IO = 3001, 10e-6, 1.0


def build() -> tuple[Path, Path]:
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "buck-model", "--example", "trajectory"],
                   cwd=REPO, check=True)
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "estimator", "--example", "drive_fmu"],
                   cwd=REPO, check=True)
    fmu = subprocess.run(["cargo", "xtask", "fmu"], cwd=REPO, check=True, capture_output=True, text=True)
    return REPO / "target" / "release" / "examples" / "trajectory", Path(fmu.stdout.strip().splitlines()[-1])


def in_process(binary: Path, duty) -> float:
    text = "\n".join(f"{d}" for d in duty)
    proc = subprocess.run([str(binary), "switched", str(CL), str(IO)], input=text, capture_output=True,
                          text=True, check=True)
    return float(re.search(r"in ([0-9.]+) ms", proc.stderr).group(1)) / 1e3


def through_rust_importer(fmu: Path, duty) -> float:
    text = "\n".join(f"{d}" for d in duty)
    proc = subprocess.run([str(REPO / "target" / "release" / "examples" / "drive_fmu"), str(fmu), f"Cl={CL}", "mode=2"],
                          input=text, capture_output=True, text=True, check=True)
    return float(re.search(r"in ([0-9.]+) ms", proc.stderr).group(1)) / 1e3


def through_fmpy(fmu: Path, duty) -> float:
    md, folder = read_model_description(str(fmu)), extract(str(fmu))
    with open_slave(folder, md, "bench", start={"mode": SWITCHED, "Cl": CL, "io": IO, "duty": float(duty[0])}) as s:
        t0 = time.perf_counter()
        drive(s, md, duty)
        return time.perf_counter() - t0


def ngspice(duty) -> float:
    t0 = time.perf_counter()
    buck_spice.simulate(duty, Cl=CL, io=IO)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    binary, fmu = build()
    duty = buck_spice.prbs_duty(PERIODS, bit_periods=8, low=0.4, high=0.6, seed=1)
    best = lambda f: min(f() for _ in range(args.repeat))  # noqa: E731
    rows = [
        ("Rust model, in process", best(lambda: in_process(binary, duty))),
        ("FMU from our Rust importer (loop per period)", best(lambda: through_rust_importer(fmu, duty))),
        ("FMU from fmpy (Python loop per period)", best(lambda: through_fmpy(fmu, duty))),
        ("ngspice 39, ideal switch (T/100 max step)", best(lambda: ngspice(duty))),
    ]
    spice = rows[-1][1]
    print(f"3001 switched periods, Cl = {CL * 1e6:g} µF, best of {args.repeat}\n")
    print("| simulator | wall time | ngspice / this |")
    print("|---|---:|---:|")
    for name, t in rows:
        print(f"| {name} | {t * 1e3:.3f} ms | {spice / t:,.0f}× |")


if __name__ == "__main__":
    main()
