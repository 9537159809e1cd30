"""Where a vehicle's front and rear are, relative to its GPS antenna.

Gaps are measured between vehicle ends, never between antennas: two 30 m trams whose
antennas are 60 m apart are 30 m apart. A report states what it knows:

=====================  ===============================================================
report carries         ends placed
=====================  ===============================================================
length and offset      ``reported``: front ``antenna_offset_m`` ahead of the antenna,
                       rear ``length_m - antenna_offset_m`` behind it.
length only            ``assumed_offset``: the antenna at the profile's usual place
                       (``antenna_offset_fraction`` of the length from the front,
                       mid-vehicle for the shipped profiles); that assumption carries an
                       uncertainty of ``antenna_offset_sigma_fraction`` of the length,
                       which shortens every gap of the vehicle (``2 sigma`` with the
                       positions', see :class:`~antikol.analysis.analyser.AnalyserConfig`).
neither                ``assumed_length``: as above with the profile's
                       ``vehicle_length_m``.
=====================  ===============================================================

The paper's packet, GTFS-realtime and the operators' high-frequency feeds carry no antenna
offset, so the middle case is the common one. Every threat says which rule placed the ends
of both vehicles (:attr:`~antikol.analysis.assessment.Threat.ends`).

>>> from antikol import VehicleReport, load_profile
>>> from antikol.analysis.ends import vehicle_ends
>>> r = VehicleReport("T1", 0.0, 50.06, 19.94, 8.0, 90.0, length_m=30.0)
>>> vehicle_ends(r, load_profile("tram"))
VehicleEnds(front_m=15.0, rear_m=15.0, sigma_m=3.0, assumption='assumed_offset')
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from antikol.analysis.profiles import BrakingProfile
from antikol.report import VehicleReport

__all__ = ["EndsAssumption", "VehicleEnds", "vehicle_ends"]

EndsAssumption = Literal["reported", "assumed_offset", "assumed_length"]

#: Uncertainty of reported ends (antenna survey, coupler slack), m.
_REPORTED_SIGMA_M = 0.5


@dataclass(frozen=True, slots=True)
class VehicleEnds:
    """A vehicle's ends relative to its antenna, along its running direction.

    Attributes
    ----------
    front_m : float
        From the antenna forward to the front, m.
    rear_m : float
        From the antenna back to the rear, m.
    sigma_m : float
        One-sigma uncertainty of where the ends are, m.
    assumption : str
        ``reported``, ``assumed_offset`` or ``assumed_length`` (see the module).
    """

    front_m: float
    rear_m: float
    sigma_m: float
    assumption: EndsAssumption


def vehicle_ends(report: VehicleReport, profile: BrakingProfile) -> VehicleEnds:
    """Place a vehicle's ends by the rule of this module.

    Parameters
    ----------
    report : VehicleReport
        Its ``length_m`` and ``antenna_offset_m`` are used when given.
    profile : BrakingProfile
        Supplies the usual length and antenna position of this kind of vehicle.

    Returns
    -------
    VehicleEnds
    """
    if report.length_m is not None and report.antenna_offset_m is not None:
        return VehicleEnds(
            report.antenna_offset_m,
            report.length_m - report.antenna_offset_m,
            _REPORTED_SIGMA_M,
            "reported",
        )
    length = report.length_m if report.length_m is not None else profile.vehicle_length_m
    front = profile.antenna_offset_fraction * length
    return VehicleEnds(
        front,
        length - front,
        profile.antenna_offset_sigma_fraction * length,
        "assumed_offset" if report.length_m is not None else "assumed_length",
    )
