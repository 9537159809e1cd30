"""What callers hand a :class:`~antikol.positioning.matcher.Positioner`, checked before
anything changes: the reports to fuse, a discrete fix, a saved state to restore.

A value that is not what it must be gets an :class:`~antikol.errors.InvalidArgumentError`
naming it (for a saved state: the vehicle and the key, as a subscript of the dict
:meth:`Positioner.state <antikol.positioning.matcher.Positioner.state>` gives). The checks
only read, so a refused call leaves the positioner as it was: without them a report that
is not one failed deep inside a cycle, and a state saved on another map was half restored
and broke every later call (its state ids index this map's arrays).

A state id packs an edge and a running direction (:mod:`antikol.positioning.reach`), so
the ids of a map with ``n`` edges are ``0 .. 2n - 1``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, TypeGuard

import numpy as np
import numpy.typing as npt

from antikol.errors import InvalidArgumentError
from antikol.numeric import finite_float, why_not_finite
from antikol.positioning.fleet import SLOT_FIELDS, UNKNOWN_AT_START, VEHICLE_FIELDS
from antikol.positioning.odometerscale import MAX_SCALE_ERROR
from antikol.positioning.records import DiscreteFix
from antikol.positioning.speedunits import UNIT_FACTORS
from antikol.report import VehicleReport

__all__ = ["check_state", "checked_fix", "checked_report", "checked_reports"]

FloatArray = npt.NDArray[np.float64]
Where = tuple[int, int]  # (edge id, running direction)

#: A saved offset may lie this far beyond its edge's ends, m: offsets are clipped to the
#: edge when computed, so this only forgives rounding; a state of another map lies farther.
_OFFSET_SLACK_M = 1.0
#: Keys every saved state has (the others came later: a state saved before them restores).
_REQUIRED = (
    "states", "slots", "vehicle", "filter", "rejected_in_row", "confident_in_row",
    "unmatched", "lost", "last_report",
)  # fmt: skip
#: Variances (m²) among the per-hypothesis values (the fix error filter's).
_SLOT_VARIANCES = ("paa", "pxx", "pyy")
#: The largest magnitude of a value of the along-track filter (s, m, m/s and their
#: covariances): far beyond any it holds (unix times are about 1.7e9 s), while its process
#: noise, cubic in the time step, swamps or overflows its other terms not far beyond it.
_FILTER_MAX = 1e12
#: A count in a row is stored as a 64-bit int.
_COUNT_MAX = 2**63
#: A log-probability is at most 0 (this much more: rounding of the normalisation).
_LOG_P_MAX = 1e-9
#: The odometer's scale: 1 within its largest error (odometerscale clips it there).
_ODOMETER_SCALES = (1.0 - MAX_SCALE_ERROR, 1.0 + MAX_SCALE_ERROR)


# -- reports ----------------------------------------------------------------------------------
def checked_report(report: object, name: str = "report") -> VehicleReport:
    """``report`` when it is a :class:`~antikol.report.VehicleReport`.

    Raises
    ------
    InvalidArgumentError
        Anything else (named ``name``).
    """
    if not isinstance(report, VehicleReport):
        raise InvalidArgumentError(name, report, "must be a VehicleReport")
    return report


def checked_reports(reports: object) -> list[VehicleReport]:
    """``reports`` as a list, when it is an iterable of reports (a sequence, typically).

    Raises
    ------
    InvalidArgumentError
        Not iterable (``reports``), or an item not a report (``reports[i]``).
    """
    if isinstance(reports, str | bytes | Mapping) or not isinstance(reports, Iterable):
        raise InvalidArgumentError("reports", reports, "must be a sequence of VehicleReport")
    out = list(reports)
    if not all(type(r) is VehicleReport for r in out):  # (the usual case costs one pass)
        for i, r in enumerate(out):
            checked_report(r, f"reports[{i}]")
    return out


# -- discrete fixes ---------------------------------------------------------------------------
def checked_fix(lengths: FloatArray, fix: object) -> DiscreteFix:
    """``fix`` when it is a :class:`~antikol.positioning.records.DiscreteFix` of this map:
    a finite time, an edge of the map (``lengths``: the length of each, m) and an offset
    on it.

    Raises
    ------
    InvalidArgumentError
        Naming ``fix`` or the field (``fix.t``, ``fix.edge_id``, ``fix.offset_m``,
        ``fix.fix_id``).
    """
    if not isinstance(fix, DiscreteFix):
        raise InvalidArgumentError("fix", fix, "must be a DiscreteFix")
    if finite_float(fix.t) is None:
        raise InvalidArgumentError("fix.t", fix.t, why_not_finite(fix.t))
    if not _is_int(fix.edge_id) or not 0 <= fix.edge_id < len(lengths):
        raise InvalidArgumentError("fix.edge_id", fix.edge_id, _not_edge(len(lengths)))
    offset = finite_float(fix.offset_m)
    if offset is None:
        raise InvalidArgumentError("fix.offset_m", fix.offset_m, why_not_finite(fix.offset_m))
    length = float(lengths[fix.edge_id])
    if not 0.0 <= offset <= length:
        raise InvalidArgumentError("fix.offset_m", offset, f"outside its edge (0..{length:g} m)")
    if fix.fix_id is not None and not isinstance(fix.fix_id, str):
        raise InvalidArgumentError("fix.fix_id", fix.fix_id, "must be a str or None")
    return fix


# -- saved states -----------------------------------------------------------------------------
class _StateChecks:
    """The checks of one saved state: each names the vehicle and the key it refuses."""

    def __init__(self, lengths: FloatArray, vehicle_id: str) -> None:
        self.lengths = lengths
        self.vehicle_id = vehicle_id

    def fail(self, key: str, value: object, reason: str) -> InvalidArgumentError:
        return InvalidArgumentError(f"state of {self.vehicle_id!r}: {key}", value, reason)

    def mapping(self, key: str, value: object) -> Mapping[Any, Any]:
        if not isinstance(value, Mapping):
            raise self.fail(key, value, "must be a dict as Positioner.state() gives")
        return value

    def sequence(self, key: str, value: object, length: int | None = None) -> Sequence[Any]:
        if isinstance(value, str | bytes) or not isinstance(value, Sequence):
            raise self.fail(key, value, "must be a list")
        if length is not None and len(value) != length:
            raise self.fail(key, value, f"must hold {length} values, holds {len(value)}")
        return value

    def count(self, key: str, value: object) -> None:
        if not _is_int(value) or not 0 <= value < _COUNT_MAX:
            raise self.fail(key, value, "must be a non-negative int (64 bits)")

    def real(
        self, key: str, value: object, low: float = -math.inf, high: float = math.inf
    ) -> float:
        """A finite real number in ``low .. high`` (a state holds neither NaN, which it
        writes as None, nor infinities)."""
        number = finite_float(value)
        if number is None:
            raise self.fail(key, value, why_not_finite(value))
        if not low <= number <= high:
            raise self.fail(key, value, f"outside {low:g} .. {high:g}")
        return number

    def optional_real(
        self, key: str, value: object, low: float = -math.inf, high: float = math.inf
    ) -> None:
        if value is not None:  # (None: NaN, not known)
            self.real(key, value, low, high)

    def vehicle(self, value: object) -> None:
        """The per-vehicle values: None only where a new row does not know them yet."""
        given = self.mapping("vehicle", value)
        for name in VEHICLE_FIELDS:  # (others are not restored; missing ones keep defaults)
            if name not in given:
                continue
            key, number = f"vehicle[{name!r}]", given[name]
            if name not in UNKNOWN_AT_START or number is not None:
                self.real(key, number)
        # scales multiply every later reading: a unit recognised, an error within its clip
        if "uscale" in given and not any(
            math.isclose(given["uscale"], f, rel_tol=1e-9) for f in UNIT_FACTORS.values()
        ):
            raise self.fail("vehicle['uscale']", given["uscale"], "not a known speed unit")
        if "oscale" in given:
            self.real("vehicle['oscale']", given["oscale"], *_ODOMETER_SCALES)

    def state(self, key: str, value: object, *, empty: bool = False) -> int:
        """A state id of this map (``empty``: ``-1`` too, and as a float: the state a
        hypothesis entered its own from is stored as one)."""
        n = 2 * len(self.lengths)
        if empty and isinstance(value, float) and value.is_integer():
            value = int(value)
        if not _is_int(value):
            raise self.fail(key, value, "a state id must be an int")
        if not (-1 if empty else 0) <= value < n:
            raise self.fail(key, value, f"not a state id of this map (0..{n - 1}; another map?)")
        return int(value)

    def edge(self, key: str, value: object) -> int:
        if not _is_int(value) or not 0 <= value < len(self.lengths):
            raise self.fail(key, value, _not_edge(len(self.lengths), "; another map?"))
        return int(value)

    def offset(self, key: str, value: object, edge: int) -> None:
        offset, length = self.real(key, value), float(self.lengths[edge])
        if not -_OFFSET_SLACK_M <= offset <= length + _OFFSET_SLACK_M:
            why = f"beyond its edge {edge} (0..{length:g} m; another map?)"
            raise self.fail(key, value, why)

    def direction(self, key: str, value: object) -> int:
        if not _is_int(value) or value not in (1, -1):
            raise self.fail(key, value, "a running direction must be 1 or -1")
        return int(value)

    def where(self, key: str, value: object) -> Where | None:
        if value is None:
            return None
        edge, direction = self.sequence(key, value, 2)
        return self.edge(f"{key}[0]", edge), self.direction(f"{key}[1]", direction)

    def slots(self, states: list[int], slots: object) -> None:
        """The per-hypothesis values: a list per field, one value per state."""
        given = self.mapping("slots", slots)
        if "ho" not in given:
            raise self.fail("slots", given, "has no offsets ('ho')")
        for name in SLOT_FIELDS:
            if name not in given:  # (a field added later: restore keeps its default)
                continue
            key = f"slots[{name!r}]"
            values = self.sequence(key, given[name], len(states))
            for k, (state, value) in enumerate(zip(states, values, strict=True)):
                at = f"{key}[{k}]"
                if name == "ho":
                    self.offset(at, value, state >> 1)
                elif name == "hv":  # the state it entered its own from: indexes the map
                    self.state(at, value, empty=True)
                elif name == "hp":  # a log-probability
                    self.real(at, value, high=_LOG_P_MAX)
                else:
                    self.real(at, value, low=0.0 if name in _SLOT_VARIANCES else -math.inf)

    def filter(self, values: object) -> None:
        """The along-track filter (time, position, speed, their covariance): unset (time
        None; its other values are not read) or six finite numbers, its variances >= 0."""
        t, *rest = self.sequence("filter", values, 6)
        if t is None:
            for k, value in enumerate(rest, 1):
                self.optional_real(f"filter[{k}]", value)
            return
        for k, value in enumerate((t, *rest)):
            low = 0.0 if k in (3, 5) else -_FILTER_MAX
            self.real(f"filter[{k}]", value, low, _FILTER_MAX)

    def before(self, values: object) -> None:
        for k, item in enumerate(self.sequence("before", values)):
            state, offset, log_p = self.sequence(f"before[{k}]", item, 3)
            edge = self.state(f"before[{k}][0]", state) >> 1
            self.offset(f"before[{k}][1]", offset, edge)
            if log_p is not None and log_p != -math.inf:  # (-inf, None: probability 0)
                self.real(f"before[{k}][2]", log_p, high=_LOG_P_MAX)

    def fixes(self, value: object) -> None:
        """The discrete fixes' bookkeeping (:meth:`DiscreteFixes.state
        <antikol.positioning.fixes.DiscreteFixes.state>`; None: none)."""
        if value is None:
            return
        data = self.mapping("fixes", value)
        for key in ("last_fix_s", "missed", "expected"):
            if key not in data:
                raise self.fail("fixes", data, f"has no {key!r}")
        self.optional_real("fixes['last_fix_s']", data["last_fix_s"])
        self.count("fixes['missed']", data["missed"])
        for k, item in enumerate(self.sequence("fixes['expected']", data["expected"])):
            fix_id, s = self.sequence(f"fixes['expected'][{k}]", item, 2)
            if not isinstance(fix_id, str):
                raise self.fail(f"fixes['expected'][{k}][0]", fix_id, "a fix id must be a str")
            self.real(f"fixes['expected'][{k}][1]", s)
        previous = data.get("previous")
        if previous is not None:
            edge, offset, direction, s = self.sequence("fixes['previous']", previous, 4)
            self.offset("fixes['previous'][1]", offset, self.edge("fixes['previous'][0]", edge))
            self.direction("fixes['previous'][2]", direction)
            self.real("fixes['previous'][3]", s)

    def last_report(self, value: object) -> None:
        if value is None:  # (a vehicle whose reports were all refused)
            return
        fields = self.mapping("last_report", value)
        try:
            VehicleReport(**fields)
        except (TypeError, ValueError) as e:  # (InvalidReportError is a ValueError)
            raise self.fail("last_report", value, f"not a report: {e}") from e


def check_state(lengths: FloatArray, vehicle_id: object, data: object) -> tuple[Where | None, ...]:
    """Check a saved state before :meth:`Positioner.restore
    <antikol.positioning.matcher.Positioner.restore>` changes anything.

    Parameters
    ----------
    lengths : ndarray
        The length of each edge of the positioner's map, m.
    vehicle_id : object
        The vehicle the state is restored to (must be a str).
    data : object
        The state: a dict as ``Positioner.state`` gives (after a JSON round trip too).

    Returns
    -------
    tuple of (int, int) or None
        Where the vehicle was last reported and the time before (edge id, direction; None:
        not known), for the switch hold's memory.

    Raises
    ------
    InvalidArgumentError
        ``vehicle_id`` not a str; or a key of ``data`` missing, of the wrong type, out of
        range or not of this map (the message names the vehicle and the key).
    """
    if not isinstance(vehicle_id, str):
        raise InvalidArgumentError("vehicle_id", vehicle_id, "must be a str")
    if not isinstance(data, Mapping):
        why = "must be a dict as Positioner.state() gives"
        raise InvalidArgumentError(f"state of {vehicle_id!r}", data, why)
    check, state = _StateChecks(lengths, vehicle_id), data
    for key in _REQUIRED:
        if key not in state:
            raise check.fail(key, None, "missing from the state")
    saved = check.sequence("states", state["states"])
    states = [check.state(f"states[{k}]", s) for k, s in enumerate(saved)]
    check.slots(states, state["slots"])
    check.vehicle(state["vehicle"])
    check.filter(state["filter"])
    check.before(state.get("before", []))
    for key in ("rejected_in_row", "confident_in_row", "gated_in_row"):
        if key in state:
            check.count(key, state[key])
    if not isinstance(state["unmatched"], bool | np.bool_):
        raise check.fail("unmatched", state["unmatched"], "must be a bool")
    if state["lost"] is not None and not isinstance(state["lost"], str):
        raise check.fail("lost", state["lost"], "must be a str (the reason) or None")
    check.last_report(state["last_report"])
    check.fixes(state.get("fixes"))
    return tuple(check.where(key, state.get(key)) for key in ("reported", "reported_before"))


def _is_int(value: object) -> TypeGuard[int]:
    """An integer, not a bool (``True`` is no edge id)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _not_edge(n: int, hint: str = "") -> str:
    return f"not an edge of this map (ints 0..{n - 1}{hint})"
