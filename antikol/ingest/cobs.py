"""Consistent Overhead Byte Stuffing (COBS), the radio protocol's framing layer.

COBS removes every ``0x00`` from a block of bytes at a cost of ``1 + n // 254`` bytes at most,
so that ``0x00`` can delimit frames (see :mod:`antikol.ingest.protocol`). :class:`FrameError`
is defined here, with the lowest layer that raises it.
"""

from __future__ import annotations

from antikol.errors import ProtocolError

__all__ = ["FrameError", "cobs_decode", "cobs_encode"]

_CODE_BYTES = tuple(bytes((i,)) for i in range(256))


class FrameError(ProtocolError):
    """A received frame was rejected.

    Parameters
    ----------
    reason : str
        One of :data:`REJECT_REASONS`.
    detail : str
        Human-readable explanation (offsets, field names, values).

    Attributes
    ----------
    reason : str
        The rejection reason, as counted by :class:`StreamDecoder`.
    detail : str
        The explanation.
    """

    def __init__(self, reason: str, detail: str) -> None:
        self.reason = reason
        self.detail = detail
        super().__init__(f"{reason}: {detail}")


def cobs_encode(data: bytes | bytearray | memoryview) -> bytes:
    """Encode bytes with Consistent Overhead Byte Stuffing.

    Parameters
    ----------
    data : bytes-like
        Any bytes, ``0x00`` included.

    Returns
    -------
    bytes
        The encoding: contains no ``0x00`` and is ``len(data) + 1`` to
        ``len(data) + 1 + len(data) // 254`` bytes long (``b"\\x01"`` for empty input).
    """
    segments = bytes(data).split(b"\x00")
    if max(map(len, segments)) < 254:  # common case: one block per zero-free segment
        return b"".join([_CODE_BYTES[len(seg) + 1] + seg for seg in segments])
    out = bytearray()
    last = len(segments) - 1
    for i, seg in enumerate(segments):
        n = len(seg)
        pos = 0
        while n - pos >= 254:  # a full block: code 0xFF, no implied zero after it
            out.append(0xFF)
            out += seg[pos : pos + 254]
            pos += 254
        # The block ending this segment (its code implies the zero that followed it);
        # omitted only after a final non-empty segment that ended on a full block.
        if i != last or pos < n or n == 0:
            out.append(n - pos + 1)
            out += seg[pos:]
    return bytes(out)


def cobs_decode(data: bytes | bytearray | memoryview) -> bytes:
    """Decode Consistent Overhead Byte Stuffing.

    Parameters
    ----------
    data : bytes-like
        One COBS-encoded block, without delimiters.

    Returns
    -------
    bytes
        The decoded bytes.

    Raises
    ------
    FrameError
        Reason ``"cobs"`` if ``data`` contains ``0x00``; reason ``"truncated"`` if a
        block runs past the end of ``data`` or ``data`` is empty.
    """
    data = bytes(data)
    if b"\x00" in data:
        raise FrameError("cobs", f"0x00 at offset {data.index(0)} inside a COBS block")
    n = len(data)
    if n == 0:
        raise FrameError("truncated", "empty COBS block")
    # Fast path: without 0xFF codes every code byte but the first decodes to 0x00.
    buf = bytearray(data)
    i = 0
    while i < n:
        code = buf[i]
        if code == 0xFF:
            return _cobs_decode_general(data)
        buf[i] = 0
        i += code
    if i > n:
        raise FrameError("truncated", f"last COBS block needs {i - n} more byte(s)")
    del buf[0]
    return bytes(buf)


def _cobs_decode_general(data: bytes) -> bytes:
    """Decode COBS ``data`` that is non-empty and free of ``0x00``."""
    n = len(data)
    out = bytearray()
    i = 0
    while i < n:
        code = data[i]
        end = i + code
        if end > n:
            raise FrameError("truncated", f"COBS block at offset {i} needs {end - n} more byte(s)")
        out += data[i + 1 : end]
        i = end
        if code != 0xFF and i < n:
            out.append(0)
    return bytes(out)
