"""On-board use needs none of the extras: no map building (osmium), no figures (matplotlib,
folium), no progress bars (tqdm), no C-ITS messages (pycrate)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

EXTRAS = (
    "osmium",
    "matplotlib",
    "folium",
    "tqdm",
    "pycrate_asn1dir",
    "pycrate_asn1rt",
    "pycrate_core",
)

ONBOARD = textwrap.dedent(
    """
    import sys
    for name in {extras!r}:
        sys.modules[name] = None  # any import of it now raises ImportError

    import antikol
    import trackmap

    net = trackmap.load(trackmap.default_map_path())
    an = antikol.Analyser(track_map=net, own_id="T1")
    # the own receiver: T1 at Teatr Bagatela, 15.55 kn (8 m/s) eastbound
    an.feed_nmea("$GNRMC,221320.00,A,5003.78360,N,01955.95600,E,15.551,90.00,141123,,,A,V*0C")
    other = antikol.VehicleReport("T2", 1700000000.0, 50.06306, 19.93400, 0.0, 270.0)
    an.feed_bytes(antikol.encode_report(other))
    a = an.assess()
    assert a.own_id == "T1", a
    assert "T2" in an.table, "the radio report was not stored"
    loaded = sorted(m for m in {extras!r} if sys.modules.get(m) is not None)
    print("loaded extras:", loaded)
    """
).format(extras=EXTRAS)


def test_onboard_chain_runs_without_the_extras():
    done = subprocess.run(
        [sys.executable, "-c", ONBOARD], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "loaded extras: []" in done.stdout
