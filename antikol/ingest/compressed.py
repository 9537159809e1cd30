"""Recorded feeds as operators publish them: plain, or compressed with gzip, bzip2, xz or
Zstandard (zstd).

An operator's archive of a day of vehicle positions is large and is usually downloaded
compressed (``hfp-2023-12-14.csv.gz``, ``vehicle_positions.pb.xz``, HSL's raw HFP dumps
``VP.csv.zst``). The feed readers take such files as they are: the compression is
recognised by the file's first bytes (its magic number), not its name, and the name's
compression suffix is left out when the format is recognised by name (``.csv.gz`` is read
as ``.csv``). zstd needs the PEP 784 module: the standard library's ``compression.zstd``
from Python 3.14, else its backport ``backports.zstd`` (``pip install 'antikol[feeds]'``),
imported only when a file is zstd.

A compressed file cut short (an interrupted download) keeps what it holds: the records
before the cut are read, and the cut is reported as a problem of the file (see
:class:`Decoded`), never passed over in silence. Concatenated members (and xz's stream
padding between them) are one content, decompressed a bounded amount at a time, so a
stream read line by line holds little however much a few compressed bytes unpack to. A
header asking for more decoder memory than allowed (xz: 256 MiB, four times what xz -9
needs; zstd: a 128 MiB window, zstd -d's own limit) is a problem of the file too: a
crafted one would make the reader allocate gigabytes.

>>> import gzip, tempfile, os
>>> with tempfile.TemporaryDirectory() as d:
...     path = os.path.join(d, "feed.jsonl.gz")
...     with gzip.open(path, "wb") as fh:
...         _ = fh.write(b'{"VP": {}}\\n')
...     got = read_input(path)
...     (got.data, got.compression, got.problem, logical_suffix(path))
(b'{"VP": {}}\\n', 'gzip', None, '.jsonl')
"""

from __future__ import annotations

import bz2
import importlib
import io
import lzma
import os
import zlib
from pathlib import Path
from typing import Any, BinaryIO, Final, NamedTuple, cast

from antikol.errors import InputFileError, InvalidArgumentError

__all__ = [
    "COMPRESSION_SUFFIXES",
    "Decoded",
    "DecompressedStream",
    "compression_of",
    "logical_stem",
    "logical_suffix",
    "open_input",
    "read_head",
    "read_input",
    "stream_problem",
]

#: Name suffixes of compressed files, left out when a format is recognised by name.
COMPRESSION_SUFFIXES: Final = (".gz", ".bz2", ".xz", ".zst", ".zstd")
_MAGIC: Final = (
    (b"\x1f\x8b", "gzip"),
    (b"BZh", "bzip2"),
    (b"\xfd7zXZ\x00", "xz"),
    (b"\x28\xb5\x2f\xfd", "zstd"),
    # a zstd file may start with a skippable frame (magic 0x184D2A50 to 0x184D2A5F, little
    # endian): pzstd writes one before every frame
    *((bytes([0x50 + k]) + b"\x2a\x4d\x18", "zstd") for k in range(16)),
)
#: Compressed bytes fed at a time: a damaged stream loses at most what this holds.
_CHUNK: Final = 1 << 14
#: Content decompressed at most per call: a few bytes of bzip2 may hold gigabytes, and a
#: stream read a little at a time must not hold them all at once.
_MAX_OUT: Final = 1 << 16
#: Memory the xz decoder may take: xz -9's dictionary needs 65 MiB, a crafted header may ask
#: for 1.5 GiB (xz -d itself sets no limit; we would rather report the file).
_XZ_MEMLIMIT: Final = 256 << 20
#: The largest zstd window read, as a power of two: 128 MiB, zstd -d's own default limit
#: (libzstd's too, pinned here so a crafted frame header cannot make it allocate more).
_ZSTD_WINDOW_LOG_MAX: Final = 27


class Decoded(NamedTuple):
    """The bytes of an input file, decompressed.

    Attributes
    ----------
    data : bytes
        The content (all of it, or what came before a cut in the compressed stream).
    compression : str or None
        ``"gzip"``, ``"bzip2"``, ``"xz"``, ``"zstd"``, or None for a plain file.
    problem : str or None
        Why the content ends early (a compressed stream cut short or damaged).
    """

    data: bytes
    compression: str | None
    problem: str | None


def compression_of(head: bytes) -> str | None:
    """The compression a file's first bytes show (``"gzip"``, ``"bzip2"``, ``"xz"``,
    ``"zstd"``), or None."""
    return next((name for magic, name in _MAGIC if head.startswith(magic)), None)


def logical_suffix(path: str | os.PathLike[str]) -> str:
    """The suffix that names a file's format, in lower case: the last one, or the one
    before a compression suffix (``feed.CSV.gz`` -> ``.csv``)."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix in COMPRESSION_SUFFIXES:
        return Path(p.stem).suffix.lower()
    return suffix


def logical_stem(path: str | os.PathLike[str]) -> str:
    """A file's name without its format suffix and compression suffix (``t1.nmea.gz`` ->
    ``t1``)."""
    p = Path(path)
    if p.suffix.lower() in COMPRESSION_SUFFIXES:
        p = Path(p.stem)
    return p.stem


def _zstd_module(source: object, what: str) -> Any:
    """PEP 784's zstd: the standard library's (Python 3.14), else the backport's.

    Raises
    ------
    InputFileError
        Neither is installed (the message names ``source`` and what to install).
    """
    for name in ("compression.zstd", "backports.zstd"):
        try:
            return importlib.import_module(name)
        except ImportError:
            continue
    raise InputFileError(
        f"{source}: cannot read the {what}: it is compressed with zstd, which needs Python "
        "3.14 or the backports.zstd package: pip install 'antikol[feeds]'"
    )


class DecompressedStream(io.RawIOBase):
    """A compressed file read as its content, one or more concatenated members, as the
    format's own tool reads it (``gzip -dc``, ``xz -dc``...); a cut or damaged stream ends
    the content there and says why (:attr:`problem`).

    Between and after members, xz allows stream padding (NUL bytes, a multiple of 4) and
    zstd skippable frames (which libzstd's decoder reads as frames without content). NUL
    bytes after the last gzip member, to the end of the file, are ignored as ``gzip -d``
    ignores them (silently, exit status 0); NUL bytes followed by more data end the content
    there, with a problem, as ``gzip -d`` stops there too ("decompression OK, trailing
    garbage ignored", exit status 2) without reading the member after them.

    Raises
    ------
    InvalidArgumentError
        ``compression`` is none of those :func:`compression_of` names.
    InputFileError
        zstd, and neither ``compression.zstd`` nor ``backports.zstd`` can be imported.
    """

    def __init__(self, raw: BinaryIO, compression: str, *, what: str = "input") -> None:
        super().__init__()
        self._raw = raw
        if compression not in {name for _, name in _MAGIC}:
            raise InvalidArgumentError("compression", compression, "not a known compression")
        self.compression = compression
        self._zstd: Any = None  # the zstd module, for a zstd stream
        if compression == "zstd":
            self._zstd = _zstd_module(getattr(raw, "name", "input"), what)
        # what the decoders raise on a damaged stream (zstd's only once it is imported)
        self._errors = (EOFError, OSError, lzma.LZMAError, zlib.error, ValueError) + (
            (self._zstd.ZstdError,) if self._zstd is not None else ()
        )
        self._unpack = self._decompressor()
        self._out = b""
        self._done = False
        # the last call filled _MAX_OUT: more may come out without new input
        self._full = False
        self.size = 0
        #: Why the content ended early (None: it did not).
        self.problem: str | None = None

    def _decompressor(self) -> Any:
        """A decoder for one member, its memory capped (:data:`_XZ_MEMLIMIT`...)."""
        if self.compression == "gzip":
            return zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
        if self.compression == "bzip2":
            return bz2.BZ2Decompressor()
        if self.compression == "xz":
            return lzma.LZMADecompressor(memlimit=_XZ_MEMLIMIT)
        options = {self._zstd.DecompressionParameter.window_log_max: _ZSTD_WINDOW_LOG_MAX}
        return self._zstd.ZstdDecompressor(options=options)

    def readable(self) -> bool:
        return True

    def close(self) -> None:
        if not self.closed:
            self._raw.close()
        super().close()

    def _fill(self) -> None:
        """Decompress until there is output or the stream ends."""
        while not self._out and not self._done:
            unpack = self._unpack
            if unpack.eof:  # the next member of the file, or the end
                chunk = self._next_member(unpack.unused_data)
                if not chunk:
                    self._done = True
                    return
                unpack = self._unpack = self._decompressor()
            else:
                # zlib keeps the input it did not get to; bzip2, xz and zstd keep it inside
                chunk = getattr(unpack, "unconsumed_tail", b"")
                if not chunk and not self._full:
                    chunk = self._raw.read(_CHUNK)
                    if not chunk:
                        self._end(f"the {self.compression} stream ends early")
                        return
            try:
                self._out = unpack.decompress(chunk, _MAX_OUT)
            except self._errors as exc:
                # xz's "Memory usage limit exceeded", zstd's "Frame requires too much
                # memory": a header over the caps above, not necessarily a damaged file
                why = "needs more memory than allowed" if "memory" in str(exc).lower() else ""
                self._end(f"the {self.compression} stream {why or 'is damaged'} ({exc})")
            self._full = len(self._out) == _MAX_OUT

    def _next_member(self, data: bytes) -> bytes:
        """The first bytes of the member after one that ended (``data``: what followed it
        in the last chunk), or b"" at the end of the file or after bad padding."""
        padding = 0
        while True:
            if not data:
                data = self._raw.read(_CHUNK)
            if self.compression not in ("xz", "gzip") or not data:
                break
            # xz's stream padding, or NUL bytes after gzip: they may run across chunks
            rest = data.lstrip(b"\0")
            padding += len(data) - len(rest)
            data = rest
            if data:
                break
        if self.compression == "xz" and padding % 4:  # xz -d refuses it too
            self._end(f"the xz stream padding of {padding:,} bytes is not a multiple of 4")
            return b""
        if self.compression == "gzip" and padding and data:  # gzip -d stops there too
            self._end(f"{padding:,} NUL bytes and more data follow the gzip stream")
            return b""
        return data

    def _end(self, why: str) -> None:
        self._done = True
        self.problem = f"{why} after {self.size:,} bytes; what follows is lost"

    def readinto(self, buffer: Any) -> int:
        self._fill()
        n = min(len(buffer), len(self._out))
        buffer[:n] = self._out[:n]
        self._out = self._out[n:]
        self.size += n
        return n


def open_input(path: str | os.PathLike[str], *, what: str = "input") -> BinaryIO:
    """Open a file for reading its content: decompressed when its first bytes show gzip,
    bzip2, xz or zstd (a :class:`DecompressedStream`, whose ``problem`` tells a cut), else
    as it is.

    Raises
    ------
    InputFileError
        The file is missing or unreadable, or zstd without a zstd module to read it.
    """
    p = Path(path)
    try:
        raw = p.open("rb")
        compression = compression_of(raw.read(8))
        raw.seek(0)
    except OSError as exc:
        raise InputFileError(f"{p}: cannot read the {what}: {exc.strerror or exc}") from exc
    if compression is None:
        return raw
    try:
        stream = DecompressedStream(raw, compression, what=what)
    except InputFileError:
        raw.close()
        raise
    return cast(BinaryIO, io.BufferedReader(stream, _CHUNK))


def _decompressing(stream: BinaryIO) -> DecompressedStream | None:
    """The decompressor under a stream from :func:`open_input` (None: a plain file)."""
    raw = getattr(stream, "raw", None)
    return raw if isinstance(raw, DecompressedStream) else None


def stream_problem(stream: BinaryIO) -> str | None:
    """Why the content of a stream from :func:`open_input` ended early (None: it did not,
    or the file is not compressed)."""
    under = _decompressing(stream)
    return None if under is None else under.problem


def read_input(path: str | os.PathLike[str], *, what: str = "input") -> Decoded:
    """Read a file, decompressing it when its first bytes show gzip, bzip2, xz or zstd.

    Parameters
    ----------
    path : path-like
    what : str, keyword-only
        What the file is, for the error message (``"HFP log"``...).

    Returns
    -------
    Decoded

    Raises
    ------
    InputFileError
        The file is missing or unreadable, its compressed stream is damaged before
        anything could be read from it, or it is zstd without a zstd module to read it.
    """
    p = Path(path)
    with open_input(p, what=what) as stream:
        try:
            data = stream.read()
        except OSError as exc:
            raise InputFileError(f"{p}: cannot read the {what}: {exc.strerror or exc}") from exc
        under = _decompressing(stream)
        problem = None if under is None else under.problem
        compression = None if under is None else under.compression
    if problem is not None and not data:
        raise InputFileError(f"{p}: cannot read the {what}: {problem}")
    return Decoded(data, compression, problem)


def read_head(path: str | os.PathLike[str], size: int = 4096, *, what: str = "input") -> bytes:
    """The first ``size`` bytes of a file's content (decompressed; fewer when the content
    is shorter or its compressed stream ends or is damaged before).

    Raises
    ------
    InputFileError
        The file is missing or unreadable, or zstd without a zstd module to read it.
    """
    p = Path(path)
    with open_input(p, what=what) as stream:
        try:
            return stream.read(size)
        except OSError as exc:
            raise InputFileError(f"{p}: cannot read the {what}: {exc.strerror or exc}") from exc
