"""The project's own reproducible tram traffic simulator over a :class:`~trackmap.TrackMap`.

The simulator drives trams along fixed routes of a track map with a look-ahead driver
model, records their true state every time step and turns it into noisy GPS reports
(:class:`~antikol.report.VehicleReport`), a replay CSV and per-vehicle NMEA logs. It is the
source of ground truth for tests, benchmarks and comparisons.

>>> import trackmap
>>> from antikol.sim import Simulator, fleet
>>> net = trackmap.load_default()
>>> trams = fleet(net, 20, 1)  # 20 trams on random main-line routes
>>> result = Simulator(net, trams, seed=1).run(1800.0)  # doctest: +SKIP
>>> result.write_csv("city.csv")  # doctest: +SKIP

Units are SI throughout (m, s, m/s, m/s²). Route distances are metres along a route from
its start position; track positions are ``(edge_id, offset_m, direction)`` as in
:mod:`trackmap.network`.

Modules, in the order data flows through them:

* :mod:`~antikol.sim.routes` — :class:`Route`, a path along permitted moves;
* :mod:`~antikol.sim.route_building` — random routes and routes through listed edges;
* :mod:`~antikol.sim.events` — planned stops and scripted driver actions;
* :mod:`~antikol.sim.vehicles` — :class:`TramSpec`, one tram's route, vehicle and driver;
* :mod:`~antikol.sim.track` — a route's extended track geometry and curve radii;
* :mod:`~antikol.sim.conflicts` — conflict points and who gives way there;
* :mod:`~antikol.sim.planning` — allowed speed, speed envelope and stops per tram;
* :mod:`~antikol.sim.following` — where trams' bodies lie on each other's tracks;
* :mod:`~antikol.sim.dynamics` — the driver model, stepped for all trams at once;
* :mod:`~antikol.sim.truth` — true states and GPS fix logs;
* :mod:`~antikol.sim.gps` — the receiver model that turns truth into reports;
* :mod:`~antikol.sim.places` — double track, where GPS errors hurt most;
* :mod:`~antikol.sim.urban_gps` — the realistic street receiver (multipath, outages,
  odometer);
* :mod:`~antikol.sim.simulator` — :class:`Simulator` and :class:`SimulationResult`;
* :mod:`~antikol.sim.fleet` — many trams on random routes.
"""

from antikol.sim.conflicts import crossing_clearance_m
from antikol.sim.events import DEFAULT_DWELL_S, EVENT_KINDS, EventKind, ScriptEvent, StopCall
from antikol.sim.fleet import fleet
from antikol.sim.gps import GpsModel
from antikol.sim.planning import DEFAULT_SPEED_MPS, SpeedPlan
from antikol.sim.route_building import random_route, route_from_edges
from antikol.sim.routes import Route, map_stops_on_route
from antikol.sim.simulator import (
    DEFAULT_EPOCH_UTC_S,
    ReceiverModel,
    SimulationResult,
    Simulator,
)
from antikol.sim.truth import FixLog, Truth, TruthState
from antikol.sim.urban_gps import UrbanGpsModel
from antikol.sim.vehicles import TramSpec

__all__ = [
    "DEFAULT_DWELL_S",
    "DEFAULT_EPOCH_UTC_S",
    "DEFAULT_SPEED_MPS",
    "EVENT_KINDS",
    "EventKind",
    "FixLog",
    "GpsModel",
    "ReceiverModel",
    "Route",
    "ScriptEvent",
    "SimulationResult",
    "Simulator",
    "SpeedPlan",
    "StopCall",
    "TramSpec",
    "Truth",
    "TruthState",
    "UrbanGpsModel",
    "crossing_clearance_m",
    "fleet",
    "map_stops_on_route",
    "random_route",
    "route_from_edges",
]
