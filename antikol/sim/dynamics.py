"""Driving dynamics: the vectorised time-stepping of all simulated trams.

Driver
    Each step the driver takes the largest acceleration that keeps the tram under every
    braking curve after the step: the envelope (linearised in ``v²``), the next stop, the
    route end, the leader and any conflict point where it has to yield. For a target at
    distance ``D`` with speed ``v_t`` the condition ``v(t+dt)² ≤ v_t² + 2·b·(D − Δs)`` with
    ``Δs = v·dt + a·dt²/2`` is a quadratic in ``a`` solved exactly, so a tram following a
    braking curve stops *exactly* at its target. Acceleration is limited by the profile's
    traction; planned braking uses ``comfort_decel_mps2`` (default 0.8 × service) and may
    use the full service brake; only the safety constraints (leader, conflict) may go
    beyond the service brake, up to the emergency brake, and then the report carries
    ``braking="emergency"``.
Car following
    Leaders are found by :class:`~antikol.sim.following.BodyLocator`. The driver plans to
    stay ``standstill_gap_m + time_headway_s·v`` behind the point where the leader would
    stop with its service brake (Gipps' safe-speed idea), with comfort braking; the safety
    constraint is the service-brake curve to ``standstill_gap_m`` behind that point, so a
    leader appearing too close costs a strong brake, not an emergency. Against an oncoming
    tram the driver subtracts that tram's stopping distance instead. Leaders are searched
    every 0.5 s (one vectorised look-up for all trams) and tracked in between.
Conflict points
    Settled every 0.5 s by :class:`~antikol.sim.conflicts.ConflictArbiter`; a tram that has
    to yield brakes to the fouling point like to a stop.
Stops and route end
    The front stops at every stop position on the route (exactly, within 0.1 m), waits
    ``dwell_s`` and leaves with the traction limit. At the route end the tram stops and
    stays (an obstacle for others), or with ``exit_at_end`` drives on and leaves.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
import numpy.typing as npt

from antikol.report import BrakeState
from antikol.sim.conflicts import ConflictArbiter
from antikol.sim.events import resolved
from antikol.sim.following import BodyLocator
from antikol.sim.planning import VehiclePlan

__all__ = ["BRAKE_CODES", "Dynamics", "History"]

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: Brake state of each code in :attr:`History.code` (the code is the index).
BRAKE_CODES: Final[tuple[BrakeState, ...]] = ("none", "service", "emergency")
_DETECT_EVERY_S: Final = 0.5  # leader and conflict search period
_ARRIVE_TOL_M: Final = 0.1  # a tram this close to its stop (and stopped) has arrived
_BRAKE_FLAG_MPS2: Final = 0.05  # deceleration above which the service brake is reported

#: Fast "any true" of a boolean array (much cheaper than ``ndarray.any`` on small arrays).
_nz = np.count_nonzero


@dataclass(frozen=True)
class History:
    """State of every tram at every step of a run (rows: steps 0..n_steps, columns: trams).

    Attributes
    ----------
    n_steps : int
    s : ndarray
        Route distance of the front, metres.
    v : ndarray
        Speed, m/s.
    a : ndarray
        Acceleration applied from this step to the next, m/s².
    code : ndarray of int8
        Brake state, an index into :data:`BRAKE_CODES`.
    present : ndarray of bool
        In service.
    """

    n_steps: int
    s: FloatArray
    v: FloatArray
    a: FloatArray
    code: npt.NDArray[np.int8]
    present: BoolArray


class Dynamics:
    """The vectorised time-stepping of all trams (one instance per run).

    Parameters
    ----------
    plans : sequence of VehiclePlan
        The trams, in order (``plans[i].index == i``).
    dt_s : float
        Integration step, s.
    grid_m : float
        Speed-profile grid spacing, metres (the fallback when there are no trams).
    yield_at_conflicts : bool
        Let trams give way at conflict points.
    """

    def __init__(
        self,
        plans: Sequence[VehiclePlan],
        *,
        dt_s: float,
        grid_m: float,
        yield_at_conflicts: bool,
    ) -> None:
        vehs = plans
        self.n = len(vehs)
        dt = dt_s
        self.dt = dt
        specs = [v.spec for v in vehs]
        self.specs = specs
        self.yield_at_conflicts = yield_at_conflicts
        f = np.array
        self.route_len = f([v.route_len for v in vehs], dtype=float)
        self.length = f([s.length_m for s in specs], dtype=float)
        self.gap0 = f([s.standstill_gap_m for s in specs], dtype=float)
        self.headway = f([s.time_headway_s for s in specs], dtype=float)
        self.b_plan = f([s.plan_decel_mps2 for s in specs], dtype=float)
        self.b_serv = f([s.profile.service_decel_mps2 for s in specs], dtype=float)
        self.b_emer = f([s.profile.emergency_decel_mps2 for s in specs], dtype=float)
        self.buildup = f([s.profile.emergency_buildup_s for s in specs], dtype=float)
        self.traction = f([s.profile.traction_mps2 for s in specs], dtype=float)
        self.depart = f([s.depart_s for s in specs], dtype=float)
        self.v0 = f([s.initial_speed_mps for s in specs], dtype=float)
        self.exit = f([s.exit_at_end for s in specs], dtype=bool)
        vmax = max((s.vmax_mps for s in specs), default=1.0)
        self.lookahead = f(
            [
                s.vmax_mps**2 / (2 * s.plan_decel_mps2)
                + s.standstill_gap_m
                + s.time_headway_s * s.vmax_mps
                + 2 * s.vmax_mps * _DETECT_EVERY_S
                + 60.0
                for s in specs
            ],
            dtype=float,
        )
        # speed envelope segments, padded so a window of m segments never leaves a tram
        min_dg = min((v.dg for v in vehs), default=grid_m)
        self.m = min(max(2, math.ceil(vmax * dt / min_dg) + 2), 64)
        e_start, slope, base, nseg = [], [], [], []
        pos = 0
        for v in vehs:
            env2 = v.env2
            sl = np.diff(env2) / v.dg
            sl = np.concatenate((sl, np.full(self.m, sl[-1])))
            st = np.concatenate((env2[:-1], np.full(self.m, env2[-1])))
            e_start.append(st)
            slope.append(sl)
            base.append(pos)
            nseg.append(len(env2) - 1)
            pos += len(sl)
        self.e_start = np.concatenate(e_start) if e_start else np.zeros(0)
        self.slope = np.concatenate(slope) if slope else np.zeros(0)
        self.seg_base = f(base, dtype=np.int64)
        self.nseg = f(nseg, dtype=np.int64)
        self.dg = f([v.dg for v in vehs], dtype=float)
        # stops, each tram's list closed by an infinite sentinel
        sd, sw, sb = [], [], []
        pos = 0
        for v in vehs:
            sb.append(pos)
            sd.extend([c.distance_m for c in v.plan_stops] + [math.inf])
            sw.extend([c.dwell_s for c in v.plan_stops] + [0.0])
            pos += len(v.plan_stops) + 1
        self.stop_d = f(sd, dtype=float)
        self.stop_dwell = f(sw, dtype=float)
        self.stop_base = f(sb, dtype=np.int64)
        self.bodies = BodyLocator([v.track for v in vehs], self.length)
        self.arbiter = ConflictArbiter(
            [v.passes for v in vehs], self.length, self.b_plan, detect_every_s=_DETECT_EVERY_S
        )
        # scripts
        self.scripted = [(v.index, v.spec.script) for v in vehs if v.spec.script]

    # ---------------------------------------------------------------------------------
    def run(self, n_steps: int, *, progress: bool) -> History:
        """Step all trams from time 0 through ``n_steps`` steps.

        Parameters
        ----------
        n_steps : int
            Number of steps of ``dt_s`` seconds.
        progress : bool
            Show a tqdm progress bar (when tqdm is installed).

        Returns
        -------
        History
        """
        n = self.n
        dt = self.dt
        hist = History(
            n_steps=n_steps,
            s=np.zeros((n_steps + 1, n)),
            v=np.zeros((n_steps + 1, n)),
            a=np.zeros((n_steps + 1, n)),
            code=np.zeros((n_steps + 1, n), dtype=np.int8),
            present=np.zeros((n_steps + 1, n), dtype=bool),
        )
        if n == 0:
            return hist
        s = np.zeros(n)
        v = np.zeros(n)
        present = np.zeros(n, dtype=bool)
        waiting = np.ones(n, dtype=bool)
        due_seen = np.zeros(n, dtype=bool)
        at_end = np.zeros(n, dtype=bool)
        stop_idx = np.zeros(n, dtype=np.int64)
        dwell_until = np.full(n, np.inf)  # end of the current dwell, inf when none
        code = np.zeros(n, dtype=np.int8)
        self.leader = np.full(n, -1, dtype=np.int64)
        self.lead_tail0 = np.zeros(n)
        self.lead_join = np.full(n, -np.inf)
        self.lead_s0 = np.zeros(n)
        self.lead_sign = np.ones(n)
        self.yield_pos = np.full(n, np.inf)
        cap = np.full(n, np.inf)
        hold = np.zeros(n, dtype=bool)
        inatt = np.zeros(n, dtype=bool)
        emerg = np.zeros(n, dtype=bool)
        building = np.zeros(n, dtype=bool)
        k_detect = max(1, round(_DETECT_EVERY_S / dt))
        m_idx = np.arange(self.m)
        bar = _progress_bar(n_steps, progress)
        b_plan, b_serv, b_emer = self.b_plan, self.b_serv, self.b_emer
        route_len, exit_ = self.route_len, self.exit
        any_exit = bool(_nz(exit_))
        end_at = np.where(exit_, np.inf, route_len)
        scripted = bool(self.scripted)
        inv_dg = 1.0 / self.dg
        last_seg = self.nseg - 1
        # Constraint rows, each a braking curve v'² + h·v' <= e0 + g·Δs after the step:
        # rows 0-4 are what the driver plans (envelope, route end, stop, leader with time
        # headway, conflict point; comfort braking), rows 5-6 what safety needs (leader
        # and conflict point on the service-brake curve).
        g = np.empty((7, n))
        g[1:5] = -2.0 * b_plan
        g[5:7] = -2.0 * b_serv
        h = np.zeros((7, n))
        h[3] = 2.0 * b_plan * self.headway
        lin_b = h * dt - 0.5 * g * dt * dt  # the parts of the quadratic's b and c that
        lin_c = h - g * dt  # do not depend on the state (row 0 changes every step)
        e0 = np.empty((7, n))
        dist = np.empty((4, n))
        two_dt = 2.0 * dt
        four_a = 4.0 * dt * dt
        two_a = 2.0 * dt * dt
        next_depart = float(self.depart.min())
        no_one = np.zeros(n, dtype=bool)
        next_dwell_end = np.inf
        for step in range(n_steps + 1):
            t = step * dt
            # -- scripted events ------------------------------------------------------
            if scripted:
                for i, events in self.scripted:
                    cap[i] = np.inf
                    hold[i] = inatt[i] = emerg[i] = building[i] = False
                    for ev in events:
                        if not ev.active(t):
                            continue
                        if ev.kind == "speed_cap":
                            cap[i] = min(cap[i], resolved(ev.speed_mps))
                        elif ev.kind == "hold":
                            hold[i] = True
                        elif ev.kind == "inattentive":
                            inatt[i] = True
                        else:
                            emerg[i] = True
                            building[i] = building[i] or t - ev.t_s < self.buildup[i] - 1e-9
                emerg &= present
            # -- end of dwell -------------------------------------------------------
            if t + 1e-9 >= next_dwell_end:
                ended = dwell_until <= t + 1e-9
                stop_idx[ended] += 1
                dwell_until[ended] = np.inf
                next_dwell_end = float(dwell_until.min())
            dwelling = dwell_until < np.inf
            # -- appearance, leaders and conflicts ---------------------------------------
            newly = False
            due = no_one
            if t + 1e-9 >= next_depart:
                due = waiting & (self.depart <= t + 1e-9)
                newly = bool(_nz(due & ~due_seen))
                due_seen |= due
                later = self.depart[waiting & ~due]
                next_depart = float(later.min()) if len(later) else np.inf
            if step % k_detect == 0 or newly:
                self._detect(t, s, v, code, present, due, waiting, at_end, dwell_until, hold)
            if _nz(due):  # blocked at the start: try again
                next_depart = t
            # -- control --------------------------------------------------------------
            sc = np.minimum(s, route_len)
            j = (sc * inv_dg).astype(np.int64)
            np.minimum(j, last_seg, out=j)
            gi = self.seg_base + j
            e0[0] = self.e_start[gi] + self.slope[gi] * (sc - j * self.dg)
            np.maximum(e0[0], 0.0, out=e0[0])
            g_env = self.slope[gi[:, None] + m_idx].min(axis=1)
            g[0] = g_env
            lin_b[0] = (-0.5 * dt * dt) * g_env
            lin_c[0] = -dt * g_env
            # targets: route end, next stop, leader, conflict point (distances, m)
            np.subtract(end_at, s, out=dist[0])
            nxt = self.stop_d[self.stop_base + stop_idx]
            np.subtract(nxt, s, out=dist[1])
            lead = self.leader
            has = lead >= 0
            if scripted:
                has &= ~inatt
            if _nz(has):
                lj = np.where(has, lead, 0)
                b_l = np.where(code[lj] == 2, b_emer[lj], b_serv[lj])
                sign = self.lead_sign
                pos = np.maximum(self.lead_tail0 + sign * (s[lj] - self.lead_s0), self.lead_join)
                gap = pos - s - self.gap0 + sign * v[lj] ** 2 / (2.0 * b_l)
                dist[2] = np.where(has & present[lj], gap, np.inf)
            else:
                dist[2] = np.inf
            np.subtract(self.yield_pos, s, out=dist[3])
            if scripted:
                dist[3][inatt] = np.inf
            np.multiply(g[1:5], dist, out=e0[1:5])
            np.multiply(g[5:7], dist[2:4], out=e0[5:7])
            np.negative(e0[1:7], out=e0[1:7])
            # largest a with (v + a·dt)² + h·(v + a·dt) <= e0 + g·(v·dt + a·dt²/2)
            b_q = two_dt * v + lin_b
            c_q = v * v - e0 + lin_c * v
            disc = b_q * b_q - four_a * c_q
            acc = (np.sqrt(np.maximum(disc, 0.0)) - b_q) / two_a
            acc[disc < 0.0] = -np.inf
            # a target reached within the step: brake exactly onto it (the quadratic
            # would let the speed run negative)
            lim = -v / dt
            stopping = acc < lim
            stopping[0] &= g_env < 0.0
            if _nz(stopping):
                with np.errstate(divide="ignore", invalid="ignore"):
                    d_eq = e0 / -g
                    repl = np.where(d_eq > 1e-9, -(v * v) / (2.0 * d_eq), -np.inf)
                acc[stopping] = repl[stopping]
            a_plan = np.minimum(self.traction, acc[:5].min(axis=0))
            if scripted:
                capped = cap < np.inf
                if _nz(capped):
                    a_cap = np.maximum((cap - v) / dt, -b_plan)
                    a_plan = np.where(capped, np.minimum(a_plan, a_cap), a_plan)
                if _nz(hold):
                    a_hold = np.maximum(lim, -b_plan)
                    a_plan = np.where(hold, np.minimum(a_plan, a_hold), a_plan)
            np.maximum(a_plan, -b_serv, out=a_plan)
            a_safe = np.maximum(np.minimum(acc[5], acc[6]), -b_emer)
            a = np.minimum(a_plan, a_safe)
            hard = a < -b_serv
            if _nz(hard):
                # a crawling tram that the service brake stops within this step anyway
                crawl = hard & (v <= b_serv * dt)
                a[crawl] = lim[crawl]
            if scripted and _nz(emerg):
                a = np.where(emerg & building, np.minimum(a, 0.0), a)
                a = np.where(emerg & ~building, np.maximum(-b_emer, lim), a)
            a[dwelling | at_end | ~present | ((v <= 0.0) & (a < 0.0))] = 0.0
            escalated = a < -b_serv - 1e-9
            if _nz(escalated) and logger.isEnabledFor(logging.DEBUG):
                self._log_escalation(t, escalated, s, v, acc)
            code = (a < -_BRAKE_FLAG_MPS2).astype(np.int8)
            code[escalated] = 2
            if scripted:
                code[emerg] = 2
            hist.s[step] = s
            hist.v[step] = v
            hist.a[step] = a
            hist.code[step] = code
            hist.present[step] = present
            if step == n_steps:
                break
            # -- integration ----------------------------------------------------------
            v1 = v + a * dt
            ds = v * dt + (0.5 * dt * dt) * a
            halt = v1 < 1e-9
            if _nz(halt):
                with np.errstate(divide="ignore", invalid="ignore"):
                    brake = np.where(a < 0.0, v * v / (2.0 * np.maximum(-a, 1e-12)), 0.0)
                ds[halt] = brake[halt]
                v1[halt] = 0.0
            v = v1
            s = s + np.maximum(ds, 0.0)
            if any_exit:
                s = np.where(exit_, s, np.minimum(s, route_len))
            else:
                np.minimum(s, route_len, out=s)
            # -- stops, route end -----------------------------------------------------
            stopped = v == 0.0
            if _nz(stopped):
                arrive = stopped & present & ~dwelling & (np.abs(nxt - s) <= _ARRIVE_TOL_M)
                if _nz(arrive):
                    dwell_until[arrive] = (t + dt) + self.stop_dwell[self.stop_base + stop_idx][
                        arrive
                    ]
                    next_dwell_end = min(next_dwell_end, float(dwell_until[arrive].min()))
                    dwelling = dwelling | arrive
            passed = nxt < s - _ARRIVE_TOL_M
            if _nz(passed):
                passed &= present & ~dwelling
                while _nz(passed):
                    for i in np.flatnonzero(passed).tolist():
                        logger.debug(
                            "tram %s passed its stop at %.1f m without stopping",
                            self.specs[i].vehicle_id,
                            nxt[i],
                        )
                    stop_idx[passed] += 1
                    nxt = self.stop_d[self.stop_base + stop_idx]
                    passed &= nxt < s - _ARRIVE_TOL_M
            near_end = s >= route_len - _ARRIVE_TOL_M
            if _nz(near_end):
                at_end |= near_end & present & ~exit_ & stopped
                gone = near_end & present & exit_ & (s >= route_len)
                if _nz(gone):
                    present = present & ~gone
            bar.update(1)
        bar.close()
        return hist

    def _log_escalation(
        self, t: float, escalated: BoolArray, s: FloatArray, v: FloatArray, acc: FloatArray
    ) -> None:
        for i in np.flatnonzero(escalated).tolist():
            lead = int(self.leader[i])
            why = (
                f"leader {self.specs[lead].vehicle_id}"
                if acc[5, i] <= acc[6, i] and lead >= 0
                else f"conflict point at {self.yield_pos[i]:.1f} m"
            )
            logger.debug(
                "t=%.1f s: tram %s at %.1f m, %.2f m/s brakes beyond the service brake for %s",
                t,
                self.specs[i].vehicle_id,
                s[i],
                v[i],
                why,
            )

    # ---------------------------------------------------------------------------------
    def _detect(
        self,
        t: float,
        s: FloatArray,
        v: FloatArray,
        code: npt.NDArray[np.int8],
        present: BoolArray,
        due: BoolArray,
        waiting: BoolArray,
        at_end: BoolArray,
        dwell_until: FloatArray,
        hold: BoolArray,
    ) -> None:
        """Let due trams appear, find every tram's leader, settle conflict points."""
        owners = np.flatnonzero(present)
        cand = np.flatnonzero(due)
        if len(cand):
            # blockers: trams in service, and due trams before this one in the list
            mt, md, mtail, mjoin, msign, mowner = self.bodies.matches(s, present | due)
            mpos = np.maximum(mtail, mjoin)
            first = present[mowner] | (mowner < mt)
            mt, md, mpos, mowner = mt[first], md[first], mpos[first], mowner[first]
            if len(mt):
                v_o = v[mowner]
                reach = self.b_plan[mowner]
                behind = -(
                    self.length[mt]
                    + self.gap0[mt]
                    + self.headway[mowner] * v_o
                    + v_o * v_o / (2.0 * reach)
                )
                ahead = (
                    self.gap0[mt]
                    + self.headway[mt] * self.v0[mt]
                    + self.v0[mt] ** 2 / (2.0 * self.b_plan[mt])
                )
                block = due[mt] & (md >= behind) & (mpos <= ahead)
                blocked = np.zeros(self.n, dtype=bool)
                blocked[mt[block]] = True
            else:
                blocked = np.zeros(self.n, dtype=bool)
            enter = due & ~blocked
            if _nz(enter):
                present |= enter
                waiting &= ~enter
                due &= ~enter
                s[enter] = 0.0
                v[enter] = self.v0[enter]
            owners = np.flatnonzero(present)
        self.leader[:] = -1
        if not len(owners):
            return
        mt, md, mtail, mjoin, msign, mowner = self.bodies.matches(s, present)
        mpos = np.maximum(mtail, mjoin)
        if len(mt):
            ok = (
                present[mt]
                & (md > s[mt])
                & (md <= s[mt] + self.lookahead[mt])
                & (mpos <= self.route_len[mt] + self.gap0[mt])
            )
            mt, mpos, msign, mowner = mt[ok], mpos[ok], msign[ok], mowner[ok]
            mtail, mjoin = mtail[ok], mjoin[ok]
        if len(mt):
            b_l = np.where(code[mowner] == 2, self.b_emer[mowner], self.b_serv[mowner])
            score = mpos + msign * v[mowner] ** 2 / (2.0 * b_l) - s[mt]
            order = np.lexsort((score, mt))
            mt, msign, mowner = mt[order], msign[order], mowner[order]
            mtail, mjoin = mtail[order], mjoin[order]
            firsts = np.concatenate(([True], mt[1:] != mt[:-1]))
            ti = mt[firsts]
            self.leader[ti] = mowner[firsts]
            self.lead_tail0[ti] = mtail[firsts]
            self.lead_join[ti] = mjoin[firsts]
            self.lead_s0[ti] = s[mowner[firsts]]
            self.lead_sign[ti] = msign[firsts]
        if self.yield_at_conflicts and self.arbiter.n_pass:
            self.arbiter.settle(t, s, v, present, at_end, dwell_until, hold, self.yield_pos)


class _NoBar:
    def update(self, n: int) -> None:
        pass

    def close(self) -> None:
        pass


def _progress_bar(total: int, enabled: bool) -> Any:
    if not enabled:
        return _NoBar()
    try:
        from tqdm import tqdm
    except ImportError:  # tqdm is optional: run without a bar
        logger.warning("tqdm is not installed; running without a progress bar")
        return _NoBar()
    return tqdm(total=total, unit="step", desc="simulating", mininterval=0.5)
