"""The pages in a real browser: headless Chromium with the network off.

Debian's ``chromium`` and ``chromium-driver`` (``apt-get install chromium
chromium-driver``; ``.ci/run`` installs them), driven by selenium through the system's
chromedriver; nothing downloads a browser. Without them the tests skip, saying so — unless
``ANTIKOL_BROWSER_TESTS=required`` (set by ``.ci/run`` once it has installed them), when
they fail. ``ANTIKOL_CHROMIUM`` and ``ANTIKOL_CHROMEDRIVER`` name other binaries.

The network is off: the browser's only proxy is a closed local port, and the file pages
are opened with the network emulated offline. Every request the browser makes is read
from its log and must be to the page itself (``file:``, ``data:``, or the live view's own
loopback server). No test asserts a duration: waits have generous limits only.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import trackmap
from antikol.cli import main
from antikol.evaluation.scenarios import build_scenario, run_scenario
from trackmap.cli import main as trackmap_main

pytest.importorskip("folium")
webdriver = pytest.importorskip("selenium.webdriver")

WIDTH, HEIGHT = 1000, 800


def _browser_binaries() -> tuple[str, str] | None:
    chrome = os.environ.get("ANTIKOL_CHROMIUM") or next(
        (
            found
            for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
            if (found := shutil.which(name))
        ),
        None,
    )
    driver = os.environ.get("ANTIKOL_CHROMEDRIVER") or shutil.which("chromedriver")
    return (chrome, driver) if chrome and driver else None


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    found = _browser_binaries()
    if found is None:
        reason = (
            "no Chromium with chromedriver on this machine: install Debian's chromium and "
            "chromium-driver (apt-get install chromium chromium-driver) to run the browser tests"
        )
        if os.environ.get("ANTIKOL_BROWSER_TESTS") == "required":
            pytest.fail(reason)
        pytest.skip(reason)
    from selenium.webdriver.chrome.service import Service

    os.environ.setdefault("SE_OFFLINE", "true")  # selenium must not try to fetch a driver
    chrome, driver = found
    options = webdriver.ChromeOptions()
    options.binary_location = chrome
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-quic",
        "--no-first-run",
        "--force-device-scale-factor=1",
        f"--window-size={WIDTH},{HEIGHT}",
        # the only way out is a closed port (loopback is never proxied)
        "--proxy-server=http://127.0.0.1:9",
        f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}",
    ):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    drv = webdriver.Chrome(options=options, service=Service(driver))
    drv.set_page_load_timeout(120)
    drv.set_script_timeout(60)
    try:
        yield drv
    finally:
        drv.quit()


def wait_for(check: Callable[[], Any], what: str, limit_s: float = 120.0) -> Any:
    """Poll ``check`` until it returns something truthy (a limit, not a timing test)."""
    end = time.monotonic() + limit_s
    while True:
        value = check()
        if value:
            return value
        if time.monotonic() > end:
            raise AssertionError(f"gave up waiting for {what}")
        time.sleep(0.05)


def requests_made(drv: Any) -> list[str]:
    """Addresses of the requests in the browser's log since it was last read."""
    urls = []
    for entry in drv.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg["method"] == "Network.requestWillBeSent":
            urls.append(msg["params"]["request"]["url"])
    return urls


def outside(urls: list[str], allowed: tuple[str, ...] = ()) -> list[str]:
    """The requests that left the page: not file:, data: or an allowed prefix."""
    own = ("file:", "data:", "about:", "chrome:", "chrome-untrusted:", "devtools:", *allowed)
    return [u for u in urls if not u.startswith(own)]


def console_errors(drv: Any) -> list[str]:
    return [e["message"] for e in drv.get_log("browser") if e["level"] == "SEVERE"]


def open_offline(drv: Any, page: Path) -> None:
    drv.get_log("performance")
    drv.get_log("browser")
    drv.execute_cdp_cmd("Network.enable", {})
    drv.execute_cdp_cmd(
        "Network.emulateNetworkConditions",
        {"offline": True, "latency": 0, "downloadThroughput": 0, "uploadThroughput": 0},
    )
    drv.get(page.as_uri())
    wait_for(lambda: drv.execute_script("return document.readyState") == "complete", "load")


SETTLED = """
var m = Object.keys(window).map(function (k) { return window[k]; })
  .filter(function (v) { return v instanceof L.Map; })[0];
return !!m && !m._animatingZoom && !(m._panAnim && m._panAnim._inProgress);
"""

CANVAS_INK = """
var n = 0;
document.querySelectorAll('.leaflet-overlay-pane canvas').forEach(function (c) {
  var d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  for (var i = 3; i < d.length; i += 4) { if (d[i] > 0) { n++; } }
});
return n;
"""


def pixels_near(png: bytes, rgb: tuple[int, int, int], tol: int = 30) -> int:
    """Pixels of a screenshot within ``tol`` of a colour (per channel)."""
    image = pytest.importorskip("PIL.Image")
    import numpy as np

    px = np.asarray(image.open(io.BytesIO(png)).convert("RGB"), dtype=int)
    return int((np.abs(px - np.array(rgb)).max(axis=2) <= tol).sum())


def colours(png: bytes) -> int:
    image = pytest.importorskip("PIL.Image")
    import numpy as np

    px = np.asarray(image.open(io.BytesIO(png)).convert("RGB"))
    return len(np.unique(px.reshape(-1, 3), axis=0))


def hexrgb(colour: str) -> tuple[int, int, int]:
    return int(colour[1:3], 16), int(colour[3:5], 16), int(colour[5:7], 16)


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The pages a user writes: the issue's map command, a replay's and a comparison's
    result maps."""
    d = tmp_path_factory.mktemp("pages")
    out = {}
    out["map"] = d / "k.html"
    src = trackmap.default_map_path()
    assert trackmap_main(["plot", str(src), "-o", str(out["map"]), "--tiles", "none"]) == 0
    net = trackmap.load_default()
    log = run_scenario(build_scenario("merge_at_switch", net, seed=1)).write_csv(d / "m.csv")
    out["replay"] = d / "replay.html"
    events = str(d / "e.csv")
    assert (
        main(["replay", str(log), "--map", "default", "-o", events, "--html", str(out["replay"])])
        == 0
    )
    cmp = ["compare", "--map", "synthetic", "--scenario", "merge_at_switch"]
    assert main([*cmp, "--html", str(d / "compare")]) == 0
    out["compare"] = d / "compare" / "merge_at_switch.html"
    return out


def test_pages_draw_their_tracks_offline(browser: Any, pages: dict[str, Path]) -> None:
    from trackmap.plot_html import MUTED_TRACK_COLOUR
    from trackmap.plot_style import TRACK_COLOURS

    track_colour = {
        "map": TRACK_COLOURS["main"],
        "replay": MUTED_TRACK_COLOUR,
        "compare": MUTED_TRACK_COLOUR,
    }
    for name, page in pages.items():
        open_offline(browser, page)
        assert browser.execute_script("return typeof L") == "object", name
        wait_for(lambda: browser.execute_script(SETTLED), f"{name}: the view settling")
        wait_for(lambda: browser.execute_script(CANVAS_INK) > 2000, f"{name}: drawing")
        png = browser.get_screenshot_as_png()
        (page.parent / f"{page.stem}-screenshot.png").write_bytes(png)
        assert colours(png) > 20, f"{name}: the screenshot is blank"
        assert pixels_near(png, hexrgb(track_colour[name])) > 1500, f"{name}: no tracks drawn"
        if name != "map":  # results: paths with the lamp on, and event markers
            assert pixels_near(png, hexrgb("#d62728")) > 100, f"{name}: no lamp-on path"
            n = browser.execute_script("return Object.keys(antikolResultsView.markers).length")
            assert n > 0
        else:
            legend = browser.find_element("id", "trackmap-legend").text
            assert "main line" in legend and "point switch" in legend
        assert outside(requests_made(browser)) == [], name
        assert console_errors(browser) == [], name


def test_one_click_shows_a_pair_chart(browser: Any, pages: dict[str, Path]) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    open_offline(browser, pages["compare"])
    wait_for(lambda: browser.execute_script(CANVAS_INK) > 2000, "drawing")
    # a click on a missed warning's marker, where Leaflet drew it on the canvas
    event = browser.execute_script(
        "var v = antikolResultsView;"
        "var e = v.data.events.filter(function (e) { return e.cat === 'missed'; })[0];"
        "v.map.setView([e.lat, e.lon], 18, {animate: false});"
        "var p = v.map.latLngToContainerPoint([e.lat, e.lon]);"
        "return {id: e.id, x: p.x, y: p.y, own: e.own, other: e.other, kind: e.kind};"
    )
    wait_for(lambda: browser.execute_script(CANVAS_INK) > 500, "redrawing")
    box = browser.find_element("css selector", ".leaflet-container")
    offset = (event["x"] - box.size["width"] / 2, event["y"] - box.size["height"] / 2)
    ActionChains(browser).move_to_element_with_offset(box, *offset).click().perform()
    popup = wait_for(
        lambda: browser.find_elements("css selector", ".leaflet-popup .ak-pop"), "the popup"
    )[0]
    # visible once it has faded in and the map has panned to show all of it
    text = wait_for(lambda: "missed warning:" in popup.text and popup.text, "the whole popup")
    # the marker clicked (the two vehicles' misses share a place: either is on top)
    shown = browser.execute_script(
        "return antikolResultsView.data.events[arguments[0]]",
        int(popup.get_attribute("data-event")),
    )
    assert shown["cat"] == "missed" and shown["kind"] == event["kind"]
    assert {shown["own"], shown["other"]} == {event["own"], event["other"]}
    assert f"missed warning: {shown['own']} about {shown['other']}" in text
    for field in ("kind", "level", "time", "distance", "closing speed", shown["kind"]):
        assert field in text, field
    chart = popup.find_element("css selector", ".ak-chart svg")
    assert chart.find_elements("css selector", "polyline")  # distance against time
    assert "track-aware analyser" in chart.text and "sector rule" in chart.text
    (pages["compare"].parent / "popup-screenshot.png").write_bytes(browser.get_screenshot_as_png())
    # a click on a row of the panel's list opens another event
    browser.find_element("css selector", ".leaflet-popup-close-button").click()
    rows = browser.find_elements("css selector", ".ak-events tr[data-event]")
    assert len(rows) == len(browser.execute_script("return antikolResultsView.data.events"))
    rows[0].click()
    wait_for(
        lambda: browser.find_elements("css selector", ".leaflet-popup .ak-chart svg"),
        "the popup of the first row",
    )
    assert outside(requests_made(browser)) == []
    assert console_errors(browser) == []


def test_live_view_follows_a_replay(browser: Any, tmp_path: Path) -> None:
    pytest.importorskip("starlette")
    from antikol.ingest.replaylog import read_replay_csv
    from antikol.serve import LiveView, ServerThread, create_app, live_page, replay_feed

    net = trackmap.load_default()
    scripted = run_scenario(build_scenario("merge_at_switch", net, seed=1))
    log = read_replay_csv(scripted.write_csv(tmp_path / "merge.csv"))
    published: list[dict[str, Any]] = []
    view = LiveView(net, source="test replay", on_snapshot=published.append)

    async def feed() -> None:
        await replay_feed(view, log, speed=20.0, wait_for_viewer=True)

    browser.execute_cdp_cmd(
        "Network.emulateNetworkConditions",
        {"offline": False, "latency": 0, "downloadThroughput": -1, "uploadThroughput": -1},
    )
    browser.get_log("performance")
    browser.get_log("browser")
    with ServerThread(create_app(view, live_page(net), feed=feed)) as server:
        browser.get(server.url)
        wait_for(
            lambda: browser.execute_script(
                "return window.antikolLiveView && antikolLiveView.ended"
            ),
            "the end of the replay",
        )
        history = browser.execute_script("return antikolLiveView.history")
        status = browser.find_element("id", "ak-status").text
        (tmp_path / "live-screenshot.png").write_bytes(browser.get_screenshot_as_png())
        urls = requests_made(browser)
    assert status == "the replay has ended"
    shown = [h for h in history if not h["end"]]
    # every cycle drawn, in order, none lost
    assert [h["cycle"] for h in shown] == [s["cycle"] for s in published if not s["end"]]
    assert view.cycles == len(shown) > 50
    # the markers move, and each is drawn where the server placed it
    for h, s in zip(shown, published, strict=False):
        assert set(h["markers"]) == {v["id"] for v in s["vehicles"]}
        for v in s["vehicles"]:
            assert h["markers"][v["id"]] == pytest.approx([v["lat"], v["lon"]], abs=1e-7)
    track_a = {tuple(h["markers"]["A"]) for h in shown if "A" in h["markers"]}
    assert len(track_a) > 30
    # the scripted warning: on the page in the very cycle the analyser raised it, and every
    # change of the warnings after it too (each snapshot is drawn before the next arrives)
    first = view.first_warning_cycle
    assert first is not None
    page_first = next(h["cycle"] for h in shown if h["warnings"])
    assert page_first == first
    for h, s in zip(shown, published, strict=False):
        expected = sorted(f"{w['own']}>{w['other']}:{w['level']}" for w in s["warnings"])
        assert sorted(h["warnings"]) == expected, h["cycle"]
    assert any("merge" in str(s["warnings"]) for s in published)
    # nothing but the server itself was asked for anything
    assert outside(urls, (server.url,)) == []
    assert console_errors(browser) == []
