"""Per-vehicle track positions on disk, and served back to the pairwise analysis.

The positioning stage writes one Parquet file per vehicle and day with one row per
analysis cycle the vehicle is in the vehicle table: every field of
:class:`~antikol.positioning.records.TrackPosition`, the cycle index ``k`` (the cycle ends
at ``k * cycle_s``) and the hypotheses as JSON (Python writes floats in their shortest
round-tripping form, so they read back bit for bit). :class:`StoredPositions` serves them
to an :class:`~antikol.analysis.analyser.Analyser` through its ``position_source`` hook.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, cast

from antikol.kinds import PositionStatus
from antikol.positioning.records import Hypothesis, TrackPosition
from antikol.report import VehicleReport

__all__ = [
    "POSITION_COLUMNS",
    "CycleRecord",
    "Memory",
    "StoredPositions",
    "cycle_index",
    "read_positions",
    "write_positions",
]

#: Columns of a positions file.
POSITION_COLUMNS: tuple[str, ...] = (
    "vehicle_id",
    "k",
    "t",
    "status",
    "edge_id",
    "direction",
    "offset_m",
    "lon",
    "lat",
    "heading_deg",
    "speed_mps",
    "probability",
    "sigma_m",
    "wrong_way",
    "dead_reckoned_s",
    "hypotheses",
    "track_course_deg",
    "track_moving",
    "sector_course_deg",
    "sector_moving",
)

#: What an analyser remembers of a vehicle beyond its newest report (course kept from
#: before it stopped, deg; moving or standing), see ``Analyser.memory``.
Memory = tuple[float | None, bool | None]


def cycle_index(t: float, cycle_s: float) -> int:
    """The analysis cycle a time belongs to: ``k`` with ``(k-1)·cycle_s < t <= k·cycle_s``
    (exactly as :func:`antikol.evaluation.replay.cycles` groups reports)."""
    return math.ceil(t / cycle_s - 1e-9)


@dataclass(frozen=True, slots=True)
class CycleRecord:
    """One vehicle at the end of one analysis cycle, as the positioning stage saw it.

    Attributes
    ----------
    vehicle_id : str
    k : int
        The cycle (it ends at ``k * cycle_s``).
    position : TrackPosition or None
        None without a map.
    track, sector : Memory
        The memory of the track-aware analyser and of the sector rule's (``(None,
        None)`` when that analyser has dropped the vehicle).
    """

    vehicle_id: str
    k: int
    position: TrackPosition | None
    track: Memory
    sector: Memory


def write_positions(rows: Sequence[CycleRecord], path: str | os.PathLike[str]) -> int:
    """Write cycle records to a Parquet file; returns the rows written."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    cols: dict[str, list[Any]] = {c: [] for c in POSITION_COLUMNS}
    for rec in rows:
        p = rec.position
        cols["vehicle_id"].append(rec.vehicle_id)
        cols["k"].append(rec.k)
        cols["track_course_deg"].append(rec.track[0])
        cols["track_moving"].append(rec.track[1])
        cols["sector_course_deg"].append(rec.sector[0])
        cols["sector_moving"].append(rec.sector[1])
        for c in POSITION_COLUMNS[2:16]:
            if p is None:
                cols[c].append(None)
            elif c == "hypotheses":
                cols[c].append(json.dumps([list(_hyp_tuple(h)) for h in p.hypotheses]))
            else:
                cols[c].append(getattr(p, c))
    schema = pa.schema(
        [
            ("vehicle_id", pa.string()),
            ("k", pa.int64()),
            ("t", pa.float64()),
            ("status", pa.string()),
            ("edge_id", pa.int64()),
            ("direction", pa.int8()),
            ("offset_m", pa.float64()),
            ("lon", pa.float64()),
            ("lat", pa.float64()),
            ("heading_deg", pa.float64()),
            ("speed_mps", pa.float64()),
            ("probability", pa.float64()),
            ("sigma_m", pa.float64()),
            ("wrong_way", pa.bool_()),
            ("dead_reckoned_s", pa.float64()),
            ("hypotheses", pa.string()),
            ("track_course_deg", pa.float64()),
            ("track_moving", pa.bool_()),
            ("sector_course_deg", pa.float64()),
            ("sector_moving", pa.bool_()),
        ]
    )
    pq.write_table(pa.table(cols, schema=schema), path)
    return len(rows)


def _hyp_tuple(h: Hypothesis) -> tuple[Any, ...]:
    return (
        h.edge_id,
        h.direction,
        h.offset_m,
        h.probability,
        h.progress_m,
        h.wrong_way,
        h.wrong_way_s,
    )


def read_positions(
    paths: Iterable[str | os.PathLike[str]], *, k_range: tuple[int, int] | None = None
) -> dict[tuple[str, int], CycleRecord]:
    """Cycle records from files, keyed by ``(vehicle_id, k)``; ``k_range`` keeps
    ``lo <= k < hi``."""
    import pyarrow.parquet as pq

    filters = None if k_range is None else [("k", ">=", k_range[0]), ("k", "<", k_range[1])]
    out: dict[tuple[str, int], CycleRecord] = {}
    for path in paths:
        data = pq.read_table(path, filters=filters).to_pydict()
        for i in range(len(data["k"])):
            vid, k = data["vehicle_id"][i], int(data["k"][i])
            track = (data["track_course_deg"][i], data["track_moving"][i])
            sector = (data["sector_course_deg"][i], data["sector_moving"][i])
            if data["status"][i] is None:
                out[(vid, k)] = CycleRecord(vid, k, None, track, sector)
                continue
            hyps = tuple(
                Hypothesis(int(e), int(d), o, p, g, bool(w), ws)
                for e, d, o, p, g, w, ws in json.loads(data["hypotheses"][i])
            )
            edge = data["edge_id"][i]
            direction = data["direction"][i]
            pos = TrackPosition(
                vehicle_id=data["vehicle_id"][i],
                t=data["t"][i],
                status=cast(PositionStatus, data["status"][i]),
                edge_id=None if edge is None else int(edge),
                direction=None if direction is None else int(direction),
                offset_m=data["offset_m"][i],
                lon=data["lon"][i],
                lat=data["lat"][i],
                heading_deg=data["heading_deg"][i],
                speed_mps=data["speed_mps"][i],
                probability=data["probability"][i],
                sigma_m=data["sigma_m"][i],
                wrong_way=bool(data["wrong_way"][i]),
                hypotheses=hyps,
                dead_reckoned_s=data["dead_reckoned_s"][i],
            )
            out[(vid, k)] = CycleRecord(vid, k, pos, track, sector)
    return out


class StoredPositions:
    """A :class:`~antikol.positioning.records.PositionSource` that serves stored positions.

    Parameters
    ----------
    positions : dict
        ``(vehicle_id, k)`` to the record at the end of cycle ``k``.
    cycle_s : float
        Analysis period, s.

    Notes
    -----
    The analyser asks for positions only at cycle ends where the vehicle is in its table;
    a position that is not stored is a bug of the partitioning, never silently
    replaced: :meth:`position` raises ``LookupError`` naming the vehicle and time.
    """

    def __init__(self, positions: dict[tuple[str, int], CycleRecord], cycle_s: float) -> None:
        self._positions = positions
        self.cycle_s = float(cycle_s)

    def update_many(
        self, reports: Sequence[VehicleReport], *, outputs: bool = True
    ) -> list[TrackPosition]:
        """Nothing to fuse: the positions were computed by the positioning stage."""
        return []

    def position(self, vehicle_id: str, t: float | None = None) -> TrackPosition | None:
        """The stored position of a vehicle at a cycle end ``t``, s."""
        if t is None:
            raise LookupError(f"stored positions are served by time only ({vehicle_id})")
        k = round(float(t) / self.cycle_s)
        rec = self._positions.get((vehicle_id, k))
        if rec is None or rec.position is None:
            raise LookupError(f"no stored position of {vehicle_id!r} at t={t} s (cycle {k})")
        return rec.position

    def positions(
        self, vehicle_ids: Sequence[str], t: float | None = None
    ) -> list[TrackPosition | None]:
        """:meth:`position` of many vehicles."""
        return [self.position(vid, t) for vid in vehicle_ids]

    def forget(self, vehicle_id: str) -> None:
        """Nothing to forget: stored positions have no state."""
