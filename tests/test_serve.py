"""The live view's server (``antikol serve``) without a browser: its state, its feeds (a
replayed log, UDP radio frames), its routes, access control and command line.

(The page in a real browser, following a replay: ``tests/test_browser.py``.)
"""

from __future__ import annotations

import asyncio
import json
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("starlette")
pytest.importorskip("uvicorn")
pytest.importorskip("folium")

from antikol import encode_report
from antikol.cli import main
from antikol.ingest.replaylog import ReplayLog
from antikol.serve import (
    LiveView,
    ServerThread,
    check_access,
    create_app,
    is_loopback,
    live_page,
    replay_feed,
    udp_feed,
)
from tests._paths import interleave, reports_from_xy


def head_on_log(seconds: int = 46) -> ReplayLog:
    """Two trams approaching on parallel tracks 4 m apart: the sector rule warns."""
    t = np.arange(0.0, float(seconds), 1.0)
    v1 = reports_from_xy("V1", t, np.zeros_like(t), -350.0 + 8.0 * t)
    v2 = reports_from_xy("V2", t, np.full_like(t, 4.0), 350.0 - 8.0 * t)
    return ReplayLog(reports=interleave(v1, v2), source="fig11")


def get(url: str, **headers: str) -> tuple[int, dict[str, str], bytes]:
    req = urllib.request.Request(url, headers=headers)
    try:
        with urllib.request.urlopen(req, timeout=30) as resp:
            return resp.status, dict(resp.headers), resp.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def sse_events(url: str, count: int) -> Iterator[tuple[str, dict[str, object]]]:
    """The first ``count`` events of a server-sent event stream."""
    with urllib.request.urlopen(url, timeout=30) as resp:
        assert resp.headers["Content-Type"].startswith("text/event-stream")
        kind, seen = "message", 0
        for raw in resp:
            line = raw.decode().rstrip("\n")
            if line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: "):
                yield kind, json.loads(line[6:])
                seen += 1
                kind = "message"
                if seen >= count:
                    return


# -- state ---------------------------------------------------------------------------------
def test_live_view_snapshots_and_first_warning() -> None:
    view = LiveView(None, source="test")
    log = head_on_log()
    from antikol.evaluation.replay import cycles

    snaps = [view.cycle(t, batch) for t, batch in cycles(log.reports, 1.0)]
    assert [s["cycle"] for s in snaps] == list(range(1, len(snaps) + 1))
    assert view.latest is snaps[-1]
    first = view.first_warning_cycle
    assert first is not None and 1 < first < len(snaps)
    assert not snaps[first - 2]["warnings"] and snaps[first - 1]["warnings"]
    w = snaps[first - 1]["warnings"][0]
    assert {w["own"], w["other"]} == {"V1", "V2"} and w["kind"] == "sector"
    assert w["d"] > 0 and w["v"] > 0
    v1 = [next(v for v in s["vehicles"] if v["id"] == "V1") for s in snaps]
    assert len({(v["lat"], v["lon"]) for v in v1}) == len(snaps)  # it moves every cycle
    assert v1[first - 1]["lamp"]


def test_a_slow_viewer_loses_the_oldest_snapshots_only() -> None:
    async def scenario() -> tuple[list[int], int]:
        view = LiveView(None, queue_size=3)
        sub = view.subscribe()
        log = head_on_log(10)
        from antikol.evaluation.replay import cycles

        for t, batch in cycles(log.reports, 1.0):
            view.cycle(t, batch)
        got = [(await sub.get())["cycle"] for _ in range(3)]
        view.unsubscribe(sub)
        return got, sub.dropped

    got, dropped = asyncio.run(scenario())
    assert got == [8, 9, 10] and dropped == 7


def test_replay_feed_plays_every_cycle_then_ends() -> None:
    async def scenario() -> tuple[list[int], bool]:
        view = LiveView(None)
        sub = view.subscribe()
        await replay_feed(view, head_on_log(12), speed=1000.0)
        seen = []
        while not sub.queue.empty():
            snap = await sub.get()
            seen.append(-1 if snap["end"] else snap["cycle"])
        return seen, view.ended

    seen, ended = asyncio.run(scenario())
    assert seen == [*range(1, 13), -1] and ended
    with pytest.raises(ValueError, match="speed"):
        asyncio.run(replay_feed(LiveView(None), head_on_log(3), speed=0.0))


def test_udp_feed_analyses_radio_frames() -> None:
    async def scenario() -> dict[str, object]:
        view = LiveView(None)
        ready = asyncio.Event()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        task = asyncio.create_task(udp_feed(view, port=port, cycle_s=0.05, ready=ready))
        await asyncio.wait_for(ready.wait(), 10)
        sub = view.subscribe()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
            for r in head_on_log(3).reports:
                tx.sendto(encode_report(r), ("127.0.0.1", port))
            tx.sendto(b"\x00garbage\x00", ("127.0.0.1", port))  # counted, never raised
        while True:
            snap = await asyncio.wait_for(sub.get(), 10)
            if len(snap["vehicles"]) == 2:  # type: ignore[arg-type]
                break
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        return snap

    snap = asyncio.run(scenario())
    assert [v["id"] for v in snap["vehicles"]] == ["V1", "V2"]  # type: ignore[index]
    assert snap["t"] == 2.0


# -- access ---------------------------------------------------------------------------------
def test_access_rules() -> None:
    assert is_loopback("127.0.0.1") and is_loopback("localhost") and is_loopback("::1")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.5")
    assert check_access("127.0.0.1", None) is None
    made = check_access("0.0.0.0", None)
    assert made is not None and len(made) >= 20
    assert check_access("0.0.0.0", None) != made
    assert check_access("127.0.0.1", "a-long-enough-token") == "a-long-enough-token"
    with pytest.raises(ValueError, match="at least 12"):
        check_access("0.0.0.0", "short")


@pytest.fixture(scope="module")
def page() -> str:
    return live_page(None, title="test")


def test_routes_are_read_only_with_a_strict_security_policy(page: str) -> None:
    view = LiveView(None, source="test")
    app = create_app(view, page)
    with ServerThread(app) as server:
        status, headers, body = get(server.url)
        assert status == 200 and body.decode() == page
        csp = headers["content-security-policy"]
        assert "default-src 'none'" in csp and "connect-src 'self'" in csp
        assert "https:" not in csp  # no tiles: nothing to fetch from elsewhere
        assert get(server.url + "snapshot")[2] == b"null"
        health = json.loads(get(server.url + "health")[2])
        assert health == {"ok": True, "cycles": 0, "viewers": 0, "ended": False}
        req = urllib.request.Request(server.url, data=b"x", method="POST")
        with pytest.raises(urllib.error.HTTPError) as info:
            urllib.request.urlopen(req, timeout=30)
        assert info.value.code == 405


def test_a_token_guards_every_route(page: str) -> None:
    token = "s3cret-token-for-tests"
    app = create_app(LiveView(None), page, token=token)
    with ServerThread(app) as server:
        for route in ("", "events", "snapshot", "health"):
            assert get(server.url + route)[0] == 401, route
        assert get(server.url + "health?token=wrong-token-wrong")[0] == 401
        assert get(server.url + f"health?token={token}")[0] == 200
        assert get(server.url + "health", Authorization=f"Bearer {token}")[0] == 200


def test_events_stream_follows_a_replay(page: str) -> None:
    view = LiveView(None, source="test")

    async def feed() -> None:
        await replay_feed(view, head_on_log(8), speed=50.0, wait_for_viewer=True)

    with ServerThread(create_app(view, page, feed=feed)) as server:
        events = list(sse_events(server.url + "events", 9))
    kinds = [k for k, _ in events]
    assert kinds == ["snapshot"] * 8 + ["end"]
    assert [e["cycle"] for _, e in events[:8]] == list(range(1, 9))


def test_cli_serve_errors(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["serve"])  # a source is required
    assert "--replay" in capsys.readouterr().err
    assert main(["serve", "--map", "none", "--udp", "host:notaport"]) == 2
    assert "not [HOST:]PORT" in capsys.readouterr().err
    assert main(["serve", "--map", "none", "--udp", "5005", "--token", "short"]) == 2
    assert "at least 12" in capsys.readouterr().err


def test_cli_serve_runs_a_replay(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    from antikol.ingest.replaylog import write_replay_csv

    write_replay_csv(log, head_on_log(6).reports)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    cmd = [sys.executable, "-m", "antikol", "serve", "--map", "none", "--replay", str(log)]
    cmd += ["--speed", "20", "--port", str(port)]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        banner = proc.stderr.readline()
        assert f"open http://127.0.0.1:{port}/" in banner and "?token" not in banner
        deadline = 0
        while True:  # wait until it answers (no timing is asserted)
            try:
                health = json.loads(get(f"http://127.0.0.1:{port}/health")[2])
                if health["ended"]:
                    break
            except (urllib.error.URLError, ConnectionError):
                pass
            deadline += 1
            assert deadline < 600, "the server never finished its replay"
            time.sleep(0.1)
        assert health["cycles"] == 6
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_onboard_use_does_not_load_the_web_server() -> None:
    code = (
        "import sys; import antikol, trackmap, antikol.cli; "
        "print(sorted(m for m in ('starlette', 'uvicorn', 'selenium', 'folium') "
        "if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
