"""Fleet-scale replay: an operator's archive of months, partitioned and run on Dask.

Three stages (:mod:`.stages`): each archive file into a working copy; each vehicle-day
positioned alone; each time window of each map region analysed pairwise on the stored
positions, with a warm-up before the window and a margin around the region wide enough
that the result equals the single-process replay event for event (the module notes of
:mod:`.stages` say why). :func:`replay_archive` runs them on a ``dask.distributed``
cluster, :func:`replay_archive_local` in this process; both write events and positions
as partitioned Parquet and return a :class:`FleetSummary`.

Dask and pyarrow (``pip install 'antikol[fleet]'``) are imported only when a replay runs:
importing this package, like everything on board, needs neither.
"""

from antikol.evaluation.fleet.archive import find_partitions, read_partition, write_parquet_archive
from antikol.evaluation.fleet.positions import StoredPositions
from antikol.evaluation.fleet.run import replay_archive, replay_archive_local
from antikol.evaluation.fleet.stages import EVENT_FIELDS, FleetConfig
from antikol.evaluation.fleet.summary import (
    FleetSummary,
    HotSpot,
    PartitionFailure,
    hotspot_figure,
    hotspot_html,
)

__all__ = [
    "EVENT_FIELDS",
    "FleetConfig",
    "FleetSummary",
    "HotSpot",
    "PartitionFailure",
    "StoredPositions",
    "find_partitions",
    "hotspot_figure",
    "hotspot_html",
    "read_partition",
    "replay_archive",
    "replay_archive_local",
    "write_parquet_archive",
]
