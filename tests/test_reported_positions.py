"""Track positions the vehicles report of themselves: used when they pass the checks,
refused and counted otherwise, never used for the own vehicle."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import trackmap
from antikol import Analyser, AnalyserConfig, ReportedTrackPosition
from antikol.ingest.protocol import StreamDecoder, encode_report
from antikol.positioning.reported import ReportedSettings
from tests._osm import FRAME, OsmBuilder
from tests._paths import interleave, reports_along

LINE = [(0.0, float(y)) for y in range(0, 2001, 100)]
T = np.arange(0.0, 8.0, 1.0)


@pytest.fixture(scope="module")
def net(tmp_path_factory) -> trackmap.TrackMap:
    b = OsmBuilder()
    b.line(LINE, oneway="yes")
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp("m") / "line.osm"))


def _along(net, vid, start_m, speed_mps, *, offset_shift_m=0.0, edge=None, **kw):
    """Reports along the line, each with its true track position (shifted if asked)."""
    (e,) = net.edges
    out = []
    for k, r in enumerate(
        reports_along(vid, LINE, start_m=start_m, speed_mps=speed_mps, t=T, frame=FRAME, **kw)
    ):
        tp = ReportedTrackPosition(
            e.edge_id if edge is None else edge, start_m + speed_mps * T[k] + offset_shift_m, 1
        )
        out.append(dataclasses.replace(r, track_position=tp))
    return out


def test_a_checked_reported_position_is_used_and_the_matcher_kept_warm(net):
    an = Analyser(track_map=net)
    for r in _along(net, "B", 500.0, 10.0, offset_shift_m=6.0):
        an.update(r)
    pos = an.position("B", t=7.5)
    # the sender's own position (6 m ahead of where its GPS fix projects), carried 0.5 s
    assert pos is not None and pos.status == "confident"
    assert pos.offset_m == pytest.approx(500.0 + 70.0 + 6.0 + 5.0, abs=1e-6)
    assert pos.sigma_m == pytest.approx(2.0 + 0.3 * 0.5)
    assert an.reported is not None and an.reported.used == len(T)
    # the matcher still follows B from a fix every 5 s (t = 0 and 5), ready for reports
    # without a position; the other fixes are not matched
    assert an.reported.unmatched == len(T) - 2
    assert an.positioner is not None
    warm = an.positioner.position("B")
    assert warm is not None and warm.t == 5.0
    assert warm.offset_m == pytest.approx(550.0, abs=5.0)
    plain = dataclasses.replace(_along(net, "B", 580.0, 10.0)[0], t=8.0, track_position=None)
    an.update(plain)
    after = an.position("B")
    assert after is not None and after.status == "confident"
    assert after.offset_m == pytest.approx(580.0, abs=5.0)


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ({"edge": 99}, "unknown_edge"),
        ({"offset_shift_m": 5000.0}, "offset_beyond_edge"),
        ({"offset_shift_m": 45.0}, "far_from_fix"),
    ],
)
def test_a_reported_position_that_fails_a_check_is_counted_and_matched_instead(net, change, reason):
    an = Analyser(track_map=net)
    for r in _along(net, "B", 500.0, 10.0, **change):
        an.update(r)
    pos = an.position("B")
    assert an.reported is not None and an.reported.rejected == {reason: len(T)}
    assert an.reported.used == 0
    # matched from its GPS fixes, where it really is
    assert pos is not None and pos.offset_m == pytest.approx(570.0, abs=5.0)


def test_the_own_vehicle_is_always_matched_by_the_unit(net):
    an = Analyser(track_map=net, own_id="A")
    for r in interleave(
        _along(net, "A", 100.0, 10.0, offset_shift_m=6.0), _along(net, "B", 400.0, 0.0)
    ):
        an.update(r)
    own = an.position("A")  # positioning runs when a position is first asked for
    assert an.reported is not None and an.reported.used == len(T)  # B's only
    assert own is not None and own.offset_m == pytest.approx(170.0, abs=5.0)


def test_reported_positions_travel_the_radio_and_can_be_switched_off(net):
    frames = b"".join(encode_report(r) for r in _along(net, "B", 500.0, 10.0))
    (report, *_) = StreamDecoder().feed(frames)
    assert report.track_position is not None
    on = Analyser(track_map=net)
    off = Analyser(track_map=net, config=AnalyserConfig(reported_positions=None))
    on.feed_bytes(frames)
    off.feed_bytes(frames)
    assert on.position("B") is not None and off.position("B") is not None
    assert on.reported is not None and on.reported.used == len(T)
    assert off.reported is None
    assert off.positioner is not None and off.positioner.position("B") is not None


def test_an_on_board_unit_sends_its_confident_track_position(net, tmp_path):
    # a unit on the map broadcasts its own matched position; a receiver uses it
    import io

    from antikol.onboard.transport import UdpTransport
    from antikol.onboard.unit import EventSink, OnboardUnit, UnitConfig

    rows = ["vehicle_id,t,lat,lon,speed_mps,course_deg"]
    t = np.arange(0, 30.0)
    for r in reports_along("T1", LINE, start_m=100.0, speed_mps=10.0, t=t, frame=FRAME):
        rows.append(f"T1,{r.t},{r.lat!r},{r.lon!r},10,{r.course_deg!r}")
    (tmp_path / "t1.csv").write_text("\n".join(rows) + "\n")
    listener = UdpTransport(("127.0.0.1", 0), [])
    config = UnitConfig(
        vehicle_id="T1",
        gps=f"replay:{tmp_path / 't1.csv'}",
        bind=("127.0.0.1", 0),
        destinations=(listener.address,),
        speed=8.0,
        duration_s=2.5,
    )
    unit = OnboardUnit(config, track_map=net, events=EventSink(io.StringIO()))
    unit.run()
    frames = b"".join(listener.receive(10_000))
    listener.close()
    reports = StreamDecoder().feed(frames)
    assert len(reports) >= 10
    placed = [r for r in reports if r.track_position is not None]
    assert placed and len(placed) >= len(reports) - 3  # once its position is confident
    for r in placed:
        x, y = net.point_at(r.track_position.edge_id, r.track_position.offset_m)
        fx, fy = net.to_local(r.lon, r.lat)
        assert np.hypot(x - fx, y - fy) < 15.0 and r.track_position.direction == 1


def test_a_reported_position_is_not_carried_past_an_undecided_switch(tmp_path):
    from tests._osm import switch_fixture

    net = trackmap.build(switch_fixture().write_xml(tmp_path / "s.osm"))
    trunk = next(e for e in net.edges if e.way_ids == (1,))  # drawn north up to the switch
    pts = [(0.0, -200.0), (0.0, 0.0), (0.0, 200.0)]
    (r,) = reports_along("B", pts, start_m=197.0, speed_mps=10.0, t=[0.0], frame=FRAME)
    r = dataclasses.replace(
        r, track_position=ReportedTrackPosition(trunk.edge_id, trunk.length_m - 3.0, 1)
    )
    an = Analyser(track_map=net)
    an.update(r)
    pos = an.position("B", t=2.0)
    # 20 m run, 3 m of it to the switch: it waits there, 17 m more uncertain
    assert pos is not None and pos.edge_id == trunk.edge_id
    assert pos.offset_m == pytest.approx(trunk.length_m)
    assert pos.sigma_m == pytest.approx(2.0 + 0.3 * 2.0 + 17.0)
    # with a route through the switch it follows the route
    branch = next(e.edge_id for e in net.edges if e.way_ids == (3,))
    routed = Analyser(track_map=net)
    routed.update(dataclasses.replace(r, route=(trunk.edge_id, branch)))
    on_route = routed.position("B", t=2.0)
    assert on_route is not None and on_route.edge_id == branch
    assert on_route.offset_m == pytest.approx(17.0, abs=0.1)


def test_a_position_against_the_course_is_refused_and_one_without_a_fix_taken(net):
    (e,) = net.edges
    against = [
        dataclasses.replace(r, track_position=ReportedTrackPosition(e.edge_id, 500.0 + 10 * k, -1))
        for k, r in enumerate(
            reports_along("B", LINE, start_m=500.0, speed_mps=10.0, t=T, frame=FRAME)
        )
    ]
    an = Analyser(track_map=net)
    for r in against:
        an.update(r)
    assert an.position("B") is not None
    assert an.reported is not None and an.reported.rejected == {"against_course": len(T)}
    # no fix (a tunnel: lat/lon are the last known ones): the sender's word is taken
    tunnel = Analyser(track_map=net)
    for r in _along(net, "B", 500.0, 10.0, offset_shift_m=45.0):
        tunnel.update(dataclasses.replace(r, fix_quality=0))
    assert tunnel.position("B") is not None
    assert tunnel.reported is not None and tunnel.reported.used == len(T)


@settings(max_examples=150, deadline=None)
@given(
    edge=st.integers(min_value=0, max_value=5),
    offset=st.floats(min_value=0.0, max_value=5000.0),
    direction=st.sampled_from([1, -1]),
    along=st.floats(min_value=-100.0, max_value=2100.0),
    speed=st.floats(min_value=0.0, max_value=30.0),
    course=st.floats(min_value=0.0, max_value=359.9),
    fix_quality=st.sampled_from([None, 0, 1, 4]),
    later_s=st.floats(min_value=0.0, max_value=9.0),  # within the 10 s expiry
)
def test_any_reported_position_is_used_or_refused_never_raised(
    net, edge, offset, direction, along, speed, course, fix_quality, later_s
):
    (r,) = reports_along("B", LINE, start_m=max(along, 0.0), speed_mps=0.0, t=[0.0], frame=FRAME)
    r = dataclasses.replace(
        r,
        speed_mps=speed,
        course_deg=course,
        fix_quality=fix_quality,
        track_position=ReportedTrackPosition(edge, offset, direction),
    )
    an = Analyser(track_map=net, own_id="A")
    (own,) = reports_along("A", LINE, start_m=10.0, speed_mps=5.0, t=[0.0], frame=FRAME)
    an.update(own)
    an.update(r)
    a = an.assess(t=later_s)
    pos = an.position("B", t=later_s)
    assert pos is not None and a.own_id == "A"
    assert an.reported is not None and an.reported.used + sum(an.reported.rejected.values()) == 1
    if an.reported.used:
        assert pos.sigma_m is not None and pos.sigma_m >= 2.0
        assert 0.0 <= pos.offset_m <= net.edge_length(pos.edge_id) + 1e-6


def test_every_report_is_matched_with_no_refresh_interval(net):
    config = AnalyserConfig(reported_positions=ReportedSettings(matcher_refresh_s=0.0))
    an = Analyser(track_map=net, config=config)
    for r in _along(net, "B", 500.0, 10.0):
        an.update(r)
    an.position("B")
    assert an.reported is not None and an.reported.unmatched == 0
    assert an.positioner is not None
    warm = an.positioner.position("B")
    assert warm is not None and warm.t == T[-1]


def test_a_batch_the_matcher_refuses_is_retried_without_losing_the_refresh(net):
    # the analyser retries a failed batch report by report: the refresh schedule and the
    # counts must be those of one pass
    an = Analyser(track_map=net)
    b = _along(net, "B", 500.0, 10.0)
    c = _along(net, "C", 1500.0, 10.0)
    inner = an.positioner
    assert inner is not None and an.reported is not None
    batch = inner.update_many

    def flaky(reports, *, outputs=True):
        if len(reports) > 1 and any(r.vehicle_id == "C" and r.t == 5.0 for r in reports):
            raise ValueError("one bad report in the batch")
        return batch(reports, outputs=outputs)

    inner.update_many = flaky  # type: ignore[method-assign]
    for rb, rc in zip(b, c, strict=True):
        an.update_many([rb, rc])
        an.position("B")
    warm = inner.position("B")
    assert warm is not None and warm.t == 5.0  # matched at t = 0 and 5, as without the error
    assert an.reported.used == 2 * len(T)
    assert an.reported.unmatched == 2 * (len(T) - 2)


def test_with_no_refresh_interval_a_late_report_still_goes_to_the_matcher(net):
    config = AnalyserConfig(reported_positions=ReportedSettings(matcher_refresh_s=0.0))
    an = Analyser(track_map=net, config=config)
    assert an.reported is not None
    seen: list[float] = []
    inner = an.reported.inner
    batch = inner.update_many

    def spy(reports, *, outputs=True):
        seen.extend(r.t for r in reports)
        return batch(reports, outputs=outputs)

    an.reported.inner.update_many = spy  # type: ignore[method-assign]
    reports = _along(net, "B", 500.0, 10.0)
    an.reported.update_many([reports[3]], outputs=False)
    an.reported.update_many([reports[2]], outputs=False)  # older than the last one matched
    assert seen == [3.0, 2.0]


_REPORTED = st.tuples(
    st.sampled_from([0, 1, 99]),  # an edge of the map, or none
    st.floats(min_value=-10.0, max_value=2100.0),  # reported offset, m
    st.floats(min_value=0.0, max_value=2000.0),  # where the fix is along the line, m
    st.floats(min_value=0.0, max_value=20.0),  # speed, m/s
    st.floats(min_value=0.0, max_value=359.9),  # course, degrees
    st.sampled_from([None, 0, 1]),  # fix quality
    st.booleans(),  # a track position at all
)


@settings(max_examples=60, deadline=None)
@given(batch=st.lists(_REPORTED, min_size=1, max_size=12))
def test_a_batch_of_reported_positions_is_checked_as_each_alone(net, batch):
    # the checks of a cycle's reports run in array calls: each report keeps its own reason
    from antikol.positioning.reported import ReportedFirst

    reports = []
    for k, (edge, offset, along, speed, course, quality, has_tp) in enumerate(batch):
        (r,) = reports_along(f"V{k}", LINE, start_m=along, speed_mps=0.0, t=[0.0], frame=FRAME)
        tp = ReportedTrackPosition(edge, max(offset, 0.0), 1) if has_tp else None
        reports.append(
            dataclasses.replace(
                r, speed_mps=speed, course_deg=course, fix_quality=quality, track_position=tp
            )
        )
    checker = ReportedFirst(net, inner=None)  # type: ignore[arg-type]
    alone = [checker.check_many([r])[0] for r in reports]
    assert checker.check_many(reports) == alone
    assert set(alone) <= {
        None,
        "absent",
        "unknown_edge",
        "offset_beyond_edge",
        "far_from_fix",
        "against_course",
    }
