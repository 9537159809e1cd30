"""Recorded fix sequences (``tests/data/*.json``) replayed through a positioner, and the
check that the positions it reports follow one another by permitted moves."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

from antikol import VehicleReport
from antikol.positioning.matcher import Positioner

__all__ = ["assert_connected", "replay_recorded"]


def replay_recorded(net, name: str, vehicle_id: str, config=None) -> list:
    """The positions of a recorded fix sequence (``tests/data/<name>``), one by one, as
    placed (a recording starts the vehicle afresh: its first positions are shown later,
    see ``tests/test_showing.py``)."""
    data = json.loads((Path(__file__).parent / "data" / name).read_text())
    pos = Positioner(net, config)
    out = []
    for t, lat, lon, speed, course, odometer, quality in data["reports"]:
        report = VehicleReport(
            vehicle_id, t, lat, lon, speed, course, odometer_m=odometer, fix_quality=quality
        )
        shown = pos.update(report)
        placed = pos.placed_positions([vehicle_id])[0]
        assert shown == placed or (shown.unplaced and placed.hypotheses == shown.hypotheses)
        out.append(placed)
    return out


def assert_connected(net, positions: list) -> None:
    """Each position is reached from the one before within 60 m ahead, or 10 m behind."""
    for p, q in itertools.pairwise(positions):
        ahead = net.route_distance(
            p.edge_id, p.offset_m, p.direction, q.edge_id, q.offset_m, cutoff_m=60.0
        )
        back = net.route_distance(
            q.edge_id, q.offset_m, q.direction, p.edge_id, p.offset_m, cutoff_m=10.0
        )
        assert ahead is not None or back is not None, (p, q)
