"""What the NMEA 0183 reader and writer agree on: talkers, units and the time range.

Shared by :mod:`antikol.ingest.nmea` (the reader) and :mod:`antikol.ingest.nmea_writer`.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Final

__all__ = ["GNSS_TALKERS", "KMH_PER_MPS", "KNOT_MPS", "MAX_YEAR", "MIN_YEAR", "UNIX_EPOCH"]

#: One knot in m/s (exactly 1852 m per hour).
KNOT_MPS: Final = 1852.0 / 3600.0
#: km/h per m/s: a speed in km/h is divided by this to get m/s.
KMH_PER_MPS: Final = 3.6
#: Talker identifiers of satellite receivers accepted by the reader and the writer.
GNSS_TALKERS: Final = frozenset({"GP", "GN", "GL", "GA", "GB", "BD", "GQ", "GI"})
#: The years a two-digit NMEA year can express (the reader's and writer's window).
MIN_YEAR: Final = 1969
MAX_YEAR: Final = 2068
#: Time 0 of report times ``t`` (seconds since the Unix epoch, UTC).
UNIX_EPOCH: Final = datetime(1970, 1, 1, tzinfo=UTC)
