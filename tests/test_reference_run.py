"""Speed never buys a different warning: a recorded run replays to the same assessments."""

from __future__ import annotations

from pathlib import Path

from tests._reference import load, replay

RECORDING = Path(__file__).parent / "data" / "reference_run.json"


def test_the_recorded_run_replays_to_identical_assessments():
    reports, expected = load(RECORDING)
    got = replay(reports)
    assert got.keys() == expected.keys()
    differ = [k for k in expected if got[k] != expected[k]]
    assert not differ, f"{len(differ)} assessments differ, first {differ[0]}: " + (
        f"{got[differ[0]]} != {expected[differ[0]]}"
    )
