"""Shared harness of the fmpy-based tests: circuit constants, a logger that records messages per
instance, an `FMU2Slave` context manager, period-by-period driving, a PRBS, and the independent
exact reference (scipy `expm`)."""

from __future__ import annotations

import contextlib
import ctypes
from pathlib import Path

import numpy as np
import scipy.linalg
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

OUTPUTS = ("vout", "il", "vc", "vout_avg", "il_avg")
AVERAGED, SWITCHED = 1, 2

# Circuit defaults of the modelDescription (checked against it in `test_start_values_are_the_documented_ones`).
L, RL, C, RC, FS, U = 3.3e-6, 0.1, 100e-6, 0.1, 330e3, 12.0
T = 1.0 / FS  # the same double as the FMU's `1/fs`

# ---- Logger: one native callback struct for the whole session --------------------------------
# fmpy's native proxy formats the variadic message and hands it to this Python function; messages
# are kept with their instance name so that each test looks only at its own instance.
LOG: list[tuple[str, int, str, str]] = []


def _log(_env, instance_name: bytes, status: int, category: bytes, message: bytes) -> None:
    LOG.append((instance_name.decode(), status, category.decode(), message.decode()))


def _callbacks() -> fmi2CallbackFunctions:
    from fmpy import calloc, free
    from fmpy.logging import addLoggerProxy

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(_log)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(ctypes.byref(cb))
    return cb


CALLBACKS = _callbacks()


def messages(instance: str) -> list[str]:
    return [m for name, _, _, m in LOG if name == instance]


# ---- Harness -----------------------------------------------------------------------------------
def set_values(fmu: FMU2Slave, md, values: dict) -> None:
    """Sets variables by name with the setter of their declared type."""
    by_name = {v.name: v for v in md.modelVariables}
    for name, value in values.items():
        var = by_name[name]
        if var.type == "Real":
            fmu.setReal([var.valueReference], [value])
        elif var.type in ("Integer", "Enumeration"):
            fmu.setInteger([var.valueReference], [value])
        elif var.type == "Boolean":
            fmu.setBoolean([var.valueReference], [value])
        else:
            raise AssertionError(f"unexpected type {var.type} of {name}")


def vr(md, name: str) -> int:
    return next(v.valueReference for v in md.modelVariables if v.name == name)


@contextlib.contextmanager
def open_slave(fmu_dir: Path, md, name: str, start: dict | None = None, initialize: bool = True,
               guid: str | None = None):
    """An FMU2Slave instance with our logger, `start` values set before initialization and
    (optionally) initialized at t = 0; freed (library unloaded) on exit."""
    fmu = FMU2Slave(guid=guid or md.guid, unzipDirectory=str(fmu_dir),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    try:
        fmu.instantiate(callbacks=CALLBACKS)
    except Exception:
        fmu.freeLibrary()
        raise
    try:
        if start:
            set_values(fmu, md, start)
        if initialize:
            initialize_slave(fmu)
        yield fmu
    finally:
        fmu.freeInstance()


def initialize_slave(fmu: FMU2Slave) -> None:
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()


def period(fmu: FMU2Slave, md, k: int, duty: float, steps=(1.0,)) -> list[float]:
    """Switching period number `k` (from t = k·T): sets `duty`, does one fmi2DoStep per fraction
    of T in `steps` (they sum to 1) and returns the outputs at the period end."""
    vrs = [vr(md, n) for n in OUTPUTS]
    fmu.setReal([vr(md, "duty")], [duty])
    t, acc = k * T, 0.0
    for frac in steps:
        fmu.doStep(t + acc * T, frac * T)
        acc += frac
    return fmu.getReal(vrs)


def drive(fmu: FMU2Slave, md, duties, steps=(1.0,), k0: int = 0) -> np.ndarray:
    """Runs one period per duty from period `k0` on; rows are `OUTPUTS` at each period end."""
    return np.array([period(fmu, md, k0 + k, d, steps) for k, d in enumerate(duties)])


def prbs_duty(n_periods: int, lo=0.4, hi=0.6, periods_per_bit=8, seed=0x5A) -> np.ndarray:
    """PRBS7 (x^7 + x^6 + 1) between two duty levels, each bit held `periods_per_bit` periods."""
    state, bits = seed & 0x7F or 1, []
    while len(bits) * periods_per_bit < n_periods:
        new = ((state >> 6) ^ (state >> 5)) & 1
        state = ((state << 1) | new) & 0x7F
        bits.append(new)
    return np.repeat(np.where(np.array(bits) == 1, hi, lo), periods_per_bit)[:n_periods]


# ---- Independent reference: exact piecewise solution with scipy.linalg.expm -------------------
def reference(duties, cl: float, io: float, mode: int) -> np.ndarray:
    """Exact solution of the three-state circuit over each period, with the state integral.

    Per held-input piece of length τ, `exp(M·τ)` of the generator of `[x; ∫x; u]` (Van Loan)
    advances the state and its integral exactly; switched mode has an on-piece `d·T` with
    `u_sw = U` and an off-piece `(1−d)·T` with `u_sw = 0`, averaged mode one piece `T` with
    `u_sw = d·U`. The start is the averaged DC point of the first duty, like the FMU's default
    `start_at_steady_state = true`."""
    A = np.array([[-RL / L, 0, -1 / L], [0, -1 / (RC * C), 1 / (RC * C)],
                  [1 / cl, 1 / (RC * cl), -1 / (RC * cl)]])
    B = np.array([[1 / L, 0], [0, 0], [0, -1 / cl]])
    M = np.zeros((8, 8))
    M[:3, :3], M[:3, 6:], M[3:6, :3] = A, B, np.eye(3)
    pieces = {}

    def advance(xi, tau, u_sw):
        if tau not in pieces:
            pieces[tau] = scipy.linalg.expm(M * tau)[:6]
        return pieces[tau] @ np.concatenate([xi, [u_sw, io]])

    vo0 = duties[0] * U - RL * io
    x, rows = np.array([io, vo0, vo0]), []
    for d in duties:
        xi = np.concatenate([x, np.zeros(3)])
        if mode == SWITCHED:
            xi = advance(advance(xi, d * T, U), T - d * T, 0.0)
        else:
            xi = advance(xi, T, d * U)
        x, avg = xi[:3], xi[3:] / T
        rows.append([x[2], x[0], x[1], avg[2], avg[0]])
    return np.array(rows)


