"""Recorded feeds as operators publish them: plain, or compressed with gzip, bzip2 or xz.

An operator's archive of a day of vehicle positions is large and is usually downloaded
compressed (``hfp-2023-12-14.csv.gz``, ``vehicle_positions.pb.xz``). The feed readers take
such files as they are: the compression is recognised by the file's first bytes (its magic
number), not its name, and the name's compression suffix is left out when the format is
recognised by name (``.csv.gz`` is read as ``.csv``).

A compressed file cut short (an interrupted download) keeps what it holds: the records
before the cut are read, and the cut is reported as a problem of the file (see
:class:`Decoded`), never passed over in silence. Concatenated members (and xz's stream
padding between them) are one content, decompressed a bounded amount at a time, so a
stream read line by line holds little however much a few compressed bytes unpack to.

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
import io
import lzma
import os
import zlib
from pathlib import Path
from typing import Any, BinaryIO, Final, NamedTuple, cast

from antikol.errors import InputFileError

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
COMPRESSION_SUFFIXES: Final = (".gz", ".bz2", ".xz")
_MAGIC: Final = (
    (b"\x1f\x8b", "gzip"),
    (b"BZh", "bzip2"),
    (b"\xfd7zXZ\x00", "xz"),
)
#: Compressed bytes fed at a time: a damaged stream loses at most what this holds.
_CHUNK: Final = 1 << 14
#: Content decompressed at most per call: a few bytes of bzip2 may hold gigabytes, and a
#: stream read a little at a time must not hold them all at once.
_MAX_OUT: Final = 1 << 16


class Decoded(NamedTuple):
    """The bytes of an input file, decompressed.

    Attributes
    ----------
    data : bytes
        The content (all of it, or what came before a cut in the compressed stream).
    compression : str or None
        ``"gzip"``, ``"bzip2"``, ``"xz"``, or None for a plain file.
    problem : str or None
        Why the content ends early (a compressed stream cut short or damaged).
    """

    data: bytes
    compression: str | None
    problem: str | None


def compression_of(head: bytes) -> str | None:
    """The compression a file's first bytes show (``"gzip"``, ``"bzip2"``, ``"xz"``), or
    None."""
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


def _decompressor(compression: str) -> Any:
    if compression == "gzip":
        return zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
    if compression == "bzip2":
        return bz2.BZ2Decompressor()
    return lzma.LZMADecompressor()


class DecompressedStream(io.RawIOBase):
    """A compressed file read as its content, one or more concatenated members (xz streams
    also with the stream padding xz allows between and after them: NUL bytes, a multiple
    of 4); a cut or damaged stream ends the content there and says why (:attr:`problem`)."""

    def __init__(self, raw: BinaryIO, compression: str) -> None:
        super().__init__()
        self._raw = raw
        self.compression = compression
        self._unpack = _decompressor(compression)
        self._out = b""
        self._done = False
        # the last call filled _MAX_OUT: more may come out without new input
        self._full = False
        self.size = 0
        #: Why the content ended early (None: it did not).
        self.problem: str | None = None

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
                unpack = self._unpack = _decompressor(self.compression)
            else:
                # zlib keeps the input it did not get to; bzip2 and xz keep it inside
                chunk = getattr(unpack, "unconsumed_tail", b"")
                if not chunk and not self._full:
                    chunk = self._raw.read(_CHUNK)
                    if not chunk:
                        self._end(f"the {self.compression} stream ends early")
                        return
            try:
                self._out = unpack.decompress(chunk, _MAX_OUT)
            except (EOFError, OSError, lzma.LZMAError, zlib.error, ValueError) as exc:
                self._end(f"the {self.compression} stream is damaged ({exc})")
            self._full = len(self._out) == _MAX_OUT

    def _next_member(self, data: bytes) -> bytes:
        """The first bytes of the member after one that ended (``data``: what followed it
        in the last chunk), or b"" at the end of the file or after bad stream padding."""
        padding = 0
        while True:
            if not data:
                data = self._raw.read(_CHUNK)
            if self.compression != "xz" or not data:
                break
            # xz's stream padding: NUL bytes, which may run across chunks
            rest = data.lstrip(b"\0")
            padding += len(data) - len(rest)
            data = rest
            if data:
                break
        if padding % 4:  # xz -d refuses it too: the file is damaged there
            self._end(f"the xz stream padding of {padding:,} bytes is not a multiple of 4")
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
    bzip2 or xz (a :class:`DecompressedStream`, whose ``problem`` tells a cut), else as
    it is.

    Raises
    ------
    InputFileError
        The file is missing or unreadable.
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
    return cast(BinaryIO, io.BufferedReader(DecompressedStream(raw, compression), _CHUNK))


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
    """Read a file, decompressing it when its first bytes show gzip, bzip2 or xz.

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
        The file is missing or unreadable, or its compressed stream is damaged before
        anything could be read from it.
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
        The file is missing or unreadable.
    """
    p = Path(path)
    with open_input(p, what=what) as stream:
        try:
            return stream.read(size)
        except OSError as exc:
            raise InputFileError(f"{p}: cannot read the {what}: {exc.strerror or exc}") from exc
