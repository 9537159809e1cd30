"""The simulator: trams driving their routes, and what a run yields.

:class:`Simulator` prepares every tram's plan (:mod:`antikol.sim.planning`), steps the
dynamics (:mod:`antikol.sim.dynamics`), turns the history into true states
(:class:`~antikol.sim.truth.Truth`) and applies the GPS model (:mod:`antikol.sim.gps`).
:class:`SimulationResult` holds the outcome and writes it as a replay CSV and as
per-vehicle NMEA logs; NMEA logs carry ``epoch_utc_s + t`` as UTC.

The dynamics are deterministic; the GPS noise is seeded per tram from
``(seed, vehicle_id)``.
"""

from __future__ import annotations

import itertools
import logging
import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Final, TypeAlias

import numpy as np
import numpy.typing as npt

from antikol.ingest.hfp_writer import write_hfp
from antikol.ingest.nmea_writer import format_gga, format_rmc, format_vtg
from antikol.ingest.replaylog import write_replay_csv
from antikol.report import VehicleReport
from antikol.sim.conflicts import ConflictIndex
from antikol.sim.dynamics import BRAKE_CODES, Dynamics, History
from antikol.sim.epochs import noise_generators
from antikol.sim.gps import GpsModel, observe
from antikol.sim.planning import DEFAULT_SPEED_MPS, SpeedPlan, VehiclePlan
from antikol.sim.truth import FixLog, Truth
from antikol.sim.urban_gps import UrbanGpsModel, observe_urban
from antikol.sim.vehicles import TramSpec
from trackmap import TrackMap

__all__ = ["DEFAULT_EPOCH_UTC_S", "ReceiverModel", "SimulationResult", "Simulator"]

#: The receiver models a simulation can use.
ReceiverModel: TypeAlias = GpsModel | UrbanGpsModel

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Default UTC time of simulation time 0 (2023-11-14 22:13:20 UTC), s since the Unix epoch.
DEFAULT_EPOCH_UTC_S: Final = 1_700_000_000.0


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """What :meth:`Simulator.run` returns.

    Attributes
    ----------
    truth : dict of str to Truth
        True states per vehicle id, in the order of the trams.
    reports : tuple of VehicleReport
        Noisy reports of all trams, sorted by time (then tram order). ``t`` is simulation
        seconds.
    fixes : dict of str to FixLog
        Every fix epoch per vehicle with its error terms (including dropped fixes).
    plans : dict of str to SpeedPlan
        Each tram's static speed profile and stops.
    specs : tuple of TramSpec
    gps : GpsModel or UrbanGpsModel
    dt_s, duration_s : float
        Step and simulated duration, s.
    seed : int
    epoch_utc_s : float
        UTC time of simulation time 0, seconds since the Unix epoch (used for NMEA).
    """

    truth: dict[str, Truth]
    reports: tuple[VehicleReport, ...]
    fixes: dict[str, FixLog]
    plans: dict[str, SpeedPlan]
    specs: tuple[TramSpec, ...]
    gps: ReceiverModel
    dt_s: float
    duration_s: float
    seed: int
    epoch_utc_s: float

    def reports_of(self, vehicle_id: str) -> list[VehicleReport]:
        """The reports of one vehicle, in time order."""
        if vehicle_id not in self.truth:
            raise KeyError(f"no simulated vehicle {vehicle_id!r}")
        return [r for r in self.reports if r.vehicle_id == vehicle_id]

    def write_csv(self, path: str | os.PathLike[str], *, extra_columns: Sequence[str] = ()) -> Path:
        """Write the reports as a replay CSV (:func:`antikol.ingest.replaylog.write_replay_csv`).

        The header is :data:`~antikol.ingest.replaylog.REPLAY_COLUMNS` followed by the
        chosen ``extra_columns``; ``t`` is simulation seconds. With the optional columns
        ``braking`` and ``length_m`` (and ``antenna_offset_m``) the log replays with the
        trams' brake states and lengths.

        Parameters
        ----------
        path : str or path-like
        extra_columns : sequence of str
            Any of :data:`~antikol.ingest.replaylog.REPLAY_OPTIONAL_COLUMNS` (``braking``,
            ``length_m``, ``antenna_offset_m``, ``seq``, ``hdop``, ``fix_quality``,
            ``odometer_m``).

        Returns
        -------
        pathlib.Path

        Raises
        ------
        ValueError
            An unknown extra column, or one given twice.
        """
        return write_replay_csv(path, self.reports, extra_columns=extra_columns)

    def write_hfp(self, path: str | os.PathLike[str]) -> Path:
        """Write the reports as an HSL-style HFP log of JSON lines
        (:func:`antikol.ingest.hfp_writer.write_hfp`): times ``epoch_utc_s + t``, a
        report without a fix as ``loc`` ``N/A`` without a position, the odometer as
        ``odo``. :func:`antikol.ingest.hfp.read_hfp` reads it back, the vehicles as
        ``"40/<number>"`` (``T07``: ``"40/7"``).

        Parameters
        ----------
        path : str or path-like

        Returns
        -------
        pathlib.Path
        """
        return write_hfp(path, self.reports, epoch_utc_s=self.epoch_utc_s)

    def write_nmea(
        self, directory: str | os.PathLike[str], *, vtg: bool = True, talker: str = "GN"
    ) -> list[Path]:
        """Write one NMEA log per vehicle, ``<vehicle_id>.nmea``: RMC, VTG, GGA per fix.

        The sentence order is a u-blox receiver's. NMEA times are ``epoch_utc_s + t``
        (UTC, 0.01 s resolution), so :func:`antikol.ingest.nmea.read_nmea_file` gives back ``t``
        shifted by ``epoch_utc_s`` (it emits the first fix on its RMC, before it has seen
        a GGA, and skips that epoch's VTG and GGA as unpaired). Vehicles without fixes get
        an empty file.

        Parameters
        ----------
        directory : str or path-like
            Created if missing.
        vtg : bool
            Also write a VTG sentence per fix.
        talker : str
            NMEA talker id (default ``GN``).

        Returns
        -------
        list of pathlib.Path
            The files written, in tram order.

        Raises
        ------
        ValueError
            A vehicle id cannot be a file name (path separators, ``.`` or ``..``).
        """
        folder = Path(directory)
        for vid in self.truth:
            if "/" in vid or "\\" in vid or os.sep in vid or vid in (".", ".."):
                raise ValueError(f"vehicle id {vid!r} cannot be used as an NMEA file name")
        folder.mkdir(parents=True, exist_ok=True)
        lines: dict[str, list[str]] = {vid: [] for vid in self.truth}
        for r in self.reports:
            shifted = replace(r, t=r.t + self.epoch_utc_s)
            out = lines[r.vehicle_id]
            out.append(format_rmc(shifted, talker=talker))
            if vtg:
                out.append(format_vtg(shifted, talker=talker))
            out.append(format_gga(shifted, talker=talker))
        paths = []
        for vid, text in lines.items():
            path = folder / f"{vid}.nmea"
            with path.open("w", newline="", encoding="ascii") as fh:
                fh.write("".join(line + "\r\n" for line in text))
            paths.append(path)
        return paths


class Simulator:
    """Trams driving their routes over a track map, with noisy GPS reports.

    Parameters
    ----------
    net : TrackMap
    trams : sequence of TramSpec
        Vehicle ids must be unique.
    gps : GpsModel or UrbanGpsModel, optional
        Receiver model of every tram (default :class:`GpsModel` (); the realistic street
        receiver is :meth:`GpsModel.urban`).
    dt_s : float
        Integration step, s (default 0.1).
    seed : int
        Seed of the GPS noise (each tram draws from generators seeded by
        ``(seed, vehicle_id)``).
    epoch_utc_s : float
        UTC time of simulation time 0, seconds since the Unix epoch; NMEA output carries
        ``epoch_utc_s + t`` while reports keep simulation seconds (default 1.7e9,
        2023-11-14 22:13:20 UTC).
    default_speed_mps : float
        Limit on edges without ``maxspeed``, m/s (default 50 km/h).
    yield_at_conflicts : bool
        Trams give way at merges and crossings (see :mod:`antikol.sim.conflicts`); False
        lets them run through each other there.
    grid_m : float
        Spacing of the speed-profile grid along routes, metres (default 2).
    vehicle_width_m : float
        Width of the trams, metres (default 2.5); sets the clearance at diamond crossings
        (see :func:`~antikol.sim.conflicts.crossing_clearance_m`).

    Raises
    ------
    ValueError
        Duplicate vehicle ids, a route with a move the map does not permit, or a bad
        option.
    trackmap.UnknownEdgeError
        A route uses an edge the map lacks.

    Notes
    -----
    Construction precomputes every tram's :class:`SpeedPlan` (see :attr:`plans`);
    :meth:`run` can be called several times and always starts from the beginning.
    """

    def __init__(
        self,
        net: TrackMap,
        trams: Sequence[TramSpec],
        *,
        gps: ReceiverModel | None = None,
        dt_s: float = 0.1,
        seed: int = 0,
        epoch_utc_s: float = DEFAULT_EPOCH_UTC_S,
        default_speed_mps: float = DEFAULT_SPEED_MPS,
        yield_at_conflicts: bool = True,
        grid_m: float = 2.0,
        vehicle_width_m: float = 2.5,
    ) -> None:
        if not (math.isfinite(dt_s) and 0 < dt_s <= 1.0):
            raise ValueError(f"dt_s must be in (0, 1] s, got {dt_s!r}")
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise ValueError(f"seed must be a non-negative int, got {seed!r}")
        if not (math.isfinite(default_speed_mps) and default_speed_mps > 0):
            raise ValueError(f"default_speed_mps must be > 0 m/s, got {default_speed_mps!r}")
        if not (math.isfinite(grid_m) and 0.1 <= grid_m <= 50.0):
            raise ValueError(f"grid_m must be in [0.1, 50] m, got {grid_m!r}")
        if not (math.isfinite(vehicle_width_m) and 0 < vehicle_width_m <= 10.0):
            raise ValueError(f"vehicle_width_m must be in (0, 10] m, got {vehicle_width_m!r}")
        if not math.isfinite(epoch_utc_s):
            raise ValueError(f"epoch_utc_s must be finite, got {epoch_utc_s!r}")
        specs = tuple(trams)
        seen: set[str] = set()
        for spec in specs:
            if not isinstance(spec, TramSpec):
                raise ValueError(f"trams must be TramSpec records, got {type(spec)!r}")
            if spec.vehicle_id in seen:
                raise ValueError(f"two trams have vehicle_id {spec.vehicle_id!r}")
            seen.add(spec.vehicle_id)
            steps = spec.route.steps
            for e, _ in steps:
                net.edge(e)
            graph = net.traversal_any if spec.route.wrong_way else net.traversal
            for a, b in itertools.pairwise(steps):
                if not graph.has_edge(a, b):
                    raise ValueError(
                        f"tram {spec.vehicle_id}: its route moves {a} -> {b}, which this map "
                        "does not permit (a route of another map?)"
                    )
        self.net = net
        self.specs = specs
        self.gps: ReceiverModel = gps if gps is not None else GpsModel()
        self.dt_s = float(dt_s)
        self.seed = int(seed)
        self.epoch_utc_s = float(epoch_utc_s)
        self.default_speed_mps = float(default_speed_mps)
        self.yield_at_conflicts = bool(yield_at_conflicts)
        self.grid_m = float(grid_m)
        self.vehicle_width_m = float(vehicle_width_m)
        index = ConflictIndex.of(net, width_m=self.vehicle_width_m)
        coords: dict[int, FloatArray] = {}
        t0 = time.perf_counter()
        self._veh = [
            VehiclePlan(
                i,
                spec,
                net,
                grid_m=self.grid_m,
                default_speed_mps=self.default_speed_mps,
                lead_in_m=self._lookbehind_m(spec) + 20.0,
                coords=coords,
                conflicts=index,
            )
            for i, spec in enumerate(specs)
        ]
        logger.debug("simulator: %d trams prepared in %.3f s", len(specs), time.perf_counter() - t0)

    @staticmethod
    def _lookbehind_m(spec: TramSpec) -> float:
        v = spec.vmax_mps
        return (
            spec.length_m
            + spec.standstill_gap_m
            + spec.time_headway_s * v
            + v * v / (2.0 * spec.plan_decel_mps2)
        )

    @property
    def vehicle_ids(self) -> tuple[str, ...]:
        """The trams' ids, in order."""
        return tuple(s.vehicle_id for s in self.specs)

    @property
    def plans(self) -> dict[str, SpeedPlan]:
        """Each tram's static speed profile and stops."""
        return {v.spec.vehicle_id: v.plan for v in self._veh}

    def rng_for(self, vehicle_id: str) -> tuple[np.random.Generator, np.random.Generator]:
        """The two generators of a tram's GPS noise (normals, uniforms), freshly seeded."""
        return noise_generators(self.seed, vehicle_id)

    # ------------------------------------------------------------------------- running
    def run(self, duration_s: float, *, progress: bool = False) -> SimulationResult:
        """Simulate ``duration_s`` seconds from time 0.

        Parameters
        ----------
        duration_s : float
            Simulated time, s (rounded to whole steps).
        progress : bool
            Show a tqdm progress bar.

        Returns
        -------
        SimulationResult

        Raises
        ------
        ValueError
            ``duration_s`` is negative or not finite.
        """
        if not (math.isfinite(duration_s) and duration_s >= 0):
            raise ValueError(f"duration_s must be a finite time >= 0 s, got {duration_s!r}")
        t0 = time.perf_counter()
        hist = Dynamics(
            self._veh,
            dt_s=self.dt_s,
            grid_m=self.grid_m,
            yield_at_conflicts=self.yield_at_conflicts,
        ).run(round(duration_s / self.dt_s), progress=progress)
        t1 = time.perf_counter()
        truth = {v.spec.vehicle_id: self._truth(v, hist) for v in self._veh}
        reports, fixes = self._reports(truth)
        t2 = time.perf_counter()
        logger.info(
            "simulated %d trams for %.0f s: dynamics %.2f s, truth and reports %.2f s",
            len(self._veh),
            duration_s,
            t1 - t0,
            t2 - t1,
        )
        return SimulationResult(
            truth=truth,
            reports=reports,
            fixes=fixes,
            plans=self.plans,
            specs=self.specs,
            gps=self.gps,
            dt_s=self.dt_s,
            duration_s=hist.n_steps * self.dt_s,
            seed=self.seed,
            epoch_utc_s=self.epoch_utc_s,
        )

    # ------------------------------------------------------------------------- outputs
    def _truth(self, veh: VehiclePlan, hist: History) -> Truth:
        """One tram's true states from the run's history (the steps it was in service)."""
        i = veh.index
        rows = np.flatnonzero(hist.present[:, i])
        tr = veh.track
        spec = veh.spec
        t = rows.astype(np.float64) * self.dt_s
        s = hist.s[rows, i]
        k, edge, off = tr.locate(s)
        rk, redge, roff = tr.locate(s - spec.length_m)
        ak, _, _ = tr.locate(s - spec.antenna_m)
        x, y = tr.xy(s)
        ax, ay = tr.xy(s - spec.antenna_m)
        rx, ry = tr.xy(s - spec.length_m)
        heading = (np.degrees(tr.grid_heading_rad(s)) + tr.convergence_deg(s)) % 360.0
        names = np.array(BRAKE_CODES)
        return Truth(
            vehicle_id=spec.vehicle_id,
            length_m=spec.length_m,
            antenna_offset_m=spec.antenna_m,
            t_s=t,
            distance_m=s,
            edge_id=edge,
            offset_m=off,
            direction=tr.dir[k],
            speed_mps=hist.v[rows, i],
            accel_mps2=hist.a[rows, i],
            x_m=x,
            y_m=y,
            antenna_x_m=ax,
            antenna_y_m=ay,
            heading_deg=heading,
            braking=names[hist.code[rows, i]],
            in_tunnel=tr.tunnel[ak],
            rear_edge_id=redge,
            rear_offset_m=roff,
            rear_direction=tr.dir[rk],
            rear_x_m=rx,
            rear_y_m=ry,
        )

    def _reports(
        self, truth: dict[str, Truth]
    ) -> tuple[tuple[VehicleReport, ...], dict[str, FixLog]]:
        """All trams' reports sorted by time (then tram order), and their fix logs."""
        out: list[tuple[float, int, VehicleReport]] = []
        logs: dict[str, FixLog] = {}
        for veh in self._veh:
            vid = veh.spec.vehicle_id
            if isinstance(self.gps, UrbanGpsModel):
                reports, logs[vid] = observe_urban(
                    self.gps, veh.spec, veh.track, truth[vid], self.net, self.rng_for(vid)
                )
            else:
                reports, logs[vid] = observe(
                    self.gps, veh.spec, veh.track, truth[vid], self.net, self.rng_for(vid)
                )
            out.extend((r.t, veh.index, r) for r in reports)
        out.sort(key=lambda item: (item[0], item[1]))
        return tuple(r for _, _, r in out), logs
