"""Inputs of the on-board chain: everything is turned into :class:`~antikol.VehicleReport`.

* :mod:`antikol.ingest.nmea` — the own GPS receiver (NMEA 0183 through pynmeagps);
  :mod:`antikol.ingest.nmea_writer` writes such sentences (tests, simulator), and
  :mod:`antikol.ingest.nmea_spec` holds what reader and writer share;
* :mod:`antikol.ingest.protocol` — the radio frames of the other vehicles;
* :mod:`antikol.ingest.replaylog` — recorded logs in the project's one CSV format (its
  only reader and writer).
"""

from antikol.ingest.nmea import NmeaReader, NmeaStats, read_nmea_directory, read_nmea_file
from antikol.ingest.nmea_writer import format_gga, format_rmc, format_vtg
from antikol.ingest.protocol import (
    DecoderStats,
    EncodeError,
    FrameError,
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
    "REPLAY_COLUMNS",
    "REPLAY_OPTIONAL_COLUMNS",
    "DecoderStats",
    "EncodeError",
    "FrameError",
    "NmeaReader",
    "NmeaStats",
    "ReplayLog",
    "RowProblem",
    "StreamDecoder",
    "decode_frame",
    "encode_report",
    "format_gga",
    "format_rmc",
    "format_vtg",
    "read_nmea_directory",
    "read_nmea_file",
    "read_nmea_logs",
    "read_replay_csv",
    "write_replay_csv",
]
