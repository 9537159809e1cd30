"""Keys for authenticated radio frames: HMAC-SHA-256 fleet keys and Ed25519 vehicle keys.

A frame's CRC-32 protects against noise only; anyone can compute it. With a key, the sender
appends a tag over the whole frame (TLV 9 of :mod:`antikol.ingest.protocol`) and receivers
that hold the matching key reject every frame whose tag does not verify.

Two schemes, chosen per fleet:

``hmac-sha256`` (scheme 1)
    One secret *fleet key* shared by every unit (standard library :mod:`hmac`). Cheap
    (about 2 µs a frame) and enough against outsiders; but every unit can forge frames of
    every other, so a stolen unit compromises the fleet until the key is changed. Several
    keys may be loaded at once, selected by the key id in the frame (key rotation).
``ed25519`` (scheme 2)
    A private key per vehicle, and the public keys of the whole fleet on every unit
    (through the optional :mod:`cryptography` package: ``pip install antikol[onboard]``).
    A unit can only sign as itself: the verifier looks the key up by the frame's vehicle
    id. Verification costs about 100 µs a frame.

Key files are TOML. A fleet key file (the same file on every unit)::

    scheme = "hmac-sha256"
    send_key = 1                  # key id this unit signs with
    [keys]                        # key id = hex key, 16 bytes or more
    1 = "9f1c...e2"

A vehicle's Ed25519 key file (its own private key and every public key)::

    scheme = "ed25519"
    [private_key]
    vehicle_id = "T1"
    key = "4a6b...01"             # 32-byte raw private key, hex
    [public_keys]                 # vehicle id = 32-byte raw public key, hex
    T1 = "d75a...1a"
    T2 = "3d40...0c"

A file holding a secret (a fleet key or a private key) that other users can read is
loaded with a warning. :func:`generate_key_files` writes a consistent set of files.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import logging
import os
import secrets
import stat
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, Literal

from antikol.errors import AntikolError, InputFileError
from antikol.ingest.protocol import FrameSigner, FrameVerifier

__all__ = [
    "SCHEME_CODES",
    "AuthConfigError",
    "Ed25519Signer",
    "Ed25519Verifier",
    "HmacSigner",
    "HmacVerifier",
    "KeySet",
    "generate_key_files",
    "load_key_file",
]

logger = logging.getLogger(__name__)

Scheme = Literal["hmac-sha256", "ed25519"]
#: Scheme names and their codes in the frame (TLV 9).
SCHEME_CODES: Final[dict[str, int]] = {"hmac-sha256": 1, "ed25519": 2}
#: Shortest HMAC key accepted, bytes (128 bits).
MIN_HMAC_KEY_BYTES: Final = 16


class AuthConfigError(AntikolError, ValueError):
    """A key or key file is invalid (the message names the field and the file).

    Attributes
    ----------
    field : str
        The offending field (e.g. ``"keys.1"``).
    """

    def __init__(self, field: str, reason: str) -> None:
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


def _crypto() -> Any:
    try:
        from cryptography.hazmat.primitives.asymmetric import ed25519
    except ImportError as exc:  # pragma: no cover - depends on the installed extras
        raise AuthConfigError(
            "scheme", "ed25519 needs the 'cryptography' package (pip install antikol[onboard])"
        ) from exc
    return ed25519


# --------------------------------------------------------------------------- HMAC


@dataclass(frozen=True, slots=True, repr=False)
class HmacSigner:
    """Signs frames with HMAC-SHA-256 and a fleet key.

    Parameters
    ----------
    key : bytes
        The fleet key, at least 16 bytes.
    key_id : int
        Its id, sent in every frame, 0..65535.
    """

    key: bytes
    key_id: int = 1

    def __post_init__(self) -> None:
        _check_hmac_key(f"keys.{self.key_id}", self.key)
        if not 0 <= self.key_id <= 0xFFFF:
            raise AuthConfigError("send_key", f"key id {self.key_id} outside 0..65535")

    @property
    def scheme(self) -> int:
        """Scheme code 1 (``hmac-sha256``)."""
        return 1

    def sign(self, data: bytes) -> bytes:
        """HMAC-SHA-256 of ``data`` (32 bytes)."""
        return hmac.digest(self.key, data, hashlib.sha256)

    def __repr__(self) -> str:  # never print a key
        return f"HmacSigner(key_id={self.key_id})"


class HmacVerifier:
    """Verifies HMAC-SHA-256 frames against the loaded fleet keys.

    Parameters
    ----------
    keys : mapping of int to bytes
        Fleet keys by key id (at least 16 bytes each).

    Examples
    --------
    >>> from antikol.ingest.protocol import decode_frame, encode_report
    >>> from antikol.report import VehicleReport
    >>> key = bytes(range(32))
    >>> frame = encode_report(VehicleReport("T1", 0.0, 50.0, 19.9, 8.0, 90.0),
    ...                       signer=HmacSigner(key, 7))
    >>> decode_frame(frame, verifier=HmacVerifier({7: key})).vehicle_id
    'T1'
    >>> decode_frame(frame, verifier=HmacVerifier({7: bytes(32)}))
    Traceback (most recent call last):
    ...
    antikol.ingest.cobs.FrameError: bad_signature: hmac-sha256 key 7: bad_signature
    """

    def __init__(self, keys: Mapping[int, bytes]) -> None:
        if not keys:
            raise AuthConfigError("keys", "no fleet key")
        for key_id, key in keys.items():
            _check_hmac_key(f"keys.{key_id}", key)
        self._keys = dict(keys)

    def verify(
        self, vehicle_id: bytes, scheme: int, key_id: int, signed: bytes, tag: bytes
    ) -> str | None:
        """None when ``tag`` is the HMAC of ``signed`` under fleet key ``key_id``."""
        key = self._keys.get(key_id) if scheme == 1 else None
        if key is None:
            return "unknown_key"
        if hmac.compare_digest(hmac.digest(key, signed, hashlib.sha256), tag):
            return None
        return "bad_signature"


def _check_hmac_key(field: str, key: object) -> None:
    if not isinstance(key, bytes) or len(key) < MIN_HMAC_KEY_BYTES:
        raise AuthConfigError(field, f"an HMAC key needs at least {MIN_HMAC_KEY_BYTES} bytes")


# --------------------------------------------------------------------------- Ed25519


class Ed25519Signer:
    """Signs frames with the vehicle's own Ed25519 private key.

    Parameters
    ----------
    private_key : bytes
        The 32-byte raw private key.
    key_id : int
        Sent in every frame (0 by default; receivers look keys up by vehicle id).
    """

    def __init__(self, private_key: bytes, key_id: int = 0) -> None:
        ed25519 = _crypto()
        if not isinstance(private_key, bytes) or len(private_key) != 32:
            raise AuthConfigError("private_key.key", "an Ed25519 private key is 32 bytes")
        self._key = ed25519.Ed25519PrivateKey.from_private_bytes(private_key)
        self._key_id = int(key_id)

    @property
    def scheme(self) -> int:
        """Scheme code 2 (``ed25519``)."""
        return 2

    @property
    def key_id(self) -> int:
        """Key id sent in the frame."""
        return self._key_id

    def public_key(self) -> bytes:
        """The matching 32-byte raw public key."""
        from cryptography.hazmat.primitives import serialization

        raw: bytes = self._key.public_key().public_bytes(
            serialization.Encoding.Raw, serialization.PublicFormat.Raw
        )
        return raw

    def sign(self, data: bytes) -> bytes:
        """Ed25519 signature of ``data`` (64 bytes)."""
        sig: bytes = self._key.sign(data)
        return sig

    def __repr__(self) -> str:
        return f"Ed25519Signer(key_id={self._key_id})"


class Ed25519Verifier:
    """Verifies Ed25519 frames with the public key of the vehicle named in the frame.

    Parameters
    ----------
    public_keys : mapping of str to bytes
        32-byte raw public keys by vehicle id.
    """

    def __init__(self, public_keys: Mapping[str, bytes]) -> None:
        ed25519 = _crypto()
        if not public_keys:
            raise AuthConfigError("public_keys", "no public key")
        self._keys: dict[bytes, Any] = {}
        for vid, raw in public_keys.items():
            if not isinstance(raw, bytes) or len(raw) != 32:
                raise AuthConfigError(f"public_keys.{vid}", "an Ed25519 public key is 32 bytes")
            try:
                key = ed25519.Ed25519PublicKey.from_public_bytes(raw)
            except ValueError as exc:
                raise AuthConfigError(f"public_keys.{vid}", str(exc)) from None
            self._keys[vid.encode("utf-8")] = key
        from cryptography.exceptions import InvalidSignature

        self._invalid = InvalidSignature

    def verify(
        self, vehicle_id: bytes, scheme: int, key_id: int, signed: bytes, tag: bytes
    ) -> str | None:
        """None when ``tag`` is the sender's signature of ``signed``."""
        key = self._keys.get(vehicle_id) if scheme == 2 else None
        if key is None:
            return "unknown_key"
        try:
            key.verify(tag, signed)
        except self._invalid:
            return "bad_signature"
        return None


# --------------------------------------------------------------------------- key files


@dataclass(frozen=True, slots=True)
class KeySet:
    """What a key file gives a unit.

    Attributes
    ----------
    scheme : {"hmac-sha256", "ed25519"}
    signer : FrameSigner or None
        Signs this unit's frames (None: the file lets it verify only, e.g. a control room).
    verifier : FrameVerifier
        Checks received frames.
    owner : str or None
        The vehicle whose private key the file holds (Ed25519), else None.
    path : pathlib.Path or None
    """

    scheme: Scheme
    signer: FrameSigner | None
    verifier: FrameVerifier
    owner: str | None = None
    path: Path | None = None


def _hex(field: str, value: object) -> bytes:
    if not isinstance(value, str):
        raise AuthConfigError(field, "must be a hex string")
    try:
        return bytes.fromhex(value)
    except ValueError:
        raise AuthConfigError(field, "is not valid hex") from None


def load_key_file(path: str | os.PathLike[str]) -> KeySet:
    """Read a key file (format in the module docstring).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    KeySet

    Raises
    ------
    InputFileError
        The file is missing or unreadable.
    AuthConfigError
        The file is not valid TOML or a field is missing or invalid (the message names the
        file and the field); key ids are ASCII digits of 0..65535, each given once.
    """
    file = Path(path)
    try:
        text = file.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(f"cannot read key file {str(file)!r}: {exc}") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise AuthConfigError(str(file), f"not valid TOML: {exc}") from None
    except ValueError:  # int()'s refusal of more than 4300 digits, which tomllib lets out
        raise AuthConfigError(
            str(file), "not valid TOML: an integer with too many digits"
        ) from None
    except RecursionError:  # tomllib's parser recurses once per nested array or table
        raise AuthConfigError(str(file), "not valid TOML: values nested too deeply") from None
    try:
        return _key_set(file, data)
    except AuthConfigError as exc:
        if exc.field.startswith(f"{file}: "):
            raise
        # the signer and verifier classes check the keys but know no file
        raise AuthConfigError(f"{file}: {exc.field}", exc.reason) from None


def _key_set(file: Path, data: dict[str, Any]) -> KeySet:
    """The key set a parsed key file describes (``file`` only names it in errors)."""
    scheme = data.get("scheme")
    if scheme == "hmac-sha256":
        keys_raw = data.get("keys")
        if not isinstance(keys_raw, dict) or not keys_raw:
            raise AuthConfigError(f"{file}: keys", "missing or empty table of fleet keys")
        keys: dict[int, bytes] = {}
        for name, value in keys_raw.items():
            field = f"{file}: keys.{name if len(name) <= 20 else name[:17] + '...'}"
            # str.isdigit() also takes '²' and other scripts' digits, which int() refuses
            # or reads as ASCII ones; past its leading zeros an id of more than 5 digits is
            # beyond the frame's uint16 (and int() refuses more than 4300)
            digits = name.lstrip("0") or "0"
            if not (name.isascii() and name.isdigit()) or len(digits) > 5 or int(digits) > 0xFFFF:
                raise AuthConfigError(field, "key ids are integers 0..65535")
            key_id = int(digits)
            if key_id in keys:
                raise AuthConfigError(field, f"key id {key_id} is given twice")
            keys[key_id] = _hex(field, value)
        send = data.get("send_key", min(keys))
        if isinstance(send, bool) or not isinstance(send, int) or send not in keys:
            raise AuthConfigError(f"{file}: send_key", f"{send!r} is not a loaded key id")
        _warn_if_readable(file)
        return KeySet("hmac-sha256", HmacSigner(keys[send], send), HmacVerifier(keys), None, file)
    if scheme == "ed25519":
        pub_raw = data.get("public_keys")
        if not isinstance(pub_raw, dict) or not pub_raw:
            raise AuthConfigError(f"{file}: public_keys", "missing or empty table")
        public = {vid: _hex(f"{file}: public_keys.{vid}", v) for vid, v in pub_raw.items()}
        signer: Ed25519Signer | None = None
        owner: str | None = None
        own = data.get("private_key")
        if own is not None:
            if not isinstance(own, dict) or not isinstance(own.get("vehicle_id"), str):
                raise AuthConfigError(f"{file}: private_key", "needs vehicle_id and key")
            owner = own["vehicle_id"]
            signer = Ed25519Signer(_hex(f"{file}: private_key.key", own.get("key")))
            if public.get(owner) != signer.public_key():
                raise AuthConfigError(
                    f"{file}: public_keys.{owner}", "does not match the private key"
                )
            _warn_if_readable(file)
        return KeySet("ed25519", signer, Ed25519Verifier(public), owner, file)
    raise AuthConfigError(f"{file}: scheme", f"{scheme!r} is not 'hmac-sha256' or 'ed25519'")


def _warn_if_readable(file: Path) -> None:
    try:
        mode = file.stat().st_mode
    except OSError:  # pragma: no cover - it was just read
        return
    if mode & (stat.S_IRGRP | stat.S_IROTH):
        logger.warning("key file %s holds a secret and is readable by other users", file)


def _write_secret(path: Path, text: str) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.chmod(path, 0o600)


def generate_key_files(
    directory: str | os.PathLike[str], scheme: Scheme, vehicle_ids: Iterable[str]
) -> dict[str, Path]:
    """Write a fresh, consistent set of key files (mode 0600).

    Parameters
    ----------
    directory : str or path-like
        Created if missing.
    scheme : {"hmac-sha256", "ed25519"}
    vehicle_ids : iterable of str
        The fleet.

    Returns
    -------
    dict of str to pathlib.Path
        The key file of each vehicle. HMAC: every vehicle gets the same ``fleet.toml``.
        Ed25519: ``<id>.toml`` per vehicle, and ``public.toml`` (key ``""``), the public
        keys alone for a receiver that only listens (a control room).
    """
    folder = Path(directory)
    folder.mkdir(parents=True, exist_ok=True)
    ids = list(dict.fromkeys(vehicle_ids))
    if scheme == "hmac-sha256":
        path = folder / "fleet.toml"
        _write_secret(
            path,
            f'scheme = "hmac-sha256"\nsend_key = 1\n\n[keys]\n1 = "{secrets.token_hex(32)}"\n',
        )
        return dict.fromkeys(ids, path)
    if scheme != "ed25519":
        raise AuthConfigError("scheme", f"{scheme!r} is not 'hmac-sha256' or 'ed25519'")
    private = {vid: secrets.token_bytes(32) for vid in ids}
    public = {vid: Ed25519Signer(key).public_key() for vid, key in private.items()}
    table = "".join(f'{json.dumps(vid)} = "{key.hex()}"\n' for vid, key in public.items())
    out: dict[str, Path] = {}
    for vid in ids:
        path = folder / f"{vid}.toml"
        _write_secret(
            path,
            f'scheme = "ed25519"\n\n[private_key]\nvehicle_id = {json.dumps(vid)}\n'
            f'key = "{private[vid].hex()}"\n\n[public_keys]\n{table}',
        )
        out[vid] = path
    pub = folder / "public.toml"
    pub.write_text(f'scheme = "ed25519"\n\n[public_keys]\n{table}', encoding="utf-8")
    out[""] = pub
    return out
