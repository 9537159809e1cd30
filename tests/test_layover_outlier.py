"""One fix far off while a tram stands at a layover (issue 12).

After a long stop a standing tram's fixes weigh next to nothing (their bias drifts where
it stands), and the places a matcher weighs are those near the fix. One heavy-tailed fix
28 m off along the track, behind a switch, used to carry the hypotheses there — the
reported position stepped back to the switch — and to become the reference against which
the next good fixes were rejected as jumps. A standing tram does not move: a fix whose
places only a move of more than five standard deviations of the fix's error reaches is an
outlier.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import trackmap
from antikol.evaluation.consistency import disconnected_windows, match_reports
from tests._osm import FRAME, OsmBuilder
from tests._paths import reports_along

STAND_Y = 400.0
OUTLIER_T = 400.0


#: A facing switch 15 m behind the place the tram stands at: the outlier's places lie on
#: the track before it.
SWITCH_Y = 385.0


@pytest.fixture(scope="module")
def line(tmp_path_factory):
    b = OsmBuilder()
    switch = b.node(0.0, SWITCH_Y)
    b.line([(0.0, 0.0), switch], oneway="yes")
    b.line([switch, (0.0, 1000.0)], oneway="yes")
    b.line([switch, (10.0, 420.0), (60.0, 500.0)], oneway="yes")
    return trackmap.build(b.write_xml(tmp_path_factory.mktemp("layover") / "line.osm"))


def _layover(*, odometer: bool) -> list:
    """A tram arriving at 5 m/s and standing at y = 400 m from t = 60 s to 600 s; its fixes
    scatter by 1 m, but the one at ``OUTLIER_T`` lies 28 m behind it along the track, before
    the switch."""
    path = [(0.0, 0.0), (0.0, 1000.0)]
    arriving = reports_along(
        "T", path, start_m=100.0, speed_mps=5.0, t=np.arange(0.0, 60.0), frame=FRAME
    )
    standing = reports_along(
        "T", path, start_m=STAND_Y, speed_mps=0.0, t=np.arange(60.0, 600.0), frame=FRAME
    )
    rng = np.random.default_rng(3)
    out = []
    for r in [*arriving, *standing]:
        x, y = (float(v) for v in FRAME.to_local(r.lon, r.lat))
        y = min(y, STAND_Y) - (28.0 if r.t == OUTLIER_T else 0.0)
        lon, lat = FRAME.to_lonlat(x + rng.normal(0.0, 1.0), y + rng.normal(0.0, 1.0))
        extra = {"odometer_m": min(5.0 * r.t, STAND_Y - 100.0)} if odometer else {}
        out.append(dataclasses.replace(r, lon=float(lon), lat=float(lat), **extra))
    return out


@pytest.mark.parametrize("odometer", [True, False], ids=["odometer", "speeds"])
def test_one_far_fix_at_a_layover_neither_moves_the_tram_nor_blinds_it(line, odometer):
    matched = match_reports(line, _layover(odometer=odometer))
    standing = [m for m in matched if m.t >= 70.0]
    assert all(m.matched for m in standing)
    # on the track past the switch, where it stands
    past = {m.edge_id for m in matched if m.t == 70.0}
    assert all(m.edge_id in past for m in standing)
    places = np.array([m.offset_m for m in standing]) + SWITCH_Y
    assert np.abs(places - STAND_Y).max() < 5.0
    assert disconnected_windows(line, matched)[1] == 0
    # the fixes after the outlier are taken: the place follows them, not the outlier
    after = [m for m in matched if OUTLIER_T < m.t <= OUTLIER_T + 5.0]
    assert all(m.position.status == "confident" for m in after)
