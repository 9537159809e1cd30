"""True states of simulated trams, and their GPS fixes with the error terms.

:class:`Truth` holds what really happened to one tram every simulation step; it is the
source of ground truth for scoring (:mod:`antikol.evaluation.groundtruth`). :class:`FixLog`
holds every GPS fix epoch with its error terms, for analysing estimators.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from antikol.report import BrakeState

__all__ = ["FixLog", "Truth", "TruthState"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True, slots=True)
class TruthState:
    """The true state of one tram at one time (see :class:`Truth` for the fields)."""

    vehicle_id: str
    t_s: float
    distance_m: float
    edge_id: int
    offset_m: float
    direction: int
    speed_mps: float
    accel_mps2: float
    x_m: float
    y_m: float
    antenna_x_m: float
    antenna_y_m: float
    heading_deg: float
    braking: BrakeState
    in_tunnel: bool


@dataclass(frozen=True, eq=False)
class Truth:
    """True states of one tram, sampled every simulation step while it is in service.

    All arrays have one entry per sample. Positions are in the map's local frame.

    Attributes
    ----------
    vehicle_id : str
    length_m, antenna_offset_m : float
        Vehicle length and antenna distance behind the front, metres.
    t_s : ndarray
        Simulation time, s (a contiguous run of steps from the tram's appearance to the
        end of the run or its exit).
    distance_m : ndarray
        Route distance of the front, metres.
    edge_id, offset_m, direction : ndarray
        Track position of the front (offset in metres from the edge's first vertex).
    speed_mps, accel_mps2 : ndarray
        Speed, m/s; acceleration applied from this sample to the next, m/s².
    x_m, y_m : ndarray
        Front position, metres.
    antenna_x_m, antenna_y_m : ndarray
        Antenna position, metres.
    heading_deg : ndarray
        True heading of travel at the front, degrees clockwise from north.
    braking : ndarray of str
        ``"none"``, ``"service"`` or ``"emergency"`` (what the tram would announce).
    in_tunnel : ndarray of bool
        Whether the antenna is on a tunnel edge.
    rear_edge_id, rear_offset_m, rear_direction : ndarray
        Track position of the rear.
    rear_x_m, rear_y_m : ndarray
        Rear position, metres.
    """

    vehicle_id: str
    length_m: float
    antenna_offset_m: float
    t_s: FloatArray
    distance_m: FloatArray
    edge_id: IntArray
    offset_m: FloatArray
    direction: IntArray
    speed_mps: FloatArray
    accel_mps2: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    antenna_x_m: FloatArray
    antenna_y_m: FloatArray
    heading_deg: FloatArray
    braking: npt.NDArray[np.str_]
    in_tunnel: BoolArray
    rear_edge_id: IntArray
    rear_offset_m: FloatArray
    rear_direction: IntArray
    rear_x_m: FloatArray
    rear_y_m: FloatArray

    def __len__(self) -> int:
        return len(self.t_s)

    def covers(self, t_s: float) -> bool:
        """Whether the tram is in service at ``t_s`` (within half a step of a sample)."""
        if not len(self.t_s):
            return False
        half = 0.5 * (self.t_s[1] - self.t_s[0]) if len(self.t_s) > 1 else 1e-9
        return bool(self.t_s[0] - half <= t_s <= self.t_s[-1] + half)

    def index_at(self, t_s: float) -> int:
        """Index of the sample nearest to ``t_s``.

        Raises
        ------
        ValueError
            The tram is not in service at ``t_s``.
        """
        if not self.covers(t_s):
            span = f"{self.t_s[0]:.3f}..{self.t_s[-1]:.3f} s" if len(self.t_s) else "never"
            raise ValueError(f"tram {self.vehicle_id} is not in service at t={t_s!r} s ({span})")
        k = int(np.searchsorted(self.t_s, t_s))
        k = min(max(k, 0), len(self.t_s) - 1)
        if k > 0 and abs(self.t_s[k - 1] - t_s) <= abs(self.t_s[k] - t_s):
            k -= 1
        return k

    def at(self, t_s: float, *, interpolate: bool = False) -> TruthState:
        """The state at ``t_s``: the nearest sample, or linearly interpolated.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        interpolate : bool
            Interpolate the continuous quantities (distance, speed, positions, heading;
            the offset too when both samples are on the same edge) between the samples
            around ``t_s``; discrete ones (edge, direction, braking, tunnel) come from the
            nearest sample.

        Raises
        ------
        ValueError
            The tram is not in service at ``t_s``.
        """
        k = self.index_at(t_s)
        state = TruthState(
            vehicle_id=self.vehicle_id,
            t_s=float(self.t_s[k]),
            distance_m=float(self.distance_m[k]),
            edge_id=int(self.edge_id[k]),
            offset_m=float(self.offset_m[k]),
            direction=int(self.direction[k]),
            speed_mps=float(self.speed_mps[k]),
            accel_mps2=float(self.accel_mps2[k]),
            x_m=float(self.x_m[k]),
            y_m=float(self.y_m[k]),
            antenna_x_m=float(self.antenna_x_m[k]),
            antenna_y_m=float(self.antenna_y_m[k]),
            heading_deg=float(self.heading_deg[k]),
            braking=str(self.braking[k]),  # type: ignore[arg-type]
            in_tunnel=bool(self.in_tunnel[k]),
        )
        if not interpolate or len(self.t_s) < 2:
            return state
        i = int(np.clip(np.searchsorted(self.t_s, t_s, side="right") - 1, 0, len(self.t_s) - 2))
        w = float(np.clip((t_s - self.t_s[i]) / (self.t_s[i + 1] - self.t_s[i]), 0.0, 1.0))

        def lerp(a: FloatArray) -> float:
            return float(a[i] + w * (a[i + 1] - a[i]))

        turn = (self.heading_deg[i + 1] - self.heading_deg[i] + 180.0) % 360.0 - 180.0
        same_edge = self.edge_id[i] == self.edge_id[i + 1]
        return replace(
            state,
            t_s=float(t_s),
            distance_m=lerp(self.distance_m),
            offset_m=lerp(self.offset_m) if same_edge else state.offset_m,
            speed_mps=lerp(self.speed_mps),
            x_m=lerp(self.x_m),
            y_m=lerp(self.y_m),
            antenna_x_m=lerp(self.antenna_x_m),
            antenna_y_m=lerp(self.antenna_y_m),
            heading_deg=float((self.heading_deg[i] + w * turn) % 360.0),
        )


@dataclass(frozen=True, eq=False)
class FixLog:
    """Every GPS fix epoch of one tram, with the error terms, for analysing estimators.

    Arrays have one entry per epoch (multiples of ``1/rate_hz`` while the tram is in
    service), whether or not a report was sent. Positions are in the map's local frame.

    Attributes
    ----------
    vehicle_id : str
    t_s : ndarray
        Simulation time of the epoch, s.
    available : ndarray of bool
        A report was sent (no random miss, not in or just out of a tunnel).
    in_tunnel : ndarray of bool
        The antenna was on a tunnel edge.
    true_x_m, true_y_m : ndarray
        True antenna position, metres.
    x_m, y_m : ndarray
        Measured position (true + bias + white noise + outlier), metres.
    bias_x_m, bias_y_m : ndarray
        The Gauss–Markov bias, metres.
    outlier : ndarray of bool
        An outlier was added.
    true_speed_mps, speed_mps : ndarray
        True and measured speed, m/s.
    true_course_deg, course_deg : ndarray
        True track heading at the antenna and reported course (NaN when no report),
        degrees clockwise from true north.
    canyon : ndarray, optional
        Urban-canyon factor in [0, 1] at the antenna (urban receiver model only).
    bias_lateral_m : ndarray, optional
        The across-track (left-positive) part of the bias, metres (urban model only).
    bias_jump : ndarray of bool, optional
        The bias was re-drawn at this epoch (a satellite geometry change; urban model).
    outage : ndarray of bool, optional
        The receiver was in an urban-canyon outage (urban model).
    no_fix_report : ndarray of bool, optional
        A report without a position fix (``fix_quality`` 0) was sent (urban model).
    odometer_m : ndarray, optional
        Odometer reading, metres (models with an odometer).
    """

    vehicle_id: str
    t_s: FloatArray
    available: BoolArray
    in_tunnel: BoolArray
    true_x_m: FloatArray
    true_y_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    bias_x_m: FloatArray
    bias_y_m: FloatArray
    outlier: BoolArray
    true_speed_mps: FloatArray
    speed_mps: FloatArray
    true_course_deg: FloatArray
    course_deg: FloatArray
    canyon: FloatArray | None = None
    bias_lateral_m: FloatArray | None = None
    bias_jump: BoolArray | None = None
    outage: BoolArray | None = None
    no_fix_report: BoolArray | None = None
    odometer_m: FloatArray | None = None

    def __len__(self) -> int:
        return len(self.t_s)
