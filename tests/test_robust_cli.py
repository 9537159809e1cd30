"""Both command lines end every failure in one line and an exit status of its own:
0 ok, 1 findings (trackmap check), 2 usage or input error, 3 internal error (issue 14)."""

from __future__ import annotations

import json

import pytest

from antikol.cli import main as antikol_main
from tests._fuzz import base_map_text, base_network
from trackmap.cli import main as trackmap_main


@pytest.fixture()
def files(tmp_path):
    good = tmp_path / "good.trackmap.geojson"
    good.write_text(base_map_text())
    broken = tmp_path / "broken.trackmap.geojson"
    doc = json.loads(base_map_text())
    doc["features"][0]["properties"]["node_ids"][0] = None
    broken.write_text(json.dumps(doc))
    src = base_network().write_overpass(tmp_path / "src.json")
    bad_src = tmp_path / "bad.json"
    bad_src.write_text(src.read_text().replace('"tags": {"railway"', '"tags": [{"railway"', 1))
    log = tmp_path / "log.csv"
    log.write_text("vehicle_id,t,lat,lon,speed_mps,course_deg\nT1,0,50.06,19.94,5,90\n")
    return {
        "good": good,
        "broken": broken,
        "src": src,
        "bad_src": bad_src,
        "log": log,
        "out": tmp_path / "out.trackmap.geojson",
        "tmp": tmp_path,
    }


TRACKMAP_INPUT_ERRORS = [
    ["info", "{broken}"],
    ["check", "{broken}"],
    ["plot", "{broken}", "-o", "{tmp}/m.png"],
    ["info", "{tmp}/missing.geojson"],
    ["build", "{bad_src}", "-o", "{out}"],
    ["build", "{src}", "-o", "{out}", "--kinds", "monorail"],
    ["build", "{src}", "-o", "{tmp}/no/such/dir/out.geojson"],
    ["plot", "{good}", "-o", "{tmp}/m.xyz"],
    ["build", "{good}", "-o", "{out}"],
]
ANTIKOL_INPUT_ERRORS = [
    ["replay", "{log}", "--map", "{broken}", "-o", "{tmp}/e.csv"],
    ["replay", "{log}", "--map", "{tmp}/missing.geojson", "-o", "{tmp}/e.csv"],
    ["replay", "{tmp}/missing.csv", "-o", "{tmp}/e.csv"],
    ["replay", "{src}", "--format", "csv", "-o", "{tmp}/e.csv"],
    ["replay", "{log}", "-o", "{tmp}/no/such/dir/e.csv"],
    ["simulate", "--map", "{broken}"],
    ["compare", "--scenario", "nonsense", "--map", "synthetic"],
]


def _argv(args, files):
    return [a.format(**{k: str(v) for k, v in files.items()}) for a in args]


@pytest.mark.parametrize("args", TRACKMAP_INPUT_ERRORS, ids=" ".join)
def test_trackmap_input_errors_exit_2_with_one_line(args, files, capsys):
    assert trackmap_main(_argv(args, files)) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and f"trackmap {args[0]}: error: " in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("args", ANTIKOL_INPUT_ERRORS, ids=" ".join)
def test_antikol_input_errors_exit_2_with_one_line(args, files, capsys):
    assert antikol_main(_argv(args, files)) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and f"antikol {args[0]}: error: " in err


@pytest.mark.parametrize(
    "argv",
    [
        ["replay", "x.csv", "--cycle", "0"],
        ["replay", "x.csv", "--cycle", "nan"],
        ["demo", "--trams", "0"],
    ],
)
def test_bad_options_are_usage_errors(argv):
    with pytest.raises(SystemExit) as exit_:
        antikol_main(argv)
    assert exit_.value.code == 2


def test_check_exit_status_1_is_for_findings_only(files, tmp_path, capsys):
    from tests._osm import OsmBuilder

    b = OsmBuilder()
    n = b.node(0, 100)
    b.line([(0, 0), n], oneway="yes")
    b.line([(0, 200), n], oneway="yes")
    out = tmp_path / "bad.trackmap.geojson"
    assert trackmap_main(["build", str(b.write_xml(tmp_path / "b.osm")), "-o", str(out)]) == 0
    assert trackmap_main(["check", str(out)]) == 1
    assert trackmap_main(["check", str(files["good"])]) == 0
    assert trackmap_main(["check", str(files["broken"])]) == 2


def test_an_internal_error_exits_3_with_a_hint_and_no_traceback(files, monkeypatch, capsys):
    import trackmap.cli

    def boom(args):
        raise TypeError("something we did not expect")

    monkeypatch.setitem(trackmap.cli._COMMANDS, "info", boom)
    assert trackmap_main(["info", str(files["good"])]) == 3
    err = capsys.readouterr().err
    assert "internal error: TypeError: something we did not expect" in err
    assert "Please report it" in err and "Traceback" not in err
    assert trackmap_main(["-vv", "info", str(files["good"])]) == 3
    assert "Traceback" in capsys.readouterr().err


def test_antikol_internal_error_exits_3(files, monkeypatch, capsys):
    import importlib

    replay_module = importlib.import_module("antikol.evaluation.replay")

    def boom(*args, **kwargs):
        raise KeyError("oops")

    monkeypatch.setattr(replay_module, "replay", boom)
    argv = ["replay", str(files["log"]), "-o", str(files["tmp"] / "e.csv")]
    assert antikol_main(argv) == 3
    err = capsys.readouterr().err
    assert "antikol replay: internal error: KeyError" in err and "Traceback" not in err


@pytest.mark.parametrize("program", ["antikol", "trackmap"])
def test_a_reader_that_leaves_early_ends_only_the_printing(files, program):
    """``antikol match LOG | head -1``: the reader's pipe closes while the command prints;
    the command still writes its files and ends with its own status, without a word of
    a broken pipe (before: status 2, 'error: [Errno 32] Broken pipe', no --json file)."""
    import subprocess
    import sys

    tmp = files["tmp"]
    if program == "antikol":
        rows = "".join(f"T{k % 3},{k // 3},50.06,{19.94 + 1e-5 * k},5,90\n" for k in range(300))
        files["log"].write_text("vehicle_id,t,lat,lon,speed_mps,course_deg\n" + rows)
        written = tmp / "checks.json"
        args = ["match", str(files["log"]), "-o", str(tmp / "p.csv"), "--json", str(written)]
    else:
        written = tmp / "built.trackmap.geojson"
        args = ["build", str(files["src"]), "-o", str(written)]
    code = (
        "import os, sys, time\n"
        "r, w = os.pipe()\n"
        "os.close(r)\n"  # the reader is gone before a line is printed
        "os.dup2(w, 1)\n"
        f"from {program}.cli import main\n"
        "sys.stdout = os.fdopen(1, 'w')\n"
        f"raise SystemExit(main({args!r}))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, done.stderr
    assert written.exists()
    assert "Broken pipe" not in done.stderr and "BrokenPipeError" not in done.stderr
