"""Speed never buys a different warning: a recorded run replays to the same assessments."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests._reference import load, replay, replay_on_board

RECORDING = Path(__file__).parent / "data" / "reference_run.json"


@pytest.mark.parametrize("with_map", [True, False], ids=["track", "sector"])
def test_the_recorded_run_replays_to_identical_assessments(with_map):
    reports, expected = load(RECORDING, "assessments" if with_map else "sector_assessments")
    got = replay(reports, with_map=with_map)
    assert got.keys() == expected.keys()
    differ = [k for k in expected if got[k] != expected[k]]
    assert not differ, f"{len(differ)} assessments differ, first {differ[0]}: " + (
        f"{got[differ[0]]} != {expected[differ[0]]}"
    )


@pytest.mark.parametrize("own_id", ["T15", "T21", "T27", "T13"])
def test_an_on_board_unit_assesses_its_vehicle_as_the_control_room_does(own_id):
    # on board only the own vehicle's reach is walked: the assessments must not change
    reports, expected = load(RECORDING)
    got = replay_on_board(reports, own_id)
    assert got, f"{own_id} never reported"
    differ = [k for k in got if got[k] != expected[k]]
    assert not differ, f"{len(differ)} of {len(got)} differ, first {differ[0]}: " + (
        f"{got[differ[0]]} != {expected[differ[0]]}"
    )
