"""Several ``antikol onboard`` processes on loopback, simulated trams on the embedded map:
their lamps against one analyser, under loss and blackout, and under attack.

Each run is bounded: 26 s of report time at 4x (about 7 s of wall clock after a 10 s
start-up), four units, 127.0.0.1 only. No timed assertion: the checks are on what the
units decided, cycle by cycle.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from antikol.onboard.harness import HarnessConfig, HarnessResult, run_harness
from antikol.onboard.netem import Impairment

pytestmark = pytest.mark.slow

RUN = dict(duration_s=26.0, speed=4.0, extra_trams=2, startup_s=10.0)


def _check_processes(result: HarnessResult) -> None:
    for vid, unit in result.units.items():
        assert unit.returncode == 0, (vid, unit.stderr)
        assert unit.stats, (vid, unit.stderr)
        assert unit.stats["faults"] == {}, (vid, unit.stats["faults"])
        assert unit.stats["max_rss_kb"] < 600_000  # bounded: about 140 MB each here
    assert result.foreign_reports() == dict.fromkeys(result.units, 0)


def test_four_units_light_the_lamps_one_analyser_shows(tmp_path: Path) -> None:
    result = run_harness(HarnessConfig(workdir=tmp_path, auth="hmac-sha256", **RUN))
    _check_processes(result)
    assert len(result.units) >= 4
    assert result.lamp_mismatches() == dict.fromkeys(result.units, 0), result.summary()
    warnings = result.warnings()
    assert warnings["F"]["required"] >= 1  # the scripted approach needs a warning
    assert all(w["lost"] == 0 for w in warnings.values()), warnings
    assert all(u.lamps for u in result.units.values())


def test_loss_reordering_duplication_and_a_blackout_lose_no_warning(tmp_path: Path) -> None:
    impairment = Impairment(
        loss=0.5,
        delay_s=0.01,
        jitter_s=0.05,
        duplicate=0.2,
        reorder=0.2,
        reorder_s=0.1,
        corrupt=0.02,
        blackouts=(("L", 9.0, 19.0),),  # the leader the follower must be warned of
    )
    result = run_harness(
        HarnessConfig(workdir=tmp_path, auth="hmac-sha256", impairment=impairment, **RUN)
    )
    _check_processes(result)
    warnings = result.warnings()
    assert warnings["F"]["required"] >= 1
    assert all(w["lost"] == 0 for w in warnings.values()), (warnings, result.summary())
    assert result.relay["lost"] > 0 and result.relay["blackout"] > 0
    assert result.relay["duplicated"] > 0 and result.relay["reordered"] > 0
    rejected = [u.stats["rejected"] for u in result.units.values()]
    assert any("duplicate" in r for r in rejected)  # the relay's copies were caught


def test_an_attacker_process_changes_nothing(tmp_path: Path) -> None:
    count = 500
    result = run_harness(
        HarnessConfig(
            workdir=tmp_path,
            auth="hmac-sha256",
            attack_count=count,
            attack_rate=5000.0,
            attack_start_s=4.0,
            **RUN,
        )
    )
    _check_processes(result)
    for vid, unit in result.units.items():
        sent = sum(n for k, n in result.attacker.items() if k.startswith(f"{vid}:"))
        assert sent == count * 7, result.attacker
        rejected = unit.stats["datagrams_rejected"]
        assert rejected <= sent <= rejected + unit.stats["kernel_dropped"], unit.stats
    assert result.lamp_mismatches() == dict.fromkeys(result.units, 0), result.summary()
    assert all(w["lost"] == 0 for w in result.warnings().values())


@pytest.mark.parametrize("bad", ["L", "L:10", "L:x:20", "L:20:10", ":1:2", "L:nan:5"])
def test_a_malformed_blackout_is_a_usage_error_not_a_traceback(bad, capsys):
    from antikol.cli import main as antikol_main

    with pytest.raises(SystemExit) as exc:
        antikol_main(["harness", "--blackout", bad])
    assert exc.value.code == 2
    assert "SENDER:START:END" in capsys.readouterr().err
