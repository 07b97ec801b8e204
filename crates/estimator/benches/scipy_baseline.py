#!/usr/bin/env python3
"""Baseline for the speed benchmark: the same grey-box fit with scipy.

Same data (the CSV the Rust bench writes), same model (averaged third-order buck, exact ZOH
discretization at T), same unknowns (ln Cl and the initial state), same output-error
criterion on `vout`, same start (Cl = 10 µF nominal, initial state from the first duty's DC
point); `least_squares` uses its default trust-region solver with a finite-difference
Jacobian. Two simulators:

- `lfilter` (default): written to be fast, not to lose — the discretized model's transfer
  functions run in `scipy.signal.lfilter`'s C loops;
- `dlsim`: the textbook call, `scipy.signal.dlsim` on the discrete state space.

Prints one JSON line: {"cl": estimate, "seconds": best wall time, "nfev": evaluations}.
Usage: python scipy_baseline.py DATA.csv [--simulator lfilter|dlsim] [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.signal

L, RL, C, RC = 3.3e-6, 0.1, 100e-6, 0.1


def read(path: str):
    meta, rows, header = {}, [], None
    for line in open(path):
        if line.startswith("#"):
            key, _, value = line[1:].partition("=")
            meta[key.strip()] = value.strip()
        elif header is None:
            header = line.strip().split(",")
        else:
            rows.append([float(x) for x in line.split(",")])
    data = np.array(rows)
    col = {name: data[:, i] for i, name in enumerate(header)}
    return col, float(meta["fs"])


def discretize(cl: float, t: float):
    a = np.array([[-RL / L, 0, -1 / L], [0, -1 / (RC * C), 1 / (RC * C)],
                  [1 / cl, 1 / (RC * cl), -1 / (RC * cl)]])
    b = np.array([[1 / L, 0], [0, 0], [0, -1 / cl]])
    m = np.zeros((5, 5))
    m[:3, :3], m[:3, 3:] = a, b
    e = scipy.linalg.expm(m * t)
    return e[:3, :3], e[:3, 3:]


def simulate(theta, u, t):
    """vout[k] = C·x[k] of x[k+1] = Ad·x[k] + Bd·u[k], x[0] = theta[1:4]."""
    ad, bd = discretize(np.exp(theta[0]), t)
    c = np.array([[0.0, 0.0, 1.0]])
    n = u.shape[0]
    y = np.zeros(n)
    for j in range(2):
        num, den = scipy.signal.ss2tf(ad, bd[:, [j]], c, np.zeros((1, 1)))
        y += scipy.signal.lfilter(num[0], den, u[:, j])
    # Free response C·Ad^k·x0: the impulse response of (Ad, x0, C) shifted by one sample.
    num, den = scipy.signal.ss2tf(ad, theta[1:4].reshape(3, 1), c, np.zeros((1, 1)))
    impulse = np.zeros(n + 1)
    impulse[0] = 1.0
    y += scipy.signal.lfilter(num[0], den, impulse)[1:]
    return y


def simulate_dlsim(theta, u, t):
    """The same output with `scipy.signal.dlsim` on the discrete state space."""
    ad, bd = discretize(np.exp(theta[0]), t)
    c = np.array([[0.0, 0.0, 1.0]])
    _, y, _ = scipy.signal.dlsim((ad, bd, c, np.zeros((1, 2)), t), u, x0=theta[1:4])
    return y[:, 0]


def fit(col, fs, simulator):
    t = 1.0 / fs
    u = np.column_stack([col["duty"] * col["vin"], col["io"]])
    y = col["vout"]
    vo0 = col["duty"][0] * col["vin"][0] - RL * col["io"][0]
    theta0 = np.array([np.log(10e-6), col["io"][0], vo0, vo0])
    sim = simulate if simulator == "lfilter" else simulate_dlsim
    res = scipy.optimize.least_squares(lambda th: sim(th, u, t) - y, theta0, x_scale=[1.0, 1.0, 0.1, 0.1])
    return np.exp(res.x[0]), res.nfev


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--simulator", choices=["lfilter", "dlsim"], default="lfilter")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    col, fs = read(args.csv)
    best, cl, nfev = float("inf"), None, None
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        cl, nfev = fit(col, fs, args.simulator)
        best = min(best, time.perf_counter() - t0)
    print(json.dumps({"cl": cl, "seconds": best, "nfev": nfev}))


if __name__ == "__main__":
    main()
