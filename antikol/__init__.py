"""antikol: collision warning for trams and light rail.

Driver-assistance aid, not a certified safety function.

The on-board chain follows the data flow, one sub-package per stage:
:mod:`antikol.ingest` (NMEA, radio frames, replay logs) → :mod:`antikol.table` (the paper's
vehicle table) → :mod:`antikol.positioning` (track-selective positioning) →
:mod:`antikol.analysis` (sector rule, braking model, conflicts, the analyser). The
evaluation tools live in :mod:`antikol.sim` and :mod:`antikol.evaluation`.

>>> import antikol
>>> an = antikol.Analyser()                      # no map: the paper's sector rule
>>> for vid, lon in (("A", 19.9300), ("B", 19.9320)):
...     _ = an.update(antikol.VehicleReport(vid, t=0.0, lat=50.06, lon=lon,
...                                         speed_mps=8.0, course_deg=90.0))
>>> a = an.assess("A")
>>> a.level, a.threats[0].vehicle_id, a.threats[0].method
('warning', 'B', 'sector')
"""

from antikol import analysis, ingest, positioning, table
from antikol.analysis.analyser import Analyser, AnalyserConfig, Zone
from antikol.analysis.assessment import Assessment, Suppressed, Threat
from antikol.analysis.braking import BrakingProfile, load_profile
from antikol.analysis.sector import SectorRule
from antikol.errors import (
    AntikolError,
    InputFileError,
    InvalidReportError,
    ProfileError,
    ProtocolError,
    ReplayError,
    UnknownVehicleError,
)
from antikol.ingest.auth import (
    Ed25519Signer,
    Ed25519Verifier,
    HmacSigner,
    HmacVerifier,
    generate_key_files,
    load_key_file,
)
from antikol.ingest.guard import ReplayGuard
from antikol.ingest.nmea import NmeaReader
from antikol.ingest.protocol import (
    DecoderStats,
    EncodeError,
    FrameError,
    FrameSigner,
    FrameVerifier,
    StreamDecoder,
    encode_report,
)
from antikol.positioning.matcher import (
    DiscreteFix,
    FixPoint,
    Positioner,
    PositioningConfig,
    TrackPosition,
)
from antikol.report import BrakeState, ReportedTrackPosition, VehicleReport
from antikol.table import TableUpdate, VehicleTable

__version__ = "0.2.0"

__all__ = [
    "Analyser",
    "AnalyserConfig",
    "AntikolError",
    "Assessment",
    "BrakeState",
    "BrakingProfile",
    "DecoderStats",
    "DiscreteFix",
    "Ed25519Signer",
    "Ed25519Verifier",
    "EncodeError",
    "FixPoint",
    "FrameError",
    "FrameSigner",
    "FrameVerifier",
    "HmacSigner",
    "HmacVerifier",
    "InputFileError",
    "InvalidReportError",
    "NmeaReader",
    "Positioner",
    "PositioningConfig",
    "ProfileError",
    "ProtocolError",
    "ReplayError",
    "ReplayGuard",
    "ReportedTrackPosition",
    "SectorRule",
    "StreamDecoder",
    "Suppressed",
    "TableUpdate",
    "Threat",
    "TrackPosition",
    "UnknownVehicleError",
    "VehicleReport",
    "VehicleTable",
    "Zone",
    "__version__",
    "analysis",
    "encode_report",
    "generate_key_files",
    "ingest",
    "load_key_file",
    "load_profile",
    "positioning",
    "table",
]
