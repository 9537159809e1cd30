"""Fleets: many trams on random main-line routes spread across the network."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np

from antikol.sim.route_building import as_generator, random_route, random_start, start_table
from antikol.sim.vehicles import TramSpec
from trackmap import TrackMap

__all__ = ["fleet"]

logger = logging.getLogger(__name__)


def fleet(
    net: TrackMap,
    n: int,
    rng_or_seed: np.random.Generator | int | None,
    *,
    route_length_m: float = 12_000.0,
    headway_s: float = 10.0,
    min_separation_m: float = 300.0,
    id_prefix: str = "T",
    cruise_factor_range: tuple[float, float] = (0.9, 1.0),
    **spec_options: Any,
) -> list[TramSpec]:
    """Trams on random main-line routes spread across the network.

    Parameters
    ----------
    net : TrackMap
    n : int
        Number of trams.
    rng_or_seed : numpy.random.Generator or int or None
        Random source for the routes and cruise factors.
    route_length_m : float
        Route length of every tram, metres (12 km: enough for 30 min with stops).
    headway_s : float
        Tram ``i`` departs at ``i · headway_s`` seconds.
    min_separation_m : float
        Wanted straight-line distance between start positions, metres; at most half the
        main-line length per tram, and relaxed after 50 failed draws for a tram.
    id_prefix : str
        Vehicle ids are ``id_prefix`` + a zero-padded number from 1.
    cruise_factor_range : (float, float)
        Each driver's cruise factor is drawn uniformly from this range.
    **spec_options
        Further :class:`TramSpec` fields (``length_m``, ``dwell_s``, ``broadcast_route``,
        ``exit_at_end``, ``profile``, ...); a ``cruise_factor`` here overrides the draw.

    Returns
    -------
    list of TramSpec

    Raises
    ------
    ValueError
        ``n`` is negative, or a length, headway or range is invalid.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise ValueError(f"n must be a non-negative int, got {n!r}")
    if not (math.isfinite(headway_s) and headway_s >= 0):
        raise ValueError(f"headway_s must be >= 0 s, got {headway_s!r}")
    lo, hi = cruise_factor_range
    if not 0 < lo <= hi <= 1:
        raise ValueError(f"cruise_factor_range must satisfy 0 < lo <= hi <= 1, got {lo, hi}")
    gen = as_generator(rng_or_seed)
    width = max(2, len(str(n)))
    table = start_table(net)
    main_m = float(table.cum_m[-1]) if len(table.cum_m) else 0.0
    separation = min(min_separation_m, 0.5 * main_m / max(n, 1))
    xs = np.zeros(n)
    ys = np.zeros(n)
    specs: list[TramSpec] = []
    for i in range(n):
        for attempt in range(50):
            (edge_id, direction), offset = random_start(net, gen, prefer_main=True)
            x, y = net.point_at(edge_id, offset)
            near = float(np.hypot(xs[:i] - x, ys[:i] - y).min(initial=np.inf))
            if near >= separation:
                break
            if attempt == 49:
                logger.debug("fleet: tram %d starts %.0f m from another", i + 1, near)
        xs[i], ys[i] = x, y
        route = random_route(net, gen, length_m=route_length_m, start=(edge_id, offset, direction))
        options = dict(spec_options)
        cruise = float(gen.uniform(lo, hi))
        options.setdefault("cruise_factor", cruise)
        specs.append(
            TramSpec(
                vehicle_id=f"{id_prefix}{i + 1:0{width}d}",
                route=route,
                depart_s=i * headway_s,
                **options,
            )
        )
    return specs
