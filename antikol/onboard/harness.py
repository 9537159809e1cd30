"""Loopback test harness: several ``antikol onboard`` processes, a lossy relay, an attacker.

For tests and figures on one machine (127.0.0.1 only; bounded in count and time). The
harness

1. simulates a scripted approach (a scenario of :mod:`antikol.evaluation.scenarios`, by
   default ``following_straight``: a follower closes in on a slow leader) plus a few
   trams on random routes of the embedded Kraków map, and writes their reports to a
   replay CSV;
2. writes fleet keys, picks free loopback ports and starts one ``antikol onboard``
   process per tram, each reading its own reports at the shared epoch (``--speed`` times
   faster than real time), sending to the relay (:mod:`antikol.onboard.netem`) or
   directly to the others;
3. optionally starts the attacker process (:mod:`antikol.onboard.attacker`), which
   sniffs the relay's tap and sends every kind of hostile frame to the units;
4. collects each unit's lamp per cycle, accepted reports and closing statistics, and
   compares them with one control-room :class:`~antikol.analysis.analyser.Analyser` fed
   the same (quantised) reports.

``antikol harness --help`` (:mod:`antikol.cli.harness`) runs it from the shell and prints
the figures.
"""

from __future__ import annotations

import json
import logging
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from antikol.analysis.analyser import Analyser
from antikol.evaluation.replay import cycles
from antikol.ingest.auth import generate_key_files
from antikol.ingest.protocol import decode_frame, encode_report
from antikol.ingest.replaylog import read_replay_csv
from antikol.onboard.attacker import ATTACK_KINDS
from antikol.onboard.netem import Impairment, Relay
from antikol.report import VehicleReport

__all__ = [
    "HarnessConfig",
    "HarnessResult",
    "UnitResult",
    "run_harness",
    "simulate_traffic",
]

logger = logging.getLogger(__name__)

_INSIDER = "X9"


@dataclass(frozen=True)
class HarnessConfig:
    """One harness run.

    Attributes
    ----------
    workdir : pathlib.Path
        Where the CSV, keys, logs and outputs go.
    scenario : str
        The scripted approach (a scenario name).
    extra_trams : int
        Trams on random routes besides the scenario's.
    duration_s : float
        Report time simulated and run, s.
    speed : float
        Report seconds per wall-clock second.
    auth : {"hmac-sha256", "ed25519", "none"}
    impairment : Impairment or None
        None: the units send to each other directly.
    attack_count : int
        Hostile frames of each kind per target (0: no attacker).
    attack_kinds : tuple of str
    attack_rate : float
        Attacker datagrams per wall-clock second.
    attack_start_s : float
        Report time the attack starts at.
    map_name : str
        ``--map`` of the units (``default``: the embedded Kraków map).
    seed : int
    startup_s : float
        Wall-clock seconds between starting the processes and report time 0.
    """

    workdir: Path
    scenario: str = "following_straight"
    extra_trams: int = 2
    duration_s: float = 30.0
    speed: float = 3.0
    auth: str = "hmac-sha256"
    impairment: Impairment | None = None
    attack_count: int = 0
    attack_kinds: tuple[str, ...] = ATTACK_KINDS
    attack_rate: float = 4000.0
    attack_start_s: float = 6.0
    map_name: str = "default"
    seed: int = 0
    startup_s: float = 10.0


@dataclass
class UnitResult:
    """What one unit process did."""

    vehicle_id: str
    returncode: int | None
    stats: dict[str, Any]
    lamps: dict[int, bool]
    rx: list[tuple[str, float, float, float]]
    stderr: str = ""


@dataclass
class HarnessResult:
    """Everything a run produced, with the checks of the issue."""

    config: HarnessConfig
    units: dict[str, UnitResult]
    reference: dict[str, dict[int, bool]]
    genuine: dict[tuple[str, float], tuple[float, float]]
    relay: dict[str, int] = field(default_factory=dict)
    attacker: dict[str, int] = field(default_factory=dict)

    def lamp_mismatches(self) -> dict[str, int]:
        """Per unit: cycles whose lamp matches the reference at none of k-1, k, k+1."""
        out = {}
        for vid, unit in self.units.items():
            ref = self.reference.get(vid, {})
            bad = 0
            for k, on in unit.lamps.items():
                near = [ref[j] for j in (k - 1, k, k + 1) if j in ref]
                if near and on not in near:
                    bad += 1
            out[vid] = bad
        return out

    def warnings(self) -> dict[str, dict[str, int]]:
        """Per unit: reference lamp-on onsets, caught on time, one cycle late, lost."""
        out = {}
        for vid, unit in self.units.items():
            ref = self.reference.get(vid, {})
            counts = {"required": 0, "on_time": 0, "late": 0, "lost": 0}
            for k, on in sorted(ref.items()):
                if not on or ref.get(k - 1, False):
                    continue
                counts["required"] += 1
                if unit.lamps.get(k):
                    counts["on_time"] += 1
                elif unit.lamps.get(k + 1):
                    counts["late"] += 1
                else:
                    counts["lost"] += 1
            out[vid] = counts
        return out

    def foreign_reports(self) -> dict[str, int]:
        """Per unit: accepted reports that no vehicle sent (phantoms) or sent elsewhere
        (moved)."""
        out = {}
        for vid, unit in self.units.items():
            bad = 0
            for rid, t, lat, lon in unit.rx:
                where = self.genuine.get((rid, t))
                if where is None or abs(where[0] - lat) > 1e-9 or abs(where[1] - lon) > 1e-9:
                    bad += 1
            out[vid] = bad
        return out

    def summary(self) -> dict[str, Any]:
        """The figures of the run (JSON-ready)."""
        return {
            "units": len(self.units),
            "exit_codes": {v: u.returncode for v, u in self.units.items()},
            "cycles": {v: u.stats.get("cycles") for v, u in self.units.items()},
            "overruns": {v: u.stats.get("overruns") for v, u in self.units.items()},
            "lamp_mismatches": self.lamp_mismatches(),
            "warnings": self.warnings(),
            "foreign_reports": self.foreign_reports(),
            "accepted": {v: u.stats.get("accepted") for v, u in self.units.items()},
            "rejected": {v: u.stats.get("rejected") for v, u in self.units.items()},
            "datagrams_rejected": {
                v: u.stats.get("datagrams_rejected") for v, u in self.units.items()
            },
            "kernel_dropped": {v: u.stats.get("kernel_dropped") for v, u in self.units.items()},
            "max_rss_kb": {v: u.stats.get("max_rss_kb") for v, u in self.units.items()},
            "relay": self.relay,
            "attacker": self.attacker,
        }


def _free_ports(n: int) -> list[int]:
    socks = []
    for _ in range(n):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", 0))
        socks.append(s)
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def simulate_traffic(
    net: Any, *, scenario: str, extra_trams: int, duration_s: float, seed: int
) -> Any:
    """The scripted approach plus ``extra_trams`` trams on random routes, simulated.

    Returns
    -------
    antikol.sim.SimulationResult
    """
    from antikol.evaluation.scenarios import build_scenario
    from antikol.sim import Simulator, fleet

    scn = build_scenario(scenario, net, seed=seed)
    specs = list(scn.specs) + fleet(net, extra_trams, seed + 1, route_length_m=3000.0)
    return Simulator(net, specs, gps=scn.gps, seed=seed).run(duration_s)


def _simulate(cfg: HarnessConfig, net: Any, csv: Path) -> list[str]:
    result = simulate_traffic(
        net,
        scenario=cfg.scenario,
        extra_trams=cfg.extra_trams,
        duration_s=cfg.duration_s,
        seed=cfg.seed,
    )
    result.write_csv(csv, extra_columns=("braking", "length_m", "antenna_offset_m"))
    return [s.vehicle_id for s in result.specs]


def _reference(reports: list[VehicleReport], net: Any, until: float) -> dict[str, dict[int, bool]]:
    analyser = Analyser(track_map=net)
    lamps: dict[str, dict[int, bool]] = {}
    for t_end, batch in cycles(reports, 1.0):
        if t_end > until:
            break
        analyser.update_many(batch)
        for vid, a in analyser.assess_all(t=t_end).items():
            lamps.setdefault(vid, {})[round(t_end)] = a.lamp
    return lamps


def _read_unit(vid: str, proc: subprocess.Popen[str], log: Path, cycle_s: float) -> UnitResult:
    out, err = proc.communicate(timeout=30)
    stats: dict[str, Any] = {}
    for line in out.splitlines():
        try:
            event = json.loads(line)
        except json.JSONDecodeError:
            continue
        if event.get("event") == "stop":
            stats = event
    lamps: dict[int, bool] = {}
    rx: list[tuple[str, float, float, float]] = []
    if log.exists():
        for line in log.read_text(encoding="utf-8").splitlines():
            row = json.loads(line)
            if row["ev"] == "cycle" and vid in row["lamps"]:
                on = row["lamps"][vid][0]
                if on is not None:
                    lamps[round(row["t"] / cycle_s)] = bool(on)
            elif row["ev"] == "rx":
                rx.append((row["id"], row["t"], row["lat"], row["lon"]))
    return UnitResult(vid, proc.returncode, stats, lamps, rx, err[-4000:])


def run_harness(cfg: HarnessConfig) -> HarnessResult:
    """Run the harness once (see the module docstring); bounded by the configuration.

    Returns
    -------
    HarnessResult
    """
    import trackmap
    from trackmap.named import load_named

    work = cfg.workdir
    work.mkdir(parents=True, exist_ok=True)
    net = load_named(cfg.map_name)
    sim_net = net if net is not None else trackmap.load_default()
    csv = work / "reports.csv"
    ids = _simulate(cfg, sim_net, csv)
    genuine_reports = [decode_frame(encode_report(r)) for r in read_replay_csv(csv).reports]
    genuine = {(r.vehicle_id, r.t): (r.lat, r.lon) for r in genuine_reports}
    keyfiles: dict[str, Path] = {}
    if cfg.auth != "none":
        keyfiles = generate_key_files(work / "keys", cfg.auth, [*ids, _INSIDER])  # type: ignore[arg-type]
    ports = dict(zip(ids, _free_ports(len(ids) + 1), strict=False))
    tap_port = _free_ports(1)[0]
    epoch = time.time() + cfg.startup_s
    relay: Relay | None = None
    if cfg.impairment is not None or cfg.attack_count:
        relay = Relay(
            ports,
            cfg.impairment or Impairment(),
            report_time=lambda wall: (wall - epoch) * cfg.speed,
            seed=cfg.seed,
            tap=("127.0.0.1", tap_port) if cfg.attack_count else None,
        )
        relay.start()
    wall_s = cfg.startup_s + cfg.duration_s / cfg.speed + 5.0
    procs: dict[str, subprocess.Popen[str]] = {}
    logs: dict[str, Path] = {}
    try:
        for vid in ids:
            peers = (
                [f"127.0.0.1:{relay.address[1]}"]
                if relay is not None
                else [f"127.0.0.1:{p}" for v, p in ports.items() if v != vid]
            )
            logs[vid] = work / f"{vid}.log"
            cmd = [sys.executable, "-m", "antikol", "onboard", "--id", vid]
            cmd += ["--gps", f"replay:{csv}", "--map", cfg.map_name]
            cmd += ["--listen", f"127.0.0.1:{ports[vid]}"]
            for peer in peers:
                cmd += ["--peer", peer]
            cmd += ["--key-file", str(keyfiles[vid])] if keyfiles else ["--unauthenticated"]
            cmd += ["--speed", str(cfg.speed), "--epoch", repr(epoch), "--duration", str(wall_s)]
            cmd += ["--json", "--log", str(logs[vid])]
            procs[vid] = subprocess.Popen(
                cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
        attacker: subprocess.Popen[str] | None = None
        if cfg.attack_count:
            cmd = [sys.executable, "-m", "antikol.onboard.attacker"]
            cmd += ["--targets", ",".join(f"{v}={p}" for v, p in ports.items())]
            cmd += ["--tap-port", str(tap_port), "--count", str(cfg.attack_count)]
            cmd += ["--kinds", ",".join(cfg.attack_kinds), "--rate", str(cfg.attack_rate)]
            cmd += ["--epoch", repr(epoch), "--speed", str(cfg.speed)]
            cmd += ["--scheme", cfg.auth if cfg.auth != "none" else "hmac-sha256"]
            cmd += ["--start-after", str(cfg.attack_start_s), "--seed", str(cfg.seed)]
            if keyfiles:
                cmd += ["--insider-key", str(keyfiles[_INSIDER])]
            attacker = subprocess.Popen(
                cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
        deadline = time.time() + wall_s + 30.0
        for proc in procs.values():
            try:
                proc.wait(timeout=max(1.0, deadline - time.time()))
            except subprocess.TimeoutExpired:
                proc.send_signal(signal.SIGTERM)
        sent: dict[str, int] = {}
        if attacker is not None:
            try:
                a_out, a_err = attacker.communicate(timeout=max(1.0, deadline - time.time()))
                sent = json.loads(a_out.strip().splitlines()[-1])["sent"] if a_out.strip() else {}
                if attacker.returncode:
                    logger.error("attacker failed: %s", a_err[-2000:])
            except subprocess.TimeoutExpired:
                attacker.kill()
        units = {v: _read_unit(v, p, logs[v], 1.0) for v, p in procs.items()}
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
        if relay is not None:
            relay.stop()
    reference = _reference(genuine_reports, net, cfg.duration_s)
    return HarnessResult(cfg, units, reference, genuine, dict(relay.stats) if relay else {}, sent)
