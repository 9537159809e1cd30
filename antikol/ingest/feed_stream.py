"""An operator's feed archive replayed in bounded memory.

:func:`~antikol.ingest.hfp.read_hfp` and
:func:`~antikol.ingest.gtfsrt.read_gtfs_realtime` give every report of a log in a list:
about 300 B per vehicle position, gigabytes for a service day of a large fleet.
:class:`StreamedFeed` reads the file once into runs sorted by time
(:class:`~antikol.ingest.spill.SortedRuns`, on disk past ``run_size`` records), checks
every record in a first pass over the runs (every problem and count known before the
replay starts, as :func:`read_hfp` gives them) and turns the records into reports again
on each pass over :attr:`StreamedFeed.reports`, in the same order and with the same
values as the readers' lists.

>>> from antikol.ingest.hfp_writer import write_hfp
>>> from antikol.report import VehicleReport
>>> import tempfile, pathlib
>>> path = pathlib.Path(tempfile.mkdtemp()) / "vp.jsonl"
>>> _ = write_hfp(path, [VehicleReport("40/412", 1702540801.0 + k, 60.17, 24.94 + 1e-4 * k,
...                                    5.0, 90.0) for k in range(3)])
>>> with StreamedFeed(path, log_format="hfp") as feed:
...     feed.valid, [r.t - 1702540800.0 for r in feed.reports]
(3, [1.0, 2.0, 3.0])
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path

from antikol.errors import InvalidArgumentError
from antikol.ingest.feed_common import FeedCollector, FeedRecord, record_order, speed_unit_factor
from antikol.ingest.replaylog import RowProblem
from antikol.ingest.spill import DEFAULT_RUN_SIZE, SortedRuns
from antikol.report import VehicleReport

__all__ = ["STREAMED_FORMATS", "StreamedFeed"]

#: The log formats :class:`StreamedFeed` reads.
STREAMED_FORMATS = ("hfp", "gtfs-rt")


class StreamedFeed:
    """An HFP or GTFS-realtime log read once, its reports given in time order on each pass.

    Parameters
    ----------
    path : path-like
        The log (a GTFS-realtime recording may be a directory of feed files).
    log_format : {"hfp", "gtfs-rt"}, keyword-only
    strict : bool, keyword-only
        Raise :class:`~antikol.errors.ReplayError` at the first bad record (here, while
        reading).
    speed_unit : {"m/s", "km/h", "kn", "mph"}, keyword-only
        Unit of the speed field.
    modes : iterable of str, optional, keyword-only
        Transport modes of an HFP log to read (:func:`~antikol.ingest.hfp.read_hfp`).
    run_size : int, keyword-only
        Records sorted in memory at a time (:class:`~antikol.ingest.spill.SortedRuns`).

    Attributes
    ----------
    source : str
    problems : list of RowProblem
        Every bad record (dropped unless ``kept``), in file and line order.
    ignored : dict of str to int
        Valid records that are no report, by reason.
    valid : int
        Reports each pass gives.
    rows : None
        (Records are not counted line by line, as for :class:`ReplayLog`.)

    Raises
    ------
    InvalidArgumentError
        An unknown ``log_format``, ``speed_unit`` or ``run_size``, or bad ``modes``.
    InputFileError, ReplayError
        As the format's reader raises them.

    Notes
    -----
    Use it as a context manager (or call :meth:`close`): the sorted runs on disk are
    deleted when it closes.
    """

    rows: int | None = None

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        log_format: str,
        strict: bool = False,
        speed_unit: str = "m/s",
        modes: Iterable[str] | None = None,
        run_size: int = DEFAULT_RUN_SIZE,
    ) -> None:
        if log_format not in STREAMED_FORMATS:
            raise InvalidArgumentError("log_format", log_format, " or ".join(STREAMED_FORMATS))
        if modes is not None and log_format != "hfp":
            raise InvalidArgumentError("modes", modes, "only for an HFP log")
        self.source = str(Path(path))
        self._speed_factor = speed_unit_factor(speed_unit)
        first = FeedCollector(self.source, strict=strict, speed_factor=self._speed_factor)
        self._runs: SortedRuns[FeedRecord] = SortedRuns(
            _records(path, log_format, first, modes), key=record_order, run_size=run_size
        )
        try:
            self.valid = sum(first.take(rec) is not None for rec in self._runs)
        except BaseException:
            self._runs.close()
            raise
        log = first.log()
        self.problems: list[RowProblem] = log.problems
        self.ignored: dict[str, int] = log.ignored

    @property
    def reports(self) -> Iterator[VehicleReport]:
        """The reports in time order, then vehicle id (a new pass over the runs on each
        use; the problems were noted when the log was read)."""
        collector = FeedCollector(self.source, speed_factor=self._speed_factor)
        for rec in self._runs:
            report = collector.take(rec)
            if report is not None:
                yield report

    @property
    def rejected(self) -> int:
        """Records dropped because they were bad."""
        return sum(not p.kept for p in self.problems)

    def rejected_by_reason(self) -> dict[str, int]:
        """Dropped records per kind of problem (:attr:`RowProblem.category`)."""
        return dict(Counter(p.category for p in self.problems if not p.kept))

    @property
    def spilled(self) -> int:
        """Sorted runs written to temporary files (0: the log fitted in one run)."""
        return self._runs.spilled

    def close(self) -> None:
        """Delete the sorted runs."""
        self._runs.close()

    def __enter__(self) -> StreamedFeed:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _records(
    path: str | os.PathLike[str],
    log_format: str,
    collector: FeedCollector,
    modes: Iterable[str] | None,
) -> Iterator[FeedRecord]:
    if log_format == "hfp":
        from antikol.ingest.hfp import iter_hfp_records

        return iter_hfp_records(path, collector, modes=modes)
    from antikol.ingest.gtfsrt import gtfs_realtime_files, iter_gtfs_realtime_records

    return iter_gtfs_realtime_records(gtfs_realtime_files(path), collector)
