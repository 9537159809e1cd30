"""HSL-style HFP writer: vehicle reports as ``{"VP": {...}}`` JSON lines.

For the simulator's logs (``antikol simulate --hfp FILE``) and tests; :mod:`antikol.ingest.hfp`
reads them back. The fields are those an operator's feed carries, at its resolution:
``tst`` (ISO 8601 UTC to the millisecond), ``lat`` and ``long`` to 1e-6 degree (0.1 m),
``spd`` to 0.01 m/s, ``hdg`` in whole degrees, ``odo`` in whole metres (null without an
odometer) and ``loc``: ``GPS`` for a fix, ``DR`` for the sender's own estimate
(``fix_quality`` 6) and ``N/A`` with null ``lat`` and ``long`` for a report without a
fix, as the feed sends it.

The vehicle's number (``veh``) is the number its id ends with (``T07``: 7) when every
vehicle's id ends with a different one, else its place in the sorted ids (from 1);
:func:`hfp_vehicle_numbers` gives the mapping. The reader keys vehicles as
``"<oper>/<veh>"``.

>>> from antikol.report import VehicleReport
>>> r = VehicleReport("T07", 1_702_540_801.25, 50.0612345, 19.9401234, 8.216, 91.4,
...                   odometer_m=1234.56)
>>> hfp_message(r, vehicle_number=7)["VP"]["tst"], hfp_message(r, vehicle_number=7)["VP"]["hdg"]
('2023-12-14T08:00:01.250Z', 91)
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Final

from antikol.report import VehicleReport

__all__ = ["hfp_message", "hfp_vehicle_numbers", "write_hfp"]

#: Operator number written as ``oper`` (HSL's tram operator is 40).
DEFAULT_OPERATOR: Final = 40
_NO_FIX: Final = 0
_ESTIMATE: Final = 6
_TRAILING_NUMBER: Final = re.compile(r"(\d+)$")


def hfp_vehicle_numbers(vehicle_ids: Iterable[str]) -> dict[str, int]:
    """Each vehicle id's HFP vehicle number: the number the id ends with when those are
    distinct for all ids, else its place in the sorted ids (from 1)."""
    ids = sorted(set(vehicle_ids))
    found = [_TRAILING_NUMBER.search(v) for v in ids]
    numbers = [int(m.group(1)) if m else None for m in found]
    if all(n is not None for n in numbers) and len(set(numbers)) == len(numbers):
        return {v: int(n) for v, n in zip(ids, numbers, strict=True) if n is not None}
    return {v: k for k, v in enumerate(ids, start=1)}


def hfp_message(
    report: VehicleReport,
    *,
    vehicle_number: int,
    operator: int = DEFAULT_OPERATOR,
    epoch_utc_s: float = 0.0,
) -> dict[str, Any]:
    """One vehicle-position message, ``{"VP": {...}}``.

    Parameters
    ----------
    report : VehicleReport
        Its time ``t`` is seconds after ``epoch_utc_s``; position in degrees, speed in
        m/s, course in degrees from north, odometer in metres.
    vehicle_number : int, keyword-only
        ``veh``.
    operator : int, keyword-only
        ``oper`` (default 40).
    epoch_utc_s : float, keyword-only
        Unix time of ``t = 0``, s.

    Returns
    -------
    dict
        JSON-ready; see the module for the fields and their resolution.
    """
    millis = round((report.t + epoch_utc_s) * 1000.0)
    stamp = datetime.fromtimestamp(millis // 1000, tz=UTC)
    no_fix = report.fix_quality == _NO_FIX
    loc = "N/A" if no_fix else ("DR" if report.fix_quality == _ESTIMATE else "GPS")
    odometer = report.odometer_m
    return {
        "VP": {
            "oper": operator,
            "veh": vehicle_number,
            "tst": stamp.strftime("%Y-%m-%dT%H:%M:%S.") + f"{millis % 1000:03d}Z",
            "lat": None if no_fix else round(report.lat, 6),
            "long": None if no_fix else round(report.lon, 6),
            "spd": round(report.speed_mps, 2),
            "hdg": round(report.course_deg) % 360,
            "odo": None if odometer is None else round(odometer),
            "loc": loc,
        }
    }


def write_hfp(
    path: str | os.PathLike[str],
    reports: Sequence[VehicleReport],
    *,
    operator: int = DEFAULT_OPERATOR,
    epoch_utc_s: float = 0.0,
) -> Path:
    """Write reports as HFP JSON lines, one message per report, in the order given.

    Parameters
    ----------
    path : str or path-like
    reports : sequence of VehicleReport
    operator : int, keyword-only
        ``oper`` of every message (default 40).
    epoch_utc_s : float, keyword-only
        Unix time of ``t = 0``, s (the simulator's ``epoch_utc_s``).

    Returns
    -------
    pathlib.Path
    """
    numbers = hfp_vehicle_numbers(r.vehicle_id for r in reports)
    out = Path(path)
    with out.open("w", encoding="utf-8") as fh:
        for r in reports:
            message = hfp_message(
                r, vehicle_number=numbers[r.vehicle_id], operator=operator, epoch_utc_s=epoch_utc_s
            )
            fh.write(json.dumps(message, separators=(",", ":")) + "\n")
    return out
