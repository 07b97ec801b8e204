"""Builds BuckQ.fmu with qfmu: the averaged buck converter as a plain-C state-space FMU, a blind
target for `buckid identify` with its load capacitance baked into the matrices.

Run with the interpreter of qfmu's own venv (tests/thirdparty/build.sh does):

    python build_buckq.py OUT_DIR

What qfmu (0.2.9) generates, read from its sources (qfmu/codegen/templates/fmi2model.jinja and
include/fmi2Template.c):
- only continuous-time models dx/dt = A·x + B·u, y = C·x + D·u;
- its "Euler integrator with step dt" evaluates the derivative ONCE per fmi2DoStep and then adds
  min(dt, rest)·der until the step is used up, so whatever dt is, every doStep of length h is one
  forward-Euler step x += h·(A·x + B·u);
- inputs are u1..un, outputs y1..ym, states x1..xn (locals), with parameters x<i>_start and
  u<j>_start; fmi2ExitInitializationMode copies the *_start values into x and u, so inputs set
  before it are replaced by u<j>_start (set those, not u<j>, to change the start inputs);
- one static instance per shared library (`static ModelInstance instance`): a second instance in
  the same process aliases the first; canHandleVariableCommunicationStepSize="false".

A forward-Euler step of the real converter at h = 1/fs = 3.03 µs is unstable (the fast mode
Rc·Cl = 0.22 µs), so the continuous matrices would be a poor target. Instead we exploit the
one-Euler-step-per-doStep structure: with Aq = (Ad - I)/T and Bq = Bd/T, where (Ad, Bd) is the
exact zero-order-hold discretization at T = 1/fs, one doStep of length T gives
x += T·(Aq·x + Bq·u) = Ad·x + Bd·u, the exact averaged model sampled once per period. This holds
only for doStep(h = T), which is how the CLI (one doStep per switching period at 330 kHz) and
canHandleVariableCommunicationStepSize="false" drive it. (A step h ≠ T applies the same
increment scaled by h/T: for h < T a stable interpolation, not the physics.)

Inputs u1 = duty (0..1; its B column is scaled by U = 12 V, the fixed input voltage) and
u2 = io [A]; outputs y1 = vout (= vo, across Cl) and y2 = il. The start state is the DC point
of u1 = 0.5, u2 = 1 A: il = 1, vc = vo = 0.5·12 - RL·1 = 5.9 V (equal to the fixed point of
the discretized model, since (I - Ad)⁻¹·Bd = -A⁻¹·B).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.linalg

from qfmu.model import StateSpace
from qfmu.utils import build_fmu

L, RL, C, RC, FS, U = 3.3e-6, 0.1, 100e-6, 0.1, 330e3, 12.0
CL = 2.2e-6  # hidden: the blind target of the identification
T = 1.0 / FS
IDENTIFIER = "BuckQ"
DUTY0, IO0 = 0.5, 1.0


def continuous():
    """(A, B) with states (il, vc, vo) and inputs (duty, io); the duty column carries U."""
    a = np.array([
        [-RL / L, 0.0, -1.0 / L],
        [0.0, -1.0 / (RC * C), 1.0 / (RC * C)],
        [1.0 / CL, 1.0 / (RC * CL), -1.0 / (RC * CL)],
    ])
    b = np.array([
        [U / L, 0.0],
        [0.0, 0.0],
        [0.0, -1.0 / CL],
    ])
    return a, b


def zoh(a, b, h):
    n, m = b.shape
    aug = np.zeros((n + m, n + m))
    aug[:n, :n] = a * h
    aug[:n, n:] = b * h
    e = scipy.linalg.expm(aug)
    return e[:n, :n], e[:n, n:]


def main() -> int:
    out_dir = Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    a, b = continuous()
    ad, bd = zoh(a, b, T)
    aq = (ad - np.eye(3)) / T
    bq = bd / T
    c = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    d = np.zeros((2, 2))
    vo0 = DUTY0 * U - RL * IO0
    x0 = np.array([IO0, vo0, vo0])
    u0 = np.array([DUTY0, IO0])

    # The DC point must be a fixed point of the one-Euler-step-per-period update.
    drift = aq @ x0 + bq @ u0
    assert np.max(np.abs(drift * T)) < 1e-9, drift

    # qfmu writes the matrices into C with np.array2string, i.e. with numpy's print options
    # (8 significant digits by default): print the shortest round-trip repr instead.
    np.set_printoptions(precision=17, floatmode="unique", linewidth=1_000_000)

    model = StateSpace(aq, bq, c, d, x0, u0)
    # qfmu zips into the working directory and compiles in a temp dir: work in a scratch folder.
    with tempfile.TemporaryDirectory(prefix="qfmu_") as scratch:
        cwd = os.getcwd()
        os.chdir(scratch)
        try:
            build_fmu(model, out_dir / f"{IDENTIFIER}.fmu", identifier=IDENTIFIER, dt=T)
        finally:
            os.chdir(cwd)
    path = out_dir / f"{IDENTIFIER}.fmu"
    if not path.is_file():
        print(f"qfmu did not write {path}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
