"""The summary of a fleet-scale replay: rates per vehicle-km, the sector rule beside the
track-aware analyser, false-alarm hot spots (a figure and an HTML map), failures.

A *false-alarm candidate* is an analysis cycle in which the paper's sector rule lights
the lamp of a vehicle and the track-aware analyser does not (the reason the map cleared
the other vehicle, e.g. ``parallel_track``, is kept). Without ground truth an archive can
say no more; on simulated traffic :mod:`antikol.evaluation.scoring` scores both.
"""

from __future__ import annotations

import json
import math
import os
from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["FleetSummary", "HotSpot", "PartitionFailure", "hotspot_figure", "hotspot_html"]


@dataclass(frozen=True)
class PartitionFailure:
    """A partition that failed after its retries.

    Attributes
    ----------
    stage : str
        ``ingest``, ``positioning`` or ``analysis``.
    name : str
        The partition (file, vehicle-day or window-region).
    error : str
        The exception, one line.
    input_error : bool
        The input is at fault (unreadable file...), not the program.
    """

    stage: str
    name: str
    error: str
    input_error: bool


@dataclass(frozen=True)
class HotSpot:
    """A square of the map with false-alarm candidates.

    Attributes
    ----------
    lon, lat : float
        Its centre, degrees.
    size_m : float
        Its side, m.
    cycles : int
        Vehicle-cycles with the sector rule's lamp on and the track-aware one's off.
    reasons : dict of str to int
        Those cycles by the reason the map cleared the other vehicle.
    """

    lon: float
    lat: float
    size_m: float
    cycles: int
    reasons: dict[str, int]


@dataclass(frozen=True)
class FleetSummary:
    """Everything a fleet-scale replay counted (SI units, distances in km).

    Attributes
    ----------
    partitions : int
        Archive files.
    rows_read : int
        Records read (where the reader counts them).
    reports : int
        Valid reports (fixes) replayed.
    rejected_by_reason : dict of str to int
    vehicles, vehicle_days : int
    vehicle_km : float
    vehicle_cycles : int
        Assessments of a vehicle in a cycle.
    events : int
        Event rows written (both analysers).
    alarms : dict of str to dict of str to int
        Per analyser (``track``, ``sector``), threat observations at level warning or
        above, by kind.
    lamp_cycles : dict of str to int
        Per analyser, vehicle-cycles with the lamp on.
    hot_spots : tuple of HotSpot
        Most false-alarm candidates first.
    failures : tuple of PartitionFailure
    tasks : dict of str to int
        Tasks run per stage.
    seconds : float
        Wall time, s.
    unsettled_alarms : int
        Pair alarms that had been in conflict since their window's warm-up began (they may
        differ from a continuous replay; 0 when every warm-up sufficed).
    """

    partitions: int
    rows_read: int
    reports: int
    rejected_by_reason: dict[str, int]
    vehicles: int
    vehicle_days: int
    vehicle_km: float
    vehicle_cycles: int
    events: int
    alarms: dict[str, dict[str, int]]
    lamp_cycles: dict[str, int]
    hot_spots: tuple[HotSpot, ...] = ()
    failures: tuple[PartitionFailure, ...] = ()
    tasks: dict[str, int] = field(default_factory=dict)
    seconds: float = 0.0
    unsettled_alarms: int = 0

    @property
    def complete(self) -> bool:
        """No partition failed."""
        return not self.failures

    def per_vehicle_km(self, analyser: str) -> dict[str, float]:
        """Warning-level threat observations per vehicle-km, by kind."""
        km = self.vehicle_km
        counts = self.alarms.get(analyser, {})
        return {k: (n / km if km > 0 else float("nan")) for k, n in sorted(counts.items())}

    def to_json(self, path: str | os.PathLike[str]) -> Path:
        """Write the summary as JSON (a rate that is not a number, with no vehicle-km,
        is written as null)."""
        p = Path(path)
        data = asdict(self)
        data["per_vehicle_km"] = {a: self.per_vehicle_km(a) for a in self.alarms}
        text = json.dumps(_finite(data), indent=2, default=str, allow_nan=False)
        p.write_text(text, encoding="utf-8")
        return p

    def lines(self) -> list[str]:
        """The summary as text lines for a terminal."""
        out = [
            f"{self.partitions} partition(s), {self.reports} fixes of {self.vehicles} vehicles "
            f"({self.vehicle_days} vehicle-days, {self.vehicle_km:.1f} vehicle-km), "
            f"{self.rows_read} records read, "
            f"{sum(self.rejected_by_reason.values())} rejected",
            "tasks: "
            + ", ".join(f"{k} {v}" for k, v in self.tasks.items())
            + f"; {self.seconds:.1f} s",
            f"{'analyser':<8} {'lamp cycles':>12}  warnings per vehicle-km by kind",
        ]
        for a in ("sector", "track"):
            if a not in self.lamp_cycles:
                continue
            rates = ", ".join(f"{k} {v:.3f}" for k, v in self.per_vehicle_km(a).items())
            out.append(f"{a:<8} {self.lamp_cycles[a]:>12}  {rates or 'none'}")
        if self.hot_spots:
            total = sum(h.cycles for h in self.hot_spots)
            out.append(
                f"false-alarm candidates (sector lamp on, track lamp off): {total} vehicle-"
                f"cycles in {len(self.hot_spots)} squares of {self.hot_spots[0].size_m:g} m"
            )
            for h in self.hot_spots[:5]:
                why = ", ".join(f"{k} {v}" for k, v in sorted(h.reasons.items()))
                out.append(f"  {h.lat:.5f},{h.lon:.5f}: {h.cycles} ({why})")
        if self.unsettled_alarms:
            out.append(
                f"warm-up too short: {self.unsettled_alarms} pair alarm(s) were in conflict "
                "since their window's warm-up began and may differ from a continuous replay "
                "(raise --warmup)"
            )
        for f in self.failures:
            out.append(f"FAILED {f.stage} {f.name}: {f.error}")
        return out


def _finite(value: Any) -> Any:
    """``value`` with every NaN or infinite float (in dicts, lists, tuples) made None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def merge_hot_spots(
    cells: Sequence[dict[tuple[int, int], dict[str, int]]], net: Any, size_m: float
) -> tuple[HotSpot, ...]:
    """Hot spots from the per-task grid counts (cell indices of ``size_m`` squares)."""
    total: dict[tuple[int, int], Counter[str]] = {}
    for part in cells:
        for key, reasons in part.items():
            total.setdefault(key, Counter()).update(reasons)
    spots = []
    for (gx, gy), reasons in total.items():
        lon, lat = net.to_lonlat((gx + 0.5) * size_m, (gy + 0.5) * size_m)
        spots.append(HotSpot(float(lon), float(lat), size_m, sum(reasons.values()), dict(reasons)))
    spots.sort(key=lambda h: (-h.cycles, h.lat, h.lon))
    return tuple(spots)


def hotspot_figure(summary: FleetSummary, net: Any, path: str | os.PathLike[str]) -> Path:
    """A matplotlib figure of the hot spots over the track map (PNG or SVG by name)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 8))
    for edge in net.edges:
        xs, ys = edge.geometry.xy
        ax.plot(xs, ys, color="0.6", lw=0.6)
    spots = summary.hot_spots
    if spots:
        xy = [net.to_local(h.lon, h.lat) for h in spots]
        size = [20 + 200 * h.cycles / spots[0].cycles for h in spots]
        sc = ax.scatter(
            [p[0] for p in xy],
            [p[1] for p in xy],
            s=size,
            c=[h.cycles for h in spots],
            cmap="inferno_r",
            alpha=0.8,
            zorder=3,
        )
        fig.colorbar(sc, ax=ax, shrink=0.6, label="vehicle-cycles: sector lamp on, track lamp off")
    ax.set_aspect("equal")
    ax.set_xlabel("x, m")
    ax.set_ylabel("y, m")
    ax.set_title("False-alarm candidates of the sector rule")
    p = Path(path)
    fig.savefig(p, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return p


def hotspot_html(summary: FleetSummary, net: Any, path: str | os.PathLike[str]) -> Path:
    """A self-contained HTML map of the hot spots over the track map (no tiles, Leaflet
    inline: the page makes no network request)."""
    import folium

    from trackmap.plot_html import html_map, save_html

    fmap = html_map(net, tiles=None, title="False-alarm candidates of the sector rule")
    top = summary.hot_spots[0].cycles if summary.hot_spots else 1
    for h in summary.hot_spots:
        why = ", ".join(f"{k}: {v}" for k, v in sorted(h.reasons.items()))
        folium.CircleMarker(
            [h.lat, h.lon],
            radius=4 + 16 * h.cycles / top,
            color="#c0392b",
            fill=True,
            popup=f"{h.cycles} vehicle-cycles ({why})",
        ).add_to(fmap)
    return save_html(fmap, path)
