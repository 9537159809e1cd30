"""antikol: collision warning for trams and light rail.

Driver-assistance aid, not a certified safety function.
"""

from antikol.errors import (
    AntikolError,
    InputFileError,
    InvalidReportError,
    ProfileError,
    ProtocolError,
    ReplayError,
    UnknownVehicleError,
)
from antikol.report import BrakeState, ReportedTrackPosition, VehicleReport

__version__ = "0.1.0"

__all__ = [
    "AntikolError",
    "BrakeState",
    "InputFileError",
    "InvalidReportError",
    "ProfileError",
    "ProtocolError",
    "ReplayError",
    "ReportedTrackPosition",
    "UnknownVehicleError",
    "VehicleReport",
    "__version__",
]
