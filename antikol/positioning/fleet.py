"""The positioning state of a whole fleet as arrays: one row per vehicle.

Rows are reused when a vehicle leaves; :class:`FleetState` grows by doubling. Hypothesis
slots hold, per vehicle, up to ``k`` places; slot 0 is the one the reported position follows.
State ids pack (edge, running direction), see :mod:`antikol.positioning.reach`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from antikol.positioning.fixerror import FIX_ERROR_FIELDS
from antikol.positioning.kalman import TrackFilterState
from antikol.positioning.reach import state_direction, state_edge
from antikol.report import VehicleReport

__all__ = [
    "SLOT_FIELDS",
    "UNKNOWN_AT_START",
    "VEHICLE_FIELDS",
    "FleetState",
    "RunSinceFix",
    "json_float",
    "report_dict",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

#: Per-hypothesis arrays of the fleet state (rows: vehicles, columns: hypothesis slots).
SLOT_FIELDS = ("ho", "hp", "hg", "hw", "hv", "he", *FIX_ERROR_FIELDS)
#: Per-vehicle float arrays of the fleet state.
VEHICLE_FIELDS = (
    "t", "x", "y", "v", "odo", "odo_fix", "t_fix", "z",
    "run", "lc", "lt", "lpcc", "lpct", "lptt", "stood", "rx", "ry",
    "run_nofix", "t_nofix", "v_nofix",
    "ux", "uy", "utrail", "ut", "uv", "urun", "udisp", "urep", "uscale",
    "oraw", "ocor", "olf", "zlf", "osum", "ox", "oy", "orn", "omx", "omy", "ocxx", "ocxy",
    "opxx", "opxy", "oscale", "bvar", "oq", "oqn", "ostep",
    "kraw", "kt", "kv", "kacc", "klow", "kn", "kmin",
    "sm", "sc", "sn", "sa", "sp", "pf", "tt",
    "qx", "qy", "qt", "qv", "qc", "qe", "qr", "qn",
)  # fmt: skip
#: Per-vehicle fields that a new row does not know yet (NaN); the others start at 0.
UNKNOWN_AT_START = (
    "t", "x", "y", "odo", "odo_fix", "t_fix", "lc", "lt", "rx", "ry", "t_nofix", "v_nofix",
    "ux", "uy", "utrail", "ut", "uv", "oraw", "ocor", "olf", "zlf", "oq", "ostep",
    "kraw", "kt", "klow", "kmin", "sc", "tt", "qx", "qy", "qt", "qv", "qc",
)  # fmt: skip


class RunSinceFix(NamedTuple):
    """How far (m, NaN: not known) and how long (s, NaN: no fix yet) each vehicle has run
    since its last position fix, and whether the distance is its odometer's (else its
    mean reported speed times the time)."""

    distance_m: FloatArray
    seconds: FloatArray
    by_odometer: npt.NDArray[np.bool_]


@dataclass
class FleetState:
    """The positioning state of every vehicle, as arrays (one row per vehicle).

    Hypothesis slots hold, per vehicle, up to ``k`` places; slot 0 is the one the reported
    position follows. State ids pack (edge, running direction), see
    :mod:`antikol.positioning.reach`; ``-1`` marks an empty slot.
    """

    k: int
    # per hypothesis (vehicles x k): state id, offset on the edge (m), log-probability,
    # progress along its history (m), time running wrong way (s), the state id it entered
    # its own from (as a float; -1: not known), the log-likelihood of the latest position
    # estimate in it since the last fix (:mod:`antikol.positioning.estimates`), and the
    # fix error filter
    # (:mod:`antikol.positioning.fixerror`): along-track lag, GPS bias east and north (m)
    # and their covariance (m²)
    hs: IntArray = field(init=False)
    ho: FloatArray = field(init=False)
    hp: FloatArray = field(init=False)
    hg: FloatArray = field(init=False)
    hw: FloatArray = field(init=False)
    hv: FloatArray = field(init=False)
    he: FloatArray = field(init=False)
    ad: FloatArray = field(init=False)
    bx: FloatArray = field(init=False)
    by: FloatArray = field(init=False)
    paa: FloatArray = field(init=False)
    pax: FloatArray = field(init=False)
    pay: FloatArray = field(init=False)
    pxx: FloatArray = field(init=False)
    pxy: FloatArray = field(init=False)
    pyy: FloatArray = field(init=False)
    # per vehicle: last fix time (s), local position (m), reported speed (m/s), odometer
    # (m), odometer and time at the last GPS position, lineage progress at the last fix (m),
    # probability of the reported place, rejections, confident matches and along-track
    # innovations beyond the gate in a row; the distance run (m) and the latency filter
    # (:mod:`antikol.positioning.latency`: offset, m, latency, s, and their covariance);
    # how long it has stood at its last fix, s; the local position of the last rejected
    # fix (m, NaN: none yet); the distance run by the reported speeds since the last fix
    # (m), up to the last report without a usable fix, and that report's time (s, NaN:
    # none since the fix) and speed (m/s); the unit of its speeds
    # (:mod:`antikol.positioning.speedunits`: the trail's first fix, m, and time, s, the
    # last report's time, s, and reported speed, the trail's run and the pooled
    # displacement, m, and run by the reported speeds, and m/s per reported unit); its
    # odometer's scale (:mod:`antikol.positioning.odometerscale`: the last raw and
    # corrected readings, the raw reading and lineage progress at the last fix, m, the
    # pooled raw run, m, the current run of fixes' regression of progress on the
    # odometer and the pooled one of the runs before, and the scale); the mean square of
    # its GPS bias across the track (:mod:`antikol.positioning.biasscale`, m², 0: none
    # learnt); its odometer's resolution (the smallest difference of successive steps, m,
    # NaN: none yet, and how often it was seen) and last step, m
    # (:mod:`antikol.positioning.odometerresolution`)
    t: FloatArray = field(init=False)
    x: FloatArray = field(init=False)
    y: FloatArray = field(init=False)
    v: FloatArray = field(init=False)
    odo: FloatArray = field(init=False)
    odo_fix: FloatArray = field(init=False)
    t_fix: FloatArray = field(init=False)
    z: FloatArray = field(init=False)
    run: FloatArray = field(init=False)
    lc: FloatArray = field(init=False)
    lt: FloatArray = field(init=False)
    lpcc: FloatArray = field(init=False)
    lpct: FloatArray = field(init=False)
    lptt: FloatArray = field(init=False)
    stood: FloatArray = field(init=False)
    rx: FloatArray = field(init=False)
    ry: FloatArray = field(init=False)
    run_nofix: FloatArray = field(init=False)
    t_nofix: FloatArray = field(init=False)
    v_nofix: FloatArray = field(init=False)
    ux: FloatArray = field(init=False)
    uy: FloatArray = field(init=False)
    utrail: FloatArray = field(init=False)
    ut: FloatArray = field(init=False)
    uv: FloatArray = field(init=False)
    urun: FloatArray = field(init=False)
    udisp: FloatArray = field(init=False)
    urep: FloatArray = field(init=False)
    uscale: FloatArray = field(init=False)
    oraw: FloatArray = field(init=False)
    ocor: FloatArray = field(init=False)
    olf: FloatArray = field(init=False)
    zlf: FloatArray = field(init=False)
    osum: FloatArray = field(init=False)
    ox: FloatArray = field(init=False)
    oy: FloatArray = field(init=False)
    orn: FloatArray = field(init=False)
    omx: FloatArray = field(init=False)
    omy: FloatArray = field(init=False)
    ocxx: FloatArray = field(init=False)
    ocxy: FloatArray = field(init=False)
    opxx: FloatArray = field(init=False)
    opxy: FloatArray = field(init=False)
    oscale: FloatArray = field(init=False)
    bvar: FloatArray = field(init=False)
    oq: FloatArray = field(init=False)
    oqn: FloatArray = field(init=False)
    ostep: FloatArray = field(init=False)
    kraw: FloatArray = field(init=False)
    kt: FloatArray = field(init=False)
    kv: FloatArray = field(init=False)
    kacc: FloatArray = field(init=False)
    klow: FloatArray = field(init=False)
    kn: FloatArray = field(init=False)
    kmin: FloatArray = field(init=False)
    # when a vehicle that starts afresh is shown on a track (antikol.positioning.showing):
    # moving reports, the last standing course (degrees), standing reports that held it,
    # all reports since a fresh start, shown (1) or not (0); the place's probability at
    # the last fix
    sm: FloatArray = field(init=False)
    sc: FloatArray = field(init=False)
    sn: FloatArray = field(init=False)
    sa: FloatArray = field(init=False)
    pf: FloatArray = field(init=False)
    # when its lineage last stood tied with another hypothesis (a coin toss: dead-reckoned
    # over a switch, the branches share evenly), s; NaN: not since its lineage changed
    tt: FloatArray = field(init=False)
    sp: FloatArray = field(init=False)
    # whether its reported course is believed (antikol.positioning.coursecheck): the
    # anchor fix of the next chord (local position, m, time, s, speed, m/s, course,
    # degrees), the evidence for a right and for a reversed course beyond their priors
    # (nats), and how the course is weighed (coursecheck.CourseUse)
    qx: FloatArray = field(init=False)
    qy: FloatArray = field(init=False)
    qt: FloatArray = field(init=False)
    qv: FloatArray = field(init=False)
    qc: FloatArray = field(init=False)
    qe: FloatArray = field(init=False)
    qr: FloatArray = field(init=False)
    qn: FloatArray = field(init=False)
    # its hypotheses at the fix before the last (state id, -1: none; offset, m;
    # log-probability): a branch is decided only when it was decided then too
    # (antikol.positioning.branching)
    bs: IntArray = field(init=False)
    bo: FloatArray = field(init=False)
    bp: FloatArray = field(init=False)
    place: FloatArray = field(init=False)
    rejected: IntArray = field(init=False)
    confident_run: IntArray = field(init=False)
    gated: IntArray = field(init=False)
    unmatched: npt.NDArray[np.bool_] = field(init=False)
    kf: TrackFilterState = field(init=False)
    last: list[VehicleReport | None] = field(init=False, default_factory=list)
    lost: list[str | None] = field(init=False, default_factory=list)

    def __post_init__(self) -> None:
        k = self.k
        self.hs = np.zeros((0, k), np.int64)
        self.bs = np.zeros((0, k), np.int64)
        self.bo = np.zeros((0, k))
        self.bp = np.zeros((0, k))
        for name in SLOT_FIELDS:
            setattr(self, name, np.zeros((0, k)))
        for name in (*VEHICLE_FIELDS, "place"):
            setattr(self, name, np.zeros(0))
        self.rejected = np.zeros(0, np.int64)
        self.confident_run = np.zeros(0, np.int64)
        self.gated = np.zeros(0, np.int64)
        self.unmatched = np.zeros(0, bool)
        self.kf = TrackFilterState.empty(0)

    def grow(self, n: int) -> None:
        """Extend every array to ``n`` rows (new rows cleared)."""
        old = len(self.t)
        if n <= old:
            return
        for name in (
            "hs",
            *SLOT_FIELDS,
            "bs",
            "bo",
            "bp",
            *VEHICLE_FIELDS,
            "place",
            "rejected",
            "confident_run",
            "gated",
            "unmatched",
        ):
            arr = getattr(self, name)
            extra = np.zeros((n - old, *arr.shape[1:]), arr.dtype)
            setattr(self, name, np.concatenate([arr, extra]))
        self.kf.grow(n)
        self.last.extend([None] * (n - old))
        self.lost.extend([None] * (n - old))
        for row in range(old, n):
            self.clear(row)

    def clear(self, row: int) -> None:
        """Empty one row (a new or forgotten vehicle)."""
        self.hs[row] = -1
        self.hp[row] = -math.inf
        self.hv[row] = -1.0
        self.forget_before(row)
        for name in UNKNOWN_AT_START:
            getattr(self, name)[row] = np.nan
        self.v[row] = self.z[row] = self.place[row] = self.run[row] = self.stood[row] = 0.0
        self.run_nofix[row] = self.urun[row] = self.udisp[row] = self.urep[row] = 0.0
        self.uscale[row] = self.oscale[row] = 1.0
        for name in (
            "osum", "ox", "oy", "orn", "omx", "omy", "ocxx", "ocxy", "opxx", "opxy", "bvar",
            "oqn", "kv", "kacc", "kn", "sm", "sn", "sa", "sp", "pf", "qe", "qr", "qn",
        ):  # fmt: skip
            getattr(self, name)[row] = 0.0
        self.lpcc[row] = self.lpct[row] = self.lptt[row] = 0.0
        self.rejected[row] = self.confident_run[row] = self.gated[row] = 0
        self.unmatched[row] = False
        self.kf.t[row] = np.nan
        self.last[row] = None
        self.lost[row] = None

    def forget_before(self, row: int) -> None:
        """Forget one row's hypotheses at the fix before (none known: a fresh start)."""
        self.bs[row] = -1
        self.bo[row] = 0.0
        self.bp[row] = -math.inf

    def note_ties(self, rows: IntArray, t: FloatArray, tie_nats: float) -> None:
        """Note the time ``t`` (s) for the ``rows`` whose lineage stands tied with another
        hypothesis (log-probabilities within ``tie_nats``) ahead of a new fix: split evenly
        over a switch, a coin toss, which the fix right after the tie seldom decides."""
        with np.errstate(invalid="ignore"):  # (empty slots: -inf - -inf)
            gap = np.abs(self.hp[rows, 1:] - self.hp[rows, :1])
        tied = ((self.hs[rows, 1:] >= 0) & (gap <= tie_nats)).any(axis=1)
        tied &= self.hs[rows, 0] >= 0
        self.tt[rows[tied]] = t[tied]

    def keep_before(self, rows: IntArray, fresh: BoolArray) -> None:
        """Keep the hypotheses of ``rows`` as those at the fix before, ahead of a new fix
        (none for the rows that start afresh with it)."""
        self.bs[rows] = np.where(fresh[:, None], -1, self.hs[rows])
        self.bo[rows] = self.ho[rows]
        self.bp[rows] = self.hp[rows]

    def hypotheses_before(self, row: int) -> list[tuple[int, int, float, float]]:
        """One row's hypotheses at the fix before the last: (edge id, direction, offset
        m, probability), the most probable first (empty: not known)."""
        slots = np.flatnonzero(self.bs[row] >= 0)
        states = self.bs[row, slots]
        return list(
            zip(
                state_edge(states).tolist(),
                state_direction(states).tolist(),
                self.bo[row, slots].tolist(),
                np.exp(self.bp[row, slots]).tolist(),
                strict=True,
            )
        )

    def repeats_rejected(
        self, rows: IntArray, xs: FloatArray, ys: FloatArray, t_s: FloatArray, within_s: float
    ) -> BoolArray:
        """Which fixes (local positions, m; times, s) repeat the last rejected fix of their
        vehicle exactly, within ``within_s`` of its last accepted fix: a feed that repeats
        its last position through an outage, or a receiver holding a static position, gives
        no new evidence with each copy (but a position held that long is where the vehicle
        is, or the vehicle could never leave a wrong place while its receiver holds)."""
        fresh = t_s - self.t_fix[rows] < within_s
        return (xs == self.rx[rows]) & (ys == self.ry[rows]) & fresh

    def note_rejected(self, rows: IntArray, xs: FloatArray, ys: FloatArray) -> None:
        """Remember the rejected fixes (local positions, m) of vehicles ``rows``."""
        self.rx[rows], self.ry[rows] = xs, ys

    def run_since_fix(
        self, rows: IntArray, t_s: FloatArray, speed_mps: FloatArray, odometer_m: FloatArray
    ) -> RunSinceFix:
        """How far the vehicles of ``rows`` ran since their last fix, by reports at ``t_s``
        (s) with speeds (m/s) and odometer readings (m, NaN: none).

        Without an odometer the distance is the reported speeds' integral over every report
        since the fix (:meth:`note_run_without_fix`), not one mean speed over the whole
        time: a tram that ran a kilometre through a tunnel and then stood still has run a
        kilometre, not the half of its last speed times the time.
        """
        seconds = np.maximum(t_s - self.t_fix[rows], 0.0)
        odo_fix = self.odo_fix[rows]
        by_odometer = np.isfinite(odometer_m) & np.isfinite(odo_fix)
        step = self._speed_step(rows, t_s, speed_mps)
        distance = np.where(by_odometer, odometer_m - odo_fix, self.run_nofix[rows] + step)
        return RunSinceFix(distance, seconds, by_odometer)

    def _speed_step(self, rows: IntArray, t_s: FloatArray, speed_mps: FloatArray) -> FloatArray:
        """Distance run by the speeds from the last report taken (m): the trapezoid from
        the last report without a fix, or from the last fix."""
        t_nofix = self.t_nofix[rows]
        since = np.isfinite(t_nofix)
        t0 = np.where(since, t_nofix, self.t_fix[rows])
        v0 = np.where(since, self.v_nofix[rows], self.v[rows])
        return 0.5 * (speed_mps + v0) * np.maximum(t_s - t0, 0.0)

    def note_run_without_fix(self, row: int, t_s: float, speed_mps: float) -> None:
        """Add the run of a report without a usable fix (time, s; speed, m/s) to the
        vehicle's distance since its last fix."""
        step = self._speed_step(
            np.array([row], dtype=np.int64), np.array([t_s]), np.array([speed_mps])
        )[0]
        if math.isfinite(step):
            self.run_nofix[row] += step
        self.t_nofix[row], self.v_nofix[row] = t_s, speed_mps

    def note_fix(self, rows: IntArray) -> None:
        """The vehicles of ``rows`` have a new fix: their run since it starts at zero."""
        self.run_nofix[rows] = 0.0
        self.t_nofix[rows] = self.v_nofix[rows] = np.nan

    def lead_to_heaviest_place(
        self, row: int, *, switch_probability: float, eligible_edges: BoolArray | None = None
    ) -> bool:
        """Move a vehicle's lineage (slot 0) to the place (track state) that holds the most
        of its probability, when that place is another one, holds at least
        ``switch_probability`` and lies on an edge that may lead (``eligible_edges``, per
        edge id of the map; default: every edge).

        Returns
        -------
        bool
            Whether the lineage moved (onto the most probable hypothesis at that place).
        """
        slots = np.flatnonzero(self.hs[row] >= 0)
        states, log_p = self.hs[row, slots], self.hp[row, slots]
        unique, where = np.unique(states, return_inverse=True)
        mass = np.bincount(where, weights=np.exp(log_p), minlength=len(unique))
        best = int(np.argmax(mass))
        if (
            unique[best] == states[0]
            or (eligible_edges is not None and not eligible_edges[state_edge(unique[best])])
            or mass[best] < switch_probability
        ):
            return False
        on_best = np.flatnonzero(where == best)
        lead = int(slots[on_best[np.argmax(log_p[on_best])]])
        for name in ("hs", *SLOT_FIELDS):
            column = getattr(self, name)[row]
            column[[0, lead]] = column[[lead, 0]]
        return True

    def pin(
        self, row: int, t: float, state: int, offset_m: float, s_m: float, v_mps: float,
        sigma_m: float,
    ) -> None:  # fmt: skip
        """Pin a vehicle to one track state (an accepted discrete fix at ``t``, s):
        ``offset_m`` on its edge, ``s_m`` along the filter's frame, ``v_mps`` its speed,
        ``sigma_m`` the fix's along-track uncertainty."""
        self.hs[row] = -1
        self.hp[row] = -math.inf
        self.hs[row, 0] = state
        self.ho[row, 0] = offset_m
        self.hp[row, 0] = 0.0
        self.hg[row, 0] = s_m
        self.hw[row, 0] = self.he[row, 0] = 0.0
        self.hv[row] = -1.0
        kf = self.kf
        kf.t[row], kf.s[row], kf.v[row] = t, s_m, v_mps
        kf.pss[row], kf.psv[row] = sigma_m**2, 0.0
        self.z[row] = s_m
        self.place[row] = 1.0
        self.lost[row] = None

    def row_state(self, row: int) -> dict[str, Any]:
        """One vehicle's row as a JSON-ready dict (see ``Positioner.state``)."""
        slots = np.flatnonzero(self.hs[row] >= 0)
        kf, last = self.kf, self.last[row]
        return {
            "states": [int(self.hs[row, k]) for k in slots],
            "slots": {
                name: [float(getattr(self, name)[row, k]) for k in slots] for name in SLOT_FIELDS
            },
            "vehicle": {name: json_float(getattr(self, name)[row]) for name in VEHICLE_FIELDS},
            "filter": [json_float(a[row]) for a in (kf.t, kf.s, kf.v, kf.pss, kf.psv, kf.pvv)],
            "before": [
                [int(self.bs[row, k]), float(self.bo[row, k]), json_float(self.bp[row, k])]
                for k in np.flatnonzero(self.bs[row] >= 0).tolist()
            ],
            "rejected_in_row": int(self.rejected[row]),
            "confident_in_row": int(self.confident_run[row]),
            "gated_in_row": int(self.gated[row]),
            "unmatched": bool(self.unmatched[row]),
            "lost": self.lost[row],
            "last_report": None if last is None else report_dict(last),
        }

    def restore_row(self, row: int, data: dict[str, Any]) -> int:
        """Fill an empty row from :meth:`row_state`'s dict; returns the hypotheses kept."""
        states = [int(s) for s in data["states"]][: self.k]
        m = len(states)
        self.hs[row, :m] = states
        for name, values in data["slots"].items():
            if name in SLOT_FIELDS:
                getattr(self, name)[row, :m] = values[:m]
        for name, value in data["vehicle"].items():
            if name in VEHICLE_FIELDS:
                getattr(self, name)[row] = math.nan if value is None else value
        kf = self.kf
        for arr, value in zip(
            (kf.t, kf.s, kf.v, kf.pss, kf.psv, kf.pvv), data["filter"], strict=True
        ):
            arr[row] = math.nan if value is None else value
        before = data.get("before", [])[: self.k]  # (a state saved without them: not known)
        for k, (state, offset, log_p) in enumerate(before):
            self.bs[row, k], self.bo[row, k] = int(state), float(offset)
            self.bp[row, k] = -math.inf if log_p is None else float(log_p)
        self.rejected[row] = int(data["rejected_in_row"])
        self.confident_run[row] = int(data["confident_in_row"])
        self.gated[row] = int(data.get("gated_in_row", 0))
        self.unmatched[row] = bool(data["unmatched"])
        self.lost[row] = data["lost"]
        if "sp" not in data["vehicle"]:  # a state saved before vehicles were shown later
            self.sp[row] = 1.0
        lr = data["last_report"]
        self.last[row] = None if lr is None else VehicleReport(**lr)
        return m


def json_float(value: float) -> float | None:
    """A float for JSON: NaN becomes None."""
    v = float(value)
    return None if math.isnan(v) else v


def report_dict(r: VehicleReport) -> dict[str, Any]:
    """A report as a JSON-ready dict (enough to resume positioning)."""
    d = {name: getattr(r, name) for name in r.__dataclass_fields__}
    if d.get("track_position") is not None:
        d["track_position"] = None  # not needed to resume positioning
    if d.get("route") is not None:
        d["route"] = list(d["route"])
    return d
