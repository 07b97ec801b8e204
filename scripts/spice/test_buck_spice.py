"""Analytic sanity checks of the ngspice ideal-switch buck (constant duty)."""

import os
import shutil
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import buck_spice  # noqa: E402

L, FS, U, IO, RL, D = 3.3e-6, 330e3, 12.0, 1.0, 0.1, 0.5
N, TAIL = 300, 50  # the start-up transient has decayed below 1e-7 V by period 160


@pytest.fixture(scope="module")
def settled():
    if shutil.which("ngspice") is None:
        pytest.skip("ngspice not on PATH")
    r = buck_spice.simulate(np.full(N, D), L=L, RL=RL, fs=FS, U=U, io=IO)
    return {k: v[-TAIL:] for k, v in r.items()}


def test_period_averages_match_dc_steady_state(settled):
    assert np.max(np.abs(settled["vout_avg"] - (D * U - RL * IO))) < 1e-3
    assert np.max(np.abs(settled["il_avg"] - IO)) < 1e-3


def test_period_start_current_is_ripple_valley(settled):
    # Trailing-edge PWM: period start = end of off-time = current minimum.
    # The textbook valley neglects the RL drop and output ripple (~6 mA here).
    valley = IO - U * D * (1 - D) / (2 * L * FS)
    assert np.max(np.abs(settled["il_start"] - valley)) < 0.02
