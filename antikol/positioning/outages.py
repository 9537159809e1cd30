"""What a GPS outage says about where a vehicle is: in a tunnel, or on the track beside it.

A receiver in a tunnel has no fix for as long as the tunnel lasts; on open track an outage
(a street canyon, a bridge overhead) lasts seconds. So a report that says it has no fix is
evidence too: a hypothesis in the open explains ``dt`` seconds more without a fix with a
likelihood of ``exp(-dt / surface_outage_s)`` against one in a tunnel.

Where the track divides at a tunnel's portal and the fixes stop at the switch, the
dead-reckoned vehicle splits over both branches
(:func:`~antikol.positioning.deadreckoning.carry`), and which branch it was reported on was
a coin toss; a few seconds without a fix now give the tunnel branch the probability. The
reported lineage (slot 0) moves to the place that holds the most once that place lies in a
tunnel and holds ``switch_probability`` — the bar a fix's lineage switch must clear
(:mod:`~antikol.positioning.lineage`), so that the reported position does not swing to and
fro while the evidence builds; a move out of a tunnel waits for a fix.

An outage where no hypothesis is in a tunnel, or every one is, changes nothing: a receiver
that has failed says nothing about the track. And however long an outage lasts, it leaves
a hypothesis in the open at least ``floor`` of the probability (10 times
``min_probability``, below which hypotheses are dropped): a tram whose receiver failed
beside a tunnel's portal is found on its surface track again by the first fixes that come
back.

>>> import numpy as np
>>> outage_log_likelihood(np.array([True, False]), 5.0, surface_outage_s=10.0).tolist()
[0.0, -0.5]
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from antikol.positioning.fleet import FleetState

__all__ = ["outage_log_likelihood", "weigh_outage"]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]


def outage_log_likelihood(
    in_tunnel: BoolArray, dt_s: float, *, surface_outage_s: float
) -> FloatArray:
    """Log-likelihood of ``dt_s`` seconds without a fix, per hypothesis, up to a constant.

    Parameters
    ----------
    in_tunnel : ndarray of bool
        Whether each hypothesis lies on a tunnel edge.
    dt_s : float
        Time since the previous report, s (none is counted when not positive).
    surface_outage_s : float, keyword-only
        Mean length of an outage in the open, s (0: the outage tells nothing).

    Returns
    -------
    ndarray of float
        0 in a tunnel, ``-dt_s / surface_outage_s`` in the open, nats.
    """
    if surface_outage_s <= 0.0 or not dt_s > 0.0:
        return np.zeros(len(in_tunnel))
    return np.where(in_tunnel, 0.0, -dt_s / surface_outage_s)


def weigh_outage(
    fleet: FleetState,
    row: int,
    tunnel_edges: BoolArray,
    dt_s: float,
    *,
    surface_outage_s: float,
    switch_probability: float,
    floor: float,
) -> bool:
    """Weigh a vehicle's hypotheses by an interval without a fix; move its lineage to the
    place that now holds at least ``switch_probability`` (see the module).

    Parameters
    ----------
    fleet : FleetState
        Changed in place: the log-probabilities of row ``row``'s slots, and their order
        when the lineage moves.
    row : int
    tunnel_edges : ndarray of bool
        Per edge of the map, whether it is a tunnel.
    dt_s : float
        Time without a fix since the previous report, s.
    surface_outage_s : float, keyword-only
        Mean length of an outage in the open, s (0: nothing is weighed).
    switch_probability : float, keyword-only
        Share of the probability the reported lineage's new place must hold.
    floor : float, keyword-only
        Least probability an outage leaves a hypothesis in the open with.

    Returns
    -------
    bool
        Whether the reported lineage moved to another place.
    """
    if surface_outage_s <= 0.0 or not dt_s > 0.0:  # no evidence (also NaN)
        return False
    slots = np.flatnonzero(fleet.hs[row] >= 0)
    if len(slots) < 2 or slots[0] != 0:  # (slot 0, the lineage, is filled first)
        return False
    states = fleet.hs[row, slots]
    covered = tunnel_edges[states >> 1]
    if covered.all() or not covered.any():
        return False
    before = fleet.hp[row, slots]
    log_p = before + outage_log_likelihood(covered, dt_s, surface_outage_s=surface_outage_s)
    log_p -= np.logaddexp.reduce(log_p)
    # an open hypothesis is left the floor (or what it had, when that was less); the
    # renormalisation after it takes a hypothesis less than a percent below the floor
    log_p = np.where(covered, log_p, np.maximum(log_p, np.minimum(before, np.log(floor))))
    log_p -= np.logaddexp.reduce(log_p)
    fleet.hp[row, slots] = log_p
    # the lineage moves to the place holding the most only when it is in a tunnel (what the
    # outage speaks for) and holds the switch probability
    return fleet.lead_to_heaviest_place(
        row, switch_probability=switch_probability, eligible_edges=tunnel_edges
    )
