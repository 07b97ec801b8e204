"""The recorded ngspice captures (`captures.py`) are those the generators make today."""

from __future__ import annotations

import json

from captures import REPO, STORE, key


def test_every_recorded_capture_matches_its_generators_sources():
    entries = sorted(path for path in STORE.iterdir() if path.is_dir())
    assert entries, f"no recorded captures under {STORE}"
    stale = []
    for entry in entries:
        run = json.loads((entry / "run.json").read_text())
        for option in run["outputs"]:
            assert (entry / f"{option.lstrip('-')}.gz").is_file(), (entry.name, option)
        if key(REPO / run["generator"], run["args"]) != entry.name:
            stale.append(f"{entry.name}: {run['generator']} {' '.join(run['args'])}")
    assert not stale, ("recorded before their generator changed; record them again "
                       "(BUCKID_RECORD_CAPTURES=1, see tests/python/captures.py):\n" + "\n".join(stale))
