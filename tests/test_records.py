"""Records built by position equal the records their classes' constructors build."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given
from hypothesis import strategies as st

from antikol.analysis.assessment import Assessment, Suppressed, Threat, assessment_of
from antikol.analysis.sector import SectorHit, SectorRule
from antikol.analysis.threats import sector_threat
from trackmap.records import positional

_floats = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6)


@given(
    distance=st.floats(min_value=0.0, max_value=1e4),
    bearing=st.floats(min_value=0.0, max_value=359.99),
    closing=_floats,
    note=st.sampled_from(["", "own vehicle not matched", "other vehicle lost"]),
)
def test_a_sector_threat_is_the_record_its_keywords_make(distance, bearing, closing, note):
    rule = SectorRule()
    hit = SectorHit("B", distance, bearing)
    got = sector_threat(rule, hit, closing, note)
    detail = "within 300 m and ±15° of own course"
    expected = Threat(
        vehicle_id="B",
        kind="sector",
        level="warning",
        distance_m=distance,
        closing_speed_mps=closing,
        ttc_s=distance / closing if closing > 0 else None,
        method="sector",
        bearing_deg=bearing,
        detail=f"{detail} ({note})" if note else detail,
    )
    assert dataclasses.astuple(got) == dataclasses.astuple(expected)
    assert got == expected and hash(got) == hash(expected)


@given(
    t=_floats,
    threats=st.lists(
        st.tuples(st.sampled_from(["advisory", "warning", "emergency"]), _floats), max_size=4
    ),
    suppressed=st.lists(_floats, max_size=3),
)
def test_an_assessment_is_the_record_its_keywords_make(t, threats, suppressed):
    made = [
        Threat(f"V{k}", "rear_end", lvl, d, 1.0, None, "track")
        for k, (lvl, d) in enumerate(threats)
    ]
    hidden = [Suppressed(f"S{k}", "parallel track", d, 0.0) for k, d in enumerate(suppressed)]
    got = assessment_of("A", t, made, hidden, "track")
    ranks = {"advisory": 1, "warning": 2, "emergency": 3}
    ordered = tuple(sorted(made, key=lambda th: (-ranks[th.level], th.distance_m)))
    expected = Assessment(
        own_id="A",
        t=t,
        level=ordered[0].level if ordered else "none",
        threats=ordered,
        suppressed=tuple(sorted(hidden, key=lambda s: s.distance_m)),
        method="track",
    )
    assert got == expected and hash(got) == hash(expected)
    with pytest.raises(dataclasses.FrozenInstanceError):
        got.level = "none"  # type: ignore[misc]


def test_positional_refuses_classes_it_cannot_build_faithfully():
    @dataclasses.dataclass(frozen=True)
    class Plain:
        x: float

    @dataclasses.dataclass(frozen=True, slots=True)
    class Checked:
        x: float

        def __post_init__(self) -> None:  # pragma: no cover - never built here
            if self.x < 0:
                raise ValueError("negative")

    for cls in (Plain, Checked):
        with pytest.raises(TypeError):
            positional(cls)
