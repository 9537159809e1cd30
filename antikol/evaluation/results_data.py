"""What the interactive result maps show, gathered from a replay or a comparison.

The result pages (:mod:`antikol.evaluation.html_results`) draw plain JSON-ready data,
built here:

* **paths** — each vehicle's positions every analysis cycle, split into runs of one
  warning level (the lamp is on at ``warning`` and ``emergency``);
* **events** — every warning episode of a vehicle about another one (replay, and
  comparisons), every false alarm and every missed warning (comparisons, against the
  ground truth), with its pair, kind, level, distance, closing speed and time;
* **charts** — for the pair of each event, the distance between the two vehicles and the
  warnings against time around it (the view of Figs. 10 and 11 of the 2008 paper).

A replay is recorded while it runs by a :class:`ReplayRecorder` (an ``on_assessment``
callback of :func:`antikol.evaluation.replay.replay`); a comparison is read from its
:class:`~antikol.evaluation.scoring.Comparison`, the analysers' threat details recorded by
running them once more on the same reports (:func:`record_threats`).

>>> episodes([0.0, 1.0, 2.0, 5.0, 6.0, 9.0], max_gap_s=1.5)
[(0, 3), (3, 5), (5, 6)]
"""

from __future__ import annotations

import logging
from collections import defaultdict
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from antikol.analysis.analyser import Analyser
from antikol.analysis.assessment import Assessment, Threat
from antikol.evaluation.groundtruth import CLEAR, REQUIRED
from antikol.evaluation.scoring import Comparison, MissedEpisode
from antikol.kinds import LEVELS, level_rank
from trackmap import TrackMap

__all__ = [
    "CHART_AFTER_S",
    "CHART_BEFORE_S",
    "METHOD_LABELS",
    "ReplayRecorder",
    "comparison_results",
    "episodes",
    "record_threats",
    "replay_results",
]

logger = logging.getLogger(__name__)

#: The pair chart of an event starts this long before it, s.
CHART_BEFORE_S = 40.0
#: ... and ends this long after it, s.
CHART_AFTER_S = 20.0
#: How each method is named on the pages.
METHOD_LABELS = {"sector": "sector rule (2008 paper)", "track": "track-aware analyser"}

_WARNING = level_rank("warning")


def episodes(times: Sequence[float], *, max_gap_s: float) -> list[tuple[int, int]]:
    """Split sorted times into runs without a gap longer than ``max_gap_s``.

    Returns
    -------
    list of (int, int)
        ``(start, end_exclusive)`` indices of each run.
    """
    out: list[tuple[int, int]] = []
    start = 0
    for i in range(1, len(times) + 1):
        if i == len(times) or times[i] - times[i - 1] > max_gap_s:
            if i > start:
                out.append((start, i))
            start = i
    return out


def _r(value: float | None, digits: int = 1) -> float | None:
    if value is None or not np.isfinite(value):
        return None
    return round(float(value), digits)


def _level_runs(
    lat: Sequence[float] | np.ndarray,
    lon: Sequence[float] | np.ndarray,
    level: Sequence[int],
    breaks: Sequence[bool],
) -> list[list[Any]]:
    """Runs of equal level as ``[level, [[lat, lon], ...]]``; consecutive runs share their
    boundary point so the line is continuous; ``breaks[i]`` starts a new line at ``i``."""
    runs: list[list[Any]] = []
    cur: list[Any] | None = None
    for i in range(len(lat)):
        pt = [round(float(lat[i]), 6), round(float(lon[i]), 6)]
        if cur is None or breaks[i]:
            cur = [int(level[i]), [pt]]
            runs.append(cur)
            continue
        if level[i] != cur[0]:
            cur = [int(level[i]), [cur[1][-1], pt]]
            runs.append(cur)
        else:
            cur[1].append(pt)
    return runs


@dataclass
class _Samples:
    t: list[float] = field(default_factory=list)
    lon: list[float] = field(default_factory=list)
    lat: list[float] = field(default_factory=list)
    level: list[int] = field(default_factory=list)


class ReplayRecorder:
    """Records a replay for its result map: pass it as ``on_assessment`` of
    :func:`antikol.evaluation.replay.replay`.

    For every assessment it keeps the vehicle's position (the analyser's track position
    when it has a map, else the newest report), its level and its threats.

    Parameters
    ----------
    analyser : Analyser
        The analyser the replay runs (asked for positions).
    """

    def __init__(self, analyser: Analyser) -> None:
        self.analyser = analyser
        #: ``track`` when the analyser has a map, else ``sector``.
        self.method = "track" if analyser.track_map is not None else "sector"
        self.samples: dict[str, _Samples] = {}
        #: Threats per ordered pair (own, other) and assessment time.
        self.threats: dict[tuple[str, str], dict[float, Threat]] = defaultdict(dict)

    def __call__(self, a: Assessment) -> None:
        where = self._where(a.own_id, a.t)
        if where is None:
            return
        s = self.samples.setdefault(a.own_id, _Samples())
        s.t.append(a.t)
        s.lon.append(where[0])
        s.lat.append(where[1])
        s.level.append(level_rank(a.level))
        for th in a.threats:
            self.threats[(a.own_id, th.vehicle_id)][a.t] = th

    def _where(self, vid: str, t: float) -> tuple[float, float] | None:
        pos = self.analyser.position(vid, t)
        if pos is not None:
            return float(pos.lon), float(pos.lat)
        report = self.analyser.table.get(vid)
        if report is None:
            return None
        return float(report.lon), float(report.lat)


def replay_results(recorder: ReplayRecorder, *, title: str, cycle_s: float = 1.0) -> dict[str, Any]:
    """The data of a replay's result map (see the module notes).

    Parameters
    ----------
    recorder : ReplayRecorder
        After the replay.
    title : str
        Page title.
    cycle_s : float
        Analysis period of the replay, s (runs of warnings with gaps of up to 1.5 cycles
        are one episode).

    Returns
    -------
    dict
        JSON-ready: ``title``, ``methods``, ``paths``, ``events``, ``charts``, ``bounds``.
    """
    from pyproj import Geod

    geod = Geod(ellps="WGS84")
    method = recorder.method
    paths = []
    index: dict[str, dict[float, int]] = {}
    for vid, s in sorted(recorder.samples.items()):
        index[vid] = {t: i for i, t in enumerate(s.t)}
        breaks = [i == 0 or s.t[i] - s.t[i - 1] > 3.0 * cycle_s for i in range(len(s.t))]
        paths.append({"v": vid, "runs": _level_runs(s.lat, s.lon, s.level, breaks)})
    events: list[dict[str, Any]] = []
    charts: list[dict[str, Any]] = []
    for (own, other), by_t in sorted(recorder.threats.items()):
        warn_t = sorted(t for t, th in by_t.items() if level_rank(th.level) >= _WARNING)
        if own not in recorder.samples or not warn_t:
            continue
        s = recorder.samples[own]
        for a, b in episodes(warn_t, max_gap_s=1.5 * cycle_s):
            t0, t1 = warn_t[a], warn_t[b - 1]
            first = by_t[t0]
            ths = [by_t[t] for t in warn_t[a:b]]
            k0 = index[own][t0]
            events.append(
                {
                    "method": method,
                    "cat": "warning",
                    "own": own,
                    "other": other,
                    "kind": first.kind,
                    "level": max((th.level for th in ths), key=level_rank),
                    "t0": _r(t0, 2),
                    "t1": _r(t1, 2),
                    "d": _r(first.distance_m),
                    "dmin": _r(min(th.distance_m for th in ths)),
                    "v": _r(first.closing_speed_mps),
                    "ttc": _r(first.ttc_s),
                    "by": first.method,
                    "zone": first.zone,
                    "p": _r(first.probability, 3),
                    "note": first.detail,
                    "lat": round(s.lat[k0], 6),
                    "lon": round(s.lon[k0], 6),
                }
            )
    _attach_charts(
        events,
        charts,
        lambda own, other, lo, hi: _replay_chart(recorder, index, geod, own, other, lo, hi),
    )
    return {
        "title": title,
        "kind": "replay",
        "methods": [{"key": method, "label": METHOD_LABELS[method], "summary": ""}],
        "levels": list(LEVELS),
        "paths": {method: paths},
        "events": events,
        "charts": charts,
        "bounds": _bounds([pt for p in paths for run in p["runs"] for pt in run[1]]),
    }


def _replay_chart(
    rec: ReplayRecorder,
    index: Mapping[str, Mapping[float, int]],
    geod: Any,
    own: str,
    other: str,
    lo: float,
    hi: float,
) -> dict[str, Any]:
    s = rec.samples[own]
    o = rec.samples.get(other)
    ks = [k for k, t in enumerate(s.t) if lo <= t <= hi]
    times = [s.t[k] for k in ks]
    dist: list[float | None] = []
    for k in ks:
        j = index.get(other, {}).get(s.t[k])
        if o is None or j is None:
            dist.append(None)
            continue
        _, _, d = geod.inv(s.lon[k], s.lat[k], o.lon[j], o.lat[j])
        dist.append(_r(d))
    by_t = rec.threats.get((own, other), {})
    gap = [_r(by_t[t].distance_m) if t in by_t else None for t in times]
    level = [level_rank(by_t[t].level) if t in by_t else 0 for t in times]
    return {
        "own": own,
        "other": other,
        "t": [_r(t, 2) for t in times],
        "lines": [
            {"label": "distance between the positions (m)", "values": dist, "style": "line"},
            {"label": "gap seen by the analyser (m)", "values": gap, "style": "dots"},
        ],
        "bars": [{"label": f"{METHOD_LABELS[rec.method]}: {own} about {other}", "values": level}],
        "band": None,
    }


def _attach_charts(
    events: list[dict[str, Any]],
    charts: list[dict[str, Any]],
    make: Callable[[str, str, float, float], dict[str, Any]],
) -> None:
    """Give every event a chart of its pair; events of a pair whose chart windows overlap
    share one chart."""
    by_pair: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for ev in events:
        by_pair[(ev["own"], ev["other"])].append(ev)
    for (own, other), evs in sorted(by_pair.items()):
        evs.sort(key=lambda e: e["t0"])
        groups: list[tuple[float, float, list[dict[str, Any]]]] = []
        for ev in evs:
            lo = ev["t0"] - CHART_BEFORE_S
            hi = (ev["t1"] if ev["t1"] is not None else ev["t0"]) + CHART_AFTER_S
            if groups and lo <= groups[-1][1]:
                g_lo, g_hi, members = groups[-1]
                groups[-1] = (g_lo, max(g_hi, hi), [*members, ev])
            else:
                groups.append((lo, hi, [ev]))
        for lo, hi, members in groups:
            chart = make(own, other, lo, hi)
            chart["marks"] = sorted({e["t0"] for e in members})
            for e in members:
                e["chart"] = len(charts)
            charts.append(chart)
    for i, ev in enumerate(sorted(events, key=lambda e: (e["t0"], e["own"], e["other"]))):
        ev["id"] = i
    events.sort(key=lambda e: e["id"])


def _bounds(points: Iterable[Sequence[float]]) -> list[list[float]] | None:
    pts = np.asarray(list(points), dtype=float)
    if not len(pts):
        return None
    return [
        [float(pts[:, 0].min()), float(pts[:, 1].min())],
        [float(pts[:, 0].max()), float(pts[:, 1].max())],
    ]


# -- comparisons --------------------------------------------------------------------------
def record_threats(
    comparison: Comparison,
    net: TrackMap,
    *,
    analyser_options: Mapping[str, Any] | None = None,
) -> dict[str, dict[tuple[str, str], dict[int, Threat]]]:
    """The threats at level ``warning`` or above of both analysers of a comparison.

    :func:`~antikol.evaluation.scoring.compare` keeps only whether each pair was warned;
    the result map also shows each warning's kind, level, distance and closing speed, so
    both analysers are run once more on the same reports at the same times (as
    :func:`~antikol.evaluation.scoring.run_analyser` does). Their lamps are checked
    against the comparison's logs; a difference is logged as a warning.

    Parameters
    ----------
    comparison : Comparison
    net : TrackMap
        The map of the run.
    analyser_options : mapping, optional
        The extra options the track-aware analyser of the comparison had.

    Returns
    -------
    dict
        ``{method: {(own, other): {time index: Threat}}}``.
    """
    result = comparison.result
    times = comparison.truth.times_s
    profiles = {s.vehicle_id: s.profile for s in result.specs}
    opts = dict(analyser_options or {})
    makers: dict[str, Callable[[], Analyser]] = {
        "sector": lambda: Analyser(profiles=profiles),
        "track": lambda: Analyser(track_map=net, profiles=profiles, **opts),
    }
    out: dict[str, dict[tuple[str, str], dict[int, Threat]]] = {}
    reports = list(result.reports)
    for method, make in makers.items():
        an = make()
        found: dict[tuple[str, str], dict[int, Threat]] = defaultdict(dict)
        lamps = comparison.logs[method].lamp
        differs = 0
        r = 0
        for k, t in enumerate(times):
            batch = []
            while r < len(reports) and reports[r].t <= t + 1e-9:
                batch.append(reports[r])
                r += 1
            if batch:
                an.update_many(batch)
            for own, a in an.assess_all(t=float(t)).items():
                if own in lamps and bool(lamps[own][k]) != a.lamp:
                    differs += 1
                for th in a.threats:
                    if level_rank(th.level) >= _WARNING:
                        found[(own, th.vehicle_id)][k] = th
        if differs:
            logger.warning(
                "%s: the %s analyser run again for the result map differs from the scored "
                "run in %d lamp state(s); the map's details may not match the scores",
                comparison.name,
                method,
                differs,
            )
        out[method] = dict(found)
    return out


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    if not mask.any():
        return []
    padded = np.concatenate([[False], mask, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


class _TruthView:
    """True positions of a comparison's vehicles at its analysis times (local metres)."""

    def __init__(self, comparison: Comparison, vehicles: Sequence[str]) -> None:
        times = comparison.truth.times_s
        n = len(times)
        self.front: dict[str, np.ndarray] = {}
        self.rear: dict[str, np.ndarray] = {}
        self.live: dict[str, np.ndarray] = {}
        for v in vehicles:
            tr = comparison.result.truth[v]
            live = comparison.truth.in_service[v].copy()
            front = np.full((n, 2), np.nan)
            rear = np.full((n, 2), np.nan)
            for k in np.flatnonzero(live):
                i = tr.index_at(float(times[k]))
                front[k] = (tr.x_m[i], tr.y_m[i])
                rear[k] = (tr.rear_x_m[i], tr.rear_y_m[i])
            self.front[v], self.rear[v], self.live[v] = front, rear, live

    def gap(self, a: str, b: str) -> np.ndarray:
        """Planar distance between the nearest ends of two vehicles per time, m (NaN when
        either is out of service)."""
        ends_a = (self.front[a], self.rear[a])
        ends_b = (self.front[b], self.rear[b])
        d = [np.hypot(*(p - q).T) for p in ends_a for q in ends_b]
        return np.min(np.vstack(d), axis=0)


def comparison_results(
    comparison: Comparison,
    net: TrackMap,
    *,
    vehicles: Sequence[str] = (),
    threats: Mapping[str, Mapping[tuple[str, str], Mapping[int, Threat]]] | None = None,
) -> dict[str, Any]:
    """The data of a comparison's result map (see the module notes).

    Paths are the vehicles' true front positions, once per method, coloured by that
    analyser's lamp. Events, per method: every warning episode about a vehicle (runs of
    warning cycles that are not all on a clearly conflict-free pair), every false alarm
    (runs of warning cycles on a clearly conflict-free pair, as scored) and every missed
    warning (as scored, with how late a warning came, if it did).

    Parameters
    ----------
    comparison : Comparison
    net : TrackMap
        The map of the run.
    vehicles : sequence of str
        Vehicles to show (default: every simulated vehicle).
    threats : mapping, optional
        From :func:`record_threats` (run here when not given).

    Returns
    -------
    dict
        JSON-ready: ``title``, ``methods``, ``paths``, ``events``, ``charts``, ``bounds``.
    """
    if threats is None:
        threats = record_threats(comparison, net)
    truth = comparison.truth
    times = truth.times_s
    vids = list(vehicles or comparison.result.truth)
    shown = set(vids)
    view = _TruthView(comparison, vids)
    lonlat: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for v in vids:
        lon, lat = net.to_lonlat(view.front[v][:, 0], view.front[v][:, 1])
        lonlat[v] = (np.asarray(lon, dtype=float), np.asarray(lat, dtype=float))
    paths: dict[str, list[dict[str, Any]]] = {}
    for method in ("sector", "track"):
        log = comparison.logs[method]
        paths[method] = []
        for v in vids:
            live = view.live[v]
            ks = np.flatnonzero(live)
            if not len(ks):
                continue
            level = np.where(log.lamp[v][ks], _WARNING, 0)
            breaks = np.concatenate([[True], np.diff(ks) > 1])
            lon, lat = lonlat[v]
            runs = _level_runs(lat[ks], lon[ks], level.tolist(), breaks.tolist())
            paths[method].append({"v": v, "runs": runs})

    events: list[dict[str, Any]] = []

    def where(own: str, k: int) -> tuple[float, float]:
        lon, lat = lonlat[own]
        ok = np.flatnonzero(np.isfinite(lon))
        if len(ok) and not np.isfinite(lon[k]):  # not in service just then: nearest time
            k = int(ok[np.argmin(np.abs(ok - k))])
        return round(float(lat[k]), 6), round(float(lon[k]), 6)

    for method in ("sector", "track"):
        log = comparison.logs[method]
        details = threats.get(method, {})
        for (own, other), warn in sorted(log.pair_warn.items()):
            if own not in shown or other not in shown or not warn.any():
                continue
            state = truth.state[(own, other)]
            for a, b in _runs(warn):
                if np.all(state[a:b] == CLEAR):
                    continue
                cat_note = (
                    "a warning was required during it"
                    if np.any(state[a:b] == REQUIRED)
                    else "a conflict existed, no warning yet required"
                )
                events.append(
                    _warn_event(
                        method, "warning", own, other, a, b, times, details, cat_note, where(own, a)
                    )
                )
            for a, b in _runs(warn & (state == CLEAR)):
                events.append(
                    _warn_event(
                        method,
                        "false_alarm",
                        own,
                        other,
                        a,
                        b,
                        times,
                        details,
                        "the pair was clearly conflict-free",
                        where(own, a),
                    )
                )
        score = comparison.sector if method == "sector" else comparison.track
        for m in score.missed_detail:
            if m.own not in shown or m.other not in shown:
                continue
            events.append(_missed_event(method, m, times, view, where))

    def chart(own: str, other: str, lo: float, hi: float) -> dict[str, Any]:
        ks = np.flatnonzero((times >= lo) & (times <= hi))
        gap = view.gap(own, other)[ks]
        state = truth.state[(own, other)][ks]
        return {
            "own": own,
            "other": other,
            "t": [_r(t, 2) for t in times[ks]],
            "lines": [
                {
                    "label": "distance between the trams, nearest ends (true, m)",
                    "values": [_r(g) for g in gap],
                    "style": "line",
                }
            ],
            "bars": [
                {
                    "label": f"{METHOD_LABELS[m]}: {own} warned about {other}",
                    "values": [
                        _WARNING if w else 0
                        for w in comparison.logs[m].pair_warn[(own, other)][ks].tolist()
                    ],
                }
                for m in ("sector", "track")
            ],
            "band": {
                "label": "ground truth: warning required (red), conflict exists (yellow)",
                "values": [int(s) for s in state.tolist()],
            },
        }

    charts: list[dict[str, Any]] = []
    _attach_charts(events, charts, chart)
    all_pts = [pt for runs in paths["track"] for run in runs["runs"] for pt in run[1]]
    return {
        "title": f"{comparison.name}: sector rule and track-aware analyser",
        "kind": "comparison",
        "methods": [
            {"key": m, "label": METHOD_LABELS[m], "summary": _score_line(comparison, m)}
            for m in ("track", "sector")
        ],
        "levels": list(LEVELS),
        "paths": paths,
        "events": events,
        "charts": charts,
        "bounds": _bounds(all_pts),
    }


def _score_line(comparison: Comparison, method: str) -> str:
    sc = comparison.sector if method == "sector" else comparison.track
    return (
        f"required {sc.required}: timely {sc.timely}, missed {sc.missed} ({sc.late} late); "
        f"false-alarm episodes {sc.false_alarm_episodes}"
    )


def _warn_event(
    method: str,
    cat: str,
    own: str,
    other: str,
    a: int,
    b: int,
    times: np.ndarray,
    details: Mapping[tuple[str, str], Mapping[int, Threat]],
    note: str,
    latlon: tuple[float, float],
) -> dict[str, Any]:
    ths = details.get((own, other), {})
    run = [ths[k] for k in range(a, b) if k in ths]
    first = run[0] if run else None
    return {
        "method": method,
        "cat": cat,
        "own": own,
        "other": other,
        "kind": first.kind if first else None,
        "level": max((th.level for th in run), key=level_rank) if run else "warning",
        "t0": _r(times[a], 2),
        "t1": _r(times[b - 1], 2),
        "d": _r(first.distance_m) if first else None,
        "dmin": _r(min(th.distance_m for th in run)) if run else None,
        "v": _r(first.closing_speed_mps) if first else None,
        "ttc": _r(first.ttc_s) if first else None,
        "by": first.method if first else method,
        "zone": first.zone if first else None,
        "p": _r(first.probability, 3) if first else None,
        "note": note + (f"; {first.detail}" if first and first.detail else ""),
        "lat": latlon[0],
        "lon": latlon[1],
    }


def _missed_event(
    method: str,
    m: MissedEpisode,
    times: np.ndarray,
    view: _TruthView,
    where: Callable[[str, int], tuple[float, float]],
) -> dict[str, Any]:
    k = int(np.argmin(np.abs(times - m.start_s)))
    gap = view.gap(m.own, m.other)
    closing = None
    if 0 < k < len(times) - 1 and np.isfinite(gap[k - 1]) and np.isfinite(gap[k + 1]):
        closing = -(gap[k + 1] - gap[k - 1]) / float(times[k + 1] - times[k - 1])
    late = "never warned" if m.late_s is None else f"warned {m.late_s:.0f} s late"
    return {
        "method": method,
        "cat": "missed",
        "own": m.own,
        "other": m.other,
        "kind": str(getattr(m.kind, "value", m.kind)),
        "level": "none",
        "t0": _r(m.start_s, 2),
        "t1": _r(m.start_s, 2),
        "d": _r(gap[k]),
        "dmin": None,
        "v": _r(closing),
        "ttc": None,
        "by": "ground truth",
        "zone": None,
        "p": None,
        "note": f"warning required from this time on; {late} (true distance and closing speed)",
        "lat": where(m.own, k)[0],
        "lon": where(m.own, k)[1],
    }
