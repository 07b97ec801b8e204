"""The BuckConverter FMU run by the OSP libcosim C++ master (libcosimpy).

libcosim crashes the process (instead of raising) on some errors, so the co-simulation runs in a
child interpreter: this very file executed as a script (`main()` below); only that child ever
imports libcosimpy. It prints one JSON object on its last stdout line.

libcosim (as bundled with libcosimpy 0.0.6) ignores FMI 2.0 Enumeration variables, which is why
the FMU declares `mode` as an Integer (1 = averaged, 2 = switched). Both modes run here; in
periodic steady state the exact switched period average equals the averaged DC point, so both
have the same analytic target.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

STEP_NS = 3030  # ≈ T = 1/330 kHz = 3030.30 ns; the FMU is exact for any step length
STOP_NS = 3_000_000  # 3 ms ≈ 90 time constants of the slowest pole (~33 µs)
U, RL = 12.0, 0.1


def main(fmu: str, duty: float, io: float, mode: int) -> None:
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.ERROR)
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    execution = CosimExecution.from_step_size(STEP_NS)
    slave = CosimLocalSlave(fmu_path=fmu, instance_name="buck")
    index = execution.add_local_slave(slave)
    refs = {v.name.decode(): v.reference for v in execution.slave_variables(index)}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)

    out: dict = {}
    out["set"] = [
        execution.integer_initial_value(index, refs["mode"], mode),
        execution.real_initial_value(index, refs["duty"], duty),
        execution.real_initial_value(index, refs["io"], io),
        execution.real_initial_value(index, refs["vin"], U),
        execution.boolean_initial_value(index, refs["start_at_steady_state"], False),
    ]
    out["first_step_ok"] = execution.step(1)
    out["vout_first_step"] = observer.last_real_values(index, [refs["vout"]])[0]
    out["ok"] = execution.simulate_until(STOP_NS)
    out["vout_avg"], out["il_avg"] = observer.last_real_values(index, [refs["vout_avg"], refs["il_avg"]])
    out["mode"] = observer.last_integer_values(index, [refs["mode"]])[0]
    print(json.dumps(out))


@pytest.mark.parametrize("duty, io, mode", [(0.5, 1.0, 1), (0.45, 2.0, 2)])
def test_libcosim_runs_fmu_to_dc_point(fmu_path, duty, io, mode):
    """libcosim loads the FMU, starts it from zero (start_at_steady_state=False: after one step
    vout is still far from the target) and after 3 ms `vout_avg` is the analytic DC point
    d·U − RL·io within 5 mV and `il_avg` is io within 5 mA (duty 0.5, io 1 → 5.9 V; duty 0.45,
    io 2 → 5.2 V, so the start values really go through libcosim)."""
    proc = subprocess.run(
        [sys.executable, __file__, str(fmu_path), repr(duty), repr(io), str(mode)],
        capture_output=True, text=True, timeout=120, check=False,
    )
    assert proc.returncode == 0, f"libcosim child exited with {proc.returncode}:\n{proc.stderr[-4000:]}"
    lines = proc.stdout.strip().splitlines()
    assert lines, f"no output from the libcosim child:\n{proc.stderr[-4000:]}"
    out = json.loads(lines[-1])
    assert out["set"] == [True] * 5, out
    assert out["first_step_ok"] and out["ok"], out
    assert out["mode"] == mode, f"libcosim did not pass mode={mode} to the FMU: {out}"
    expected = duty * U - RL * io
    assert abs(out["vout_first_step"]) < 0.5 * expected, f"did not start from zero: {out}"
    assert abs(out["vout_avg"] - expected) < 5e-3, out
    assert abs(out["il_avg"] - io) < 5e-3, out


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]))
