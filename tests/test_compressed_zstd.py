"""Zstandard archives (HSL's raw HFP dumps are ``.csv.zst``), and the gzip and xz edge
cases gzip(1) and xz(1) read: NUL bytes after a gzip member, an xz header asking for more
memory than is sensible (antikol.ingest.compressed)."""

from __future__ import annotations

import gzip
import importlib
import lzma
import random
import shutil
import subprocess
import sys
from types import ModuleType

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from antikol.cli import main
from antikol.errors import InputFileError
from antikol.ingest import compressed as compressed_module
from antikol.ingest import detect_log_format
from antikol.ingest.compressed import (
    compression_of,
    logical_stem,
    logical_suffix,
    open_input,
    read_head,
    read_input,
    stream_problem,
)
from antikol.ingest.hfp import read_hfp
from tests._memory import traced_peak


def _zstd() -> ModuleType | None:
    for name in ("compression.zstd", "backports.zstd"):  # PEP 784: 3.14, or its backport
        try:
            return importlib.import_module(name)
        except ImportError:
            continue
    return None


ZSTD = _zstd()
needs_zstd = pytest.mark.skipif(ZSTD is None, reason="needs Python 3.14 or backports.zstd")
needs_zstd_tool = pytest.mark.skipif(shutil.which("zstd") is None, reason="no zstd tool")
needs_gzip_tool = pytest.mark.skipif(shutil.which("gzip") is None, reason="no gzip tool")


def _frame(data: bytes, *, checksum: bool = False, streamed: bool = False) -> bytes:
    """A zstd frame of ``data``; ``streamed``: without its content size in the header (as
    a compressor fed from a pipe writes it)."""
    assert ZSTD is not None
    options = {ZSTD.CompressionParameter.checksum_flag: int(checksum)}
    if not streamed:
        return ZSTD.compress(data, options=options)
    packer = ZSTD.ZstdCompressor(options=options)
    return packer.compress(data) + packer.flush()


def _skippable(nibble: int, data: bytes) -> bytes:
    """A zstd skippable frame: magic 0x184D2A5?, a 4-byte length, that many bytes."""
    return (0x184D2A50 + nibble).to_bytes(4, "little") + len(data).to_bytes(4, "little") + data


def _raw_frame(window_log: int, payload: bytes = b"T1,1\n") -> bytes:
    """A hand-made zstd frame declaring a ``2**window_log`` window, its content size
    unknown, holding ``payload`` in one raw block (what a crafted header looks like)."""
    header = bytes([0x00, (window_log - 10) << 3])  # no content size; window exponent
    block = ((len(payload) << 3) | 1).to_bytes(3, "little")  # last block, raw
    return b"\x28\xb5\x2f\xfd" + header + block + payload


_FRAMES = st.lists(
    st.one_of(
        st.tuples(st.just("frame"), st.binary(max_size=1500), st.booleans(), st.booleans()),
        st.tuples(st.just("skip"), st.binary(max_size=40), st.integers(0, 15), st.just(False)),
    ),
    min_size=1,
    max_size=4,
)


def _packed(frames: list[tuple[str, bytes, object, bool]]) -> tuple[bytes, list[int], list[bytes]]:
    """The file of ``frames``, where each frame ends in it, and each frame's content."""
    blobs, contents = [], []
    for kind, data, flag, streamed in frames:
        if kind == "frame":
            blobs.append(_frame(data, checksum=bool(flag), streamed=streamed))
            contents.append(data)
        else:
            blobs.append(_skippable(int(flag), data))
            contents.append(b"")
    ends = [sum(map(len, blobs[: k + 1])) for k in range(len(blobs))]
    return b"".join(blobs), ends, contents


@needs_zstd
@settings(max_examples=80, deadline=None)
@given(frames=_FRAMES, cut=st.floats(min_value=0.0, max_value=1.0))
def test_zstd_frames_and_skippable_frames_are_one_content_and_a_cut_keeps_a_prefix(
    tmp_path_factory, frames, cut
):
    path = tmp_path_factory.mktemp("z") / "log.csv.zst"
    blob, ends, contents = _packed(frames)
    whole = b"".join(contents)
    path.write_bytes(blob)
    assert read_input(path) == (whole, "zstd", None)
    assert read_head(path, 100) == whole[:100]
    keep = int(cut * (len(blob) - 1))  # at least the last byte is cut
    path.write_bytes(blob[:keep])
    if compression_of(blob[:keep]) is None:  # cut inside the first magic number
        assert read_input(path) == (blob[:keep], None, None)
        return
    before = b"".join(c for c, end in zip(contents, ends, strict=True) if end <= keep)
    if keep in ends:  # cut between two frames: a shorter file, nothing shows the cut
        assert read_input(path) == (before, "zstd", None)
        return
    try:
        got = read_input(path)
    except InputFileError as exc:  # nothing could be read before the cut
        assert before == b"" and str(path) in str(exc) and "lost" in str(exc)
        return
    # every frame before the cut is read whole, and the cut is told
    assert got.data.startswith(before) and whole.startswith(got.data)
    assert got.compression == "zstd"
    assert got.problem is not None and "zstd stream ends early" in got.problem


@needs_zstd
@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    size=st.integers(200_000, 600_000),
    pieces=st.integers(1, 3),
    cut=st.floats(min_value=0.05, max_value=0.95),
)
def test_large_zstd_content_spanning_many_reads_streams_line_by_line(
    tmp_path_factory, seed, size, pieces, cut
):
    # more than the 16 KiB fed and the 64 KiB taken out at a time, over several frames
    rng = random.Random(seed)
    text = bytes(rng.choices(b"0123456789,.T\n", k=size))
    parts = [text[k * size // pieces : (k + 1) * size // pieces] for k in range(pieces)]
    blob = b"".join(_frame(p, checksum=True, streamed=k % 2 == 1) for k, p in enumerate(parts))
    path = tmp_path_factory.mktemp("big") / "hfp.csv.zst"
    path.write_bytes(blob)
    with open_input(path) as fh:
        assert b"".join(fh) == text and stream_problem(fh) is None
    path.write_bytes(blob[: int(cut * len(blob))])
    with open_input(path) as fh:
        got = b"".join(fh)
        problem = stream_problem(fh)
    assert text.startswith(got) and len(got) < len(text)
    assert problem is not None and "ends early" in problem


@needs_zstd
@needs_zstd_tool
def test_zstd_files_read_as_zstd_dc_reads_them(tmp_path):
    plain = tmp_path / "hfp.csv"
    plain.write_bytes(b"veh,oper,tst,lat,long\n" + b"412,40,2023-12-14T08:00:01Z,60.1,24.9\n" * 500)
    cli = tmp_path / "cli.csv.zst"  # the tool's own frame: checksum, content size
    subprocess.run(["zstd", "-q", "-19", str(plain), "-o", str(cli)], check=True)
    files = {"cli": cli.read_bytes()}
    if shutil.which("pzstd"):  # pzstd puts a skippable frame before every frame
        par = tmp_path / "par.csv.zst"
        subprocess.run(["pzstd", "-q", "-p", "2", str(plain), "-o", str(par)], check=True)
        files["pzstd"] = par.read_bytes()
        assert files["pzstd"][:4] == b"\x50\x2a\x4d\x18"
    files["mixed"] = (
        _skippable(0xA, b"seek table") + files["cli"] + _skippable(0, b"") + _frame(b"tail\n")
    ) + _skippable(15, b"x" * 20_000)  # a skippable frame longer than a read
    for name, blob in files.items():
        path = tmp_path / f"{name}.zst"
        path.write_bytes(blob)
        want = subprocess.run(["zstd", "-dc", str(path)], capture_output=True, check=True)
        assert read_input(path) == (want.stdout, "zstd", None), name


def test_zstd_is_recognised_by_its_magic_and_its_suffix_left_out():
    assert compression_of(b"\x28\xb5\x2f\xfd\x04\x58") == "zstd"
    for nibble in (0, 7, 15):  # a file may start with a skippable frame (pzstd's do)
        assert compression_of(_skippable(nibble, b"")) == "zstd"
    assert compression_of(b"\x28\xb5\x2f") is None and compression_of(b"P*M\x17") is None
    assert logical_suffix("hfp/2024-03-01/VP.csv.zst") == ".csv"
    assert logical_suffix("vp.pb.ZSTD") == ".pb"
    assert logical_stem("t1.nmea.zst") == "t1"
    assert ".zst" in compressed_module.COMPRESSION_SUFFIXES


def test_zstd_without_a_zstd_module_is_an_input_error_saying_what_to_install(tmp_path, monkeypatch):
    path = tmp_path / "hfp.csv.zst"
    path.write_bytes(_raw_frame(17, b"veh,tst,lat\n"))  # a frame made without any module
    gz = tmp_path / "hfp.csv.gz"
    gz.write_bytes(gzip.compress(b"veh,tst,lat\n"))
    for name in ("compression.zstd", "backports.zstd"):
        monkeypatch.setitem(sys.modules, name, None)  # importing it fails
    for read in (read_input, read_head, open_input, read_hfp, detect_log_format):
        with pytest.raises(InputFileError) as info:
            read(path)
        message = str(info.value)
        assert str(path) in message and "zstd" in message and "antikol[feeds]" in message
        assert not isinstance(info.value, ImportError)
    assert read_input(gz).data == b"veh,tst,lat\n"  # the other formats need no module


@needs_zstd
@pytest.mark.parametrize("window_log", [28, 31])
def test_a_zstd_frame_needing_a_larger_window_than_allowed_is_a_problem(tmp_path, window_log):
    path = tmp_path / "log.csv.zst"
    # the largest window allowed (128 MiB, zstd -d's default limit too) is read
    path.write_bytes(_raw_frame(27))
    assert read_input(path) == (b"T1,1\n", "zstd", None)
    path.write_bytes(_frame(b"T1,0\n") + _raw_frame(window_log) + _frame(b"T1,2\n"))
    got = read_input(path)
    assert got.data == b"T1,0\n" and got.compression == "zstd"
    assert got.problem is not None and "memory" in got.problem and "lost" in got.problem
    path.write_bytes(_raw_frame(window_log))  # alone: nothing read, the file's error
    with pytest.raises(InputFileError, match=r"log\.csv\.zst.*memory"):
        read_input(path)
    with open_input(path) as fh:  # streamed: the problem, not an exception out of read
        assert fh.read() == b"" and "memory" in (stream_problem(fh) or "")


@needs_zstd
def test_a_real_zstd_stream_with_a_256_mib_window_is_refused(tmp_path):
    assert ZSTD is not None
    packer = ZSTD.ZstdCompressor(options={ZSTD.CompressionParameter.window_log: 28})
    blob = packer.compress(b"T1,1\n" * 1000) + packer.flush()  # content size unknown
    path = tmp_path / "log.csv.zst"
    path.write_bytes(_frame(b"head\n") + blob)
    got = read_input(path)
    assert got.data == b"head\n" and got.problem is not None and "memory" in got.problem


@needs_zstd
def test_the_zstd_window_cap_is_the_one_given_to_the_decoder(tmp_path, monkeypatch):
    # libzstd refuses windows over 128 MiB by itself; the cap must hold if that changes
    monkeypatch.setattr(compressed_module, "_ZSTD_WINDOW_LOG_MAX", 20)
    path = tmp_path / "log.zst"
    path.write_bytes(_raw_frame(20) + _raw_frame(21))
    got = read_input(path)
    assert got.data == b"T1,1\n" and got.problem is not None and "memory" in got.problem


@needs_zstd
def test_damaged_zstd_keeps_what_came_before(tmp_path):
    path = tmp_path / "log.zst"
    good = _frame(b"T1,1\n" * 10, checksum=True)
    path.write_bytes(good + b"not a frame")  # zstd -dc: "unknown header"
    got = read_input(path)
    assert got == (b"T1,1\n" * 10, "zstd", got.problem)
    assert got.problem is not None and "zstd stream is damaged" in got.problem
    bad = good[:-1] + bytes([good[-1] ^ 0xFF])  # a wrong checksum
    path.write_bytes(good + bad)
    got = read_input(path)
    assert got.data.startswith(b"T1,1\n" * 10)
    assert got.problem is not None and "damaged" in got.problem


_HFP_CSV = (
    "veh,oper,tst,lat,long,spd,hdg\n"
    "412,22,2023-12-14T08:00:01.000Z,60.170,24.940,5.1,90\n"
    "412,22,2023-12-14T08:00:02.000Z,60.170,24.941,5.2,91\n"
    "413,22,2023-12-14T08:00:01.500Z,60.171,24.939,0.0,270\n"
)


@needs_zstd
def test_an_hsl_hfp_csv_zst_dump_is_read_and_replayed(tmp_path, capsys):
    plain = tmp_path / "VP.csv"
    plain.write_text(_HFP_CSV)
    packed = tmp_path / "VP.csv.zst"
    packed.write_bytes(_frame(_HFP_CSV.encode(), checksum=True))
    got = read_hfp(packed)
    assert got.reports == read_hfp(plain).reports and len(got.reports) == 3
    assert {r.vehicle_id for r in got.reports} == {"22/412", "22/413"}
    assert not got.problems
    assert detect_log_format(packed) == "hfp"
    events = tmp_path / "events.csv"
    assert main(["replay", str(packed), "-o", str(events), "--map", "none"]) == 0
    assert "(hfp)" in capsys.readouterr().out
    # cut: the rows before the cut (in the frame's whole blocks), the cut at record 0
    rows = [
        f"{400 + k % 7},22,2023-12-14T08:{k // 600 % 60:02d}:{k // 10 % 60:02d}.{k % 10}00Z,"
        f"{60.17 + k * 1e-5:.5f},{24.94 - k * 1e-5:.5f},{k % 13}.{k % 10},{k % 360}\n"
        for k in range(8000)
    ]
    blob = _frame(("veh,oper,tst,lat,long,spd,hdg\n" + "".join(rows)).encode())
    packed.write_bytes(blob[: len(blob) * 3 // 4])
    cut = read_hfp(packed)
    assert 0 < len(cut.reports) < len(rows)
    [at_cut] = [p for p in cut.problems if p.line == 0]
    assert "zstd stream ends early" in at_cut.reason
    assert len(cut.problems) <= 2  # and at most the row cut in half


# --- gzip: NUL bytes after a member --------------------------------------------------


def _gzip_tool(path) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(["gzip", "-dc", str(path)], capture_output=True)


@settings(max_examples=40, deadline=None)
@given(
    parts=st.lists(st.binary(max_size=500), min_size=1, max_size=3),
    pad=st.one_of(st.integers(1, 64), st.integers(16_000, 40_000)),
)
def test_nul_bytes_after_the_last_gzip_member_are_ignored(tmp_path_factory, parts, pad):
    path = tmp_path_factory.mktemp("g") / "log.csv.gz"
    path.write_bytes(b"".join(map(gzip.compress, parts)) + b"\0" * pad)
    assert read_input(path) == (b"".join(parts), "gzip", None)
    with open_input(path) as fh:
        assert fh.read() == b"".join(parts) and stream_problem(fh) is None


@needs_gzip_tool
@pytest.mark.parametrize("pad", [1, 3, 4, 20_000])
def test_gzip_nul_padding_is_read_as_gzip_d_reads_it(tmp_path, pad):
    path = tmp_path / "log.csv.gz"
    first, second = gzip.compress(b"T1,1\n"), gzip.compress(b"T1,2\n")
    # after the last member: gzip -d ignores it without a word (exit status 0)
    path.write_bytes(first + second + b"\0" * pad)
    tool = _gzip_tool(path)
    assert (tool.returncode, tool.stdout) == (0, b"T1,1\nT1,2\n")
    assert read_input(path) == (b"T1,1\nT1,2\n", "gzip", None)
    # between two members: gzip -d stops at the NUL bytes and warns "decompression OK,
    # trailing garbage ignored" (exit status 2): the member after them is not read
    path.write_bytes(first + b"\0" * pad + second)
    tool = _gzip_tool(path)
    assert (tool.returncode, tool.stdout) == (2, b"T1,1\n")
    assert b"trailing garbage ignored" in tool.stderr
    got = read_input(path)
    assert got.data == b"T1,1\n" and got.compression == "gzip"
    assert got.problem is not None and f"{pad:,} NUL bytes" in got.problem
    assert "lost" in got.problem


# --- xz: a header asking for a huge dictionary ---------------------------------------


def _xz(data: bytes, dict_size: int) -> bytes:
    # the hc3 match finder keeps the encoder's own memory small; the stream's header
    # declares the dictionary all the same, and the decoder would allocate it
    lzma2 = {"id": lzma.FILTER_LZMA2, "preset": 0, "mf": lzma.MF_HC3, "dict_size": dict_size}
    return lzma.compress(data, format=lzma.FORMAT_XZ, filters=[lzma2])


@pytest.fixture(scope="module")
def huge_dictionary() -> bytes:
    return _xz(b"T1,1\n" * 100, 1536 << 20)  # a 1.5 GiB dictionary for 500 bytes


def test_an_xz_stream_declaring_a_huge_dictionary_is_refused_not_allocated(
    tmp_path, huge_dictionary
):
    path = tmp_path / "log.csv.xz"
    path.write_bytes(lzma.compress(b"T0,0\n") + huge_dictionary)
    got, peak = traced_peak(lambda: read_input(path))
    assert got.data == b"T0,0\n" and got.compression == "xz"
    assert got.problem is not None and "memory" in got.problem and "lost" in got.problem
    assert peak < 64 << 20  # not the 1.5 GiB the header asks for
    path.write_bytes(huge_dictionary)
    with pytest.raises(InputFileError, match=r"log\.csv\.xz.*memory"):
        read_input(path)


def test_xz_streams_of_the_largest_presets_are_still_read(tmp_path):
    path = tmp_path / "log.csv.xz"
    path.write_bytes(_xz(b"T1,1\n" * 100, 64 << 20))  # xz -9's dictionary
    assert read_input(path) == (b"T1,1\n" * 100, "xz", None)
