"""Inputs of the on-board chain: everything is turned into :class:`~antikol.VehicleReport`.

* :mod:`antikol.ingest.nmea` — the own GPS receiver (NMEA 0183 through pynmeagps);
  :mod:`antikol.ingest.nmea_writer` writes such sentences (tests, simulator), and
  :mod:`antikol.ingest.nmea_spec` holds what reader and writer share;
* :mod:`antikol.ingest.protocol` — the radio frames of the other vehicles (COBS framing in
  :mod:`antikol.ingest.cobs`), authenticated by :mod:`antikol.ingest.auth` (HMAC fleet key
  or Ed25519 per vehicle) and checked against replays by :mod:`antikol.ingest.guard`;
* :mod:`antikol.ingest.replaylog` — recorded logs in the project's one CSV format (its
  only reader and writer);
* operator feeds: :mod:`antikol.ingest.hfp` (HSL-style high-frequency positioning, JSON or
  CSV: :mod:`antikol.ingest.hfp_text` reads a file's forms, :mod:`antikol.ingest.hfp_messages`
  each message; :mod:`antikol.ingest.hfp_writer` writes its JSON lines) and
  :mod:`antikol.ingest.gtfsrt` (GTFS-realtime VehiclePositions, needs the ``feeds``
  extra), sharing :mod:`antikol.ingest.feed_common`;
* :mod:`antikol.ingest.feeds` — any recorded log, its format recognised; logs and feeds
  compressed with gzip, bzip2, xz or zstd are read as their content
  (:mod:`antikol.ingest.compressed`);
* :mod:`antikol.ingest.cam` — reports as ETSI C-ITS CAMs, for units that must speak C-ITS
  (needs the ``cits`` extra, imported on first use).
"""

from antikol.ingest.auth import (
    Ed25519Signer,
    Ed25519Verifier,
    HmacSigner,
    HmacVerifier,
    generate_key_files,
    load_key_file,
)
from antikol.ingest.cam import decode_cam, encode_cam
from antikol.ingest.feeds import LOG_FORMATS, detect_log_format, read_log
from antikol.ingest.gtfsrt import read_gtfs_realtime, write_feed_message
from antikol.ingest.guard import ReplayGuard
from antikol.ingest.hfp import read_hfp
from antikol.ingest.hfp_writer import write_hfp
from antikol.ingest.nmea import NmeaReader, NmeaStats, read_nmea_directory, read_nmea_file
from antikol.ingest.nmea_writer import format_gga, format_rmc, format_vtg
from antikol.ingest.protocol import (
    DecoderStats,
    EncodeError,
    FrameError,
    FrameSigner,
    FrameVerifier,
    StreamDecoder,
    decode_frame,
    encode_report,
)
from antikol.ingest.replaylog import (
    REPLAY_COLUMNS,
    REPLAY_OPTIONAL_COLUMNS,
    ReplayLog,
    RowProblem,
    read_nmea_logs,
    read_replay_csv,
    write_replay_csv,
)

__all__ = [
    "LOG_FORMATS",
    "REPLAY_COLUMNS",
    "REPLAY_OPTIONAL_COLUMNS",
    "DecoderStats",
    "Ed25519Signer",
    "Ed25519Verifier",
    "EncodeError",
    "FrameError",
    "FrameSigner",
    "FrameVerifier",
    "HmacSigner",
    "HmacVerifier",
    "NmeaReader",
    "NmeaStats",
    "ReplayGuard",
    "ReplayLog",
    "RowProblem",
    "StreamDecoder",
    "decode_cam",
    "decode_frame",
    "detect_log_format",
    "encode_cam",
    "encode_report",
    "format_gga",
    "format_rmc",
    "format_vtg",
    "generate_key_files",
    "load_key_file",
    "read_gtfs_realtime",
    "read_hfp",
    "read_log",
    "read_nmea_directory",
    "read_nmea_file",
    "read_nmea_logs",
    "read_replay_csv",
    "write_feed_message",
    "write_hfp",
    "write_replay_csv",
]
