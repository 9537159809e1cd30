"""NMEA 0183 ingest: parsing, epochs, rejections, units, writer round trip, files."""

from __future__ import annotations

import io
import logging
import math
import re
from datetime import UTC, datetime
from functools import partial
from pathlib import Path

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from pynmeagps import VALCKSUM, VALMSGID, NMEAReader
from pynmeagps.nmeahelpers import calc_checksum

from antikol.errors import InputFileError, InvalidReportError, ProtocolError
from antikol.ingest.nmea import SKIP_REASONS, NmeaReader, read_nmea_directory, read_nmea_file
from antikol.ingest.nmea_fields import MAX_LINE_BYTES, log_lines
from antikol.ingest.nmea_spec import KNOT_MPS
from antikol.ingest.nmea_writer import format_gga, format_rmc, format_vtg
from antikol.report import VehicleReport
from tests._memory import traced_peak

# Textbook sentences with their original checksums.
CLASSIC_RMC = "$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W*6A"
CLASSIC_GGA = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47"
CLASSIC_VTG = "$GPVTG,054.7,T,034.4,M,005.5,N,010.2,K*48"
CLASSIC_T = datetime(1994, 3, 23, 12, 35, 19, tzinfo=UTC).timestamp()


def nmea(body: str) -> str:
    """A sentence with a correct checksum around ``body`` (``GPRMC,...``)."""
    return f"${body}*{calc_checksum(body)}"


def rmc(
    hhmmss: str,
    ddmmyy: str = "150324",
    *,
    talker: str = "GN",
    status: str = "A",
    lat: str = "5423.41200,N",
    lon: str = "01838.15400,E",
    knots: str = "10.000",
    course: str = "45.00",
    mode: str = "A",
) -> str:
    return nmea(f"{talker}RMC,{hhmmss},{status},{lat},{lon},{knots},{course},{ddmmyy},,,{mode},V")


def gga(
    hhmmss: str, *, talker: str = "GN", quality: str = "1", hdop: str = "0.90", lat: str = ""
) -> str:
    pos = lat or "5423.41200,N,01838.15400,E"
    return nmea(f"{talker}GGA,{hhmmss},{pos},{quality},10,{hdop},12.3,M,34.5,M,,")


def vtg(
    course: str = "45.00", knots: str = "10.000", kmh: str = "18.520", *, talker: str = "GN"
) -> str:
    return nmea(f"{talker}VTG,{course},T,,M,{knots},N,{kmh},K,A")


def read_all(lines: list[str | bytes], vehicle_id: str = "tram7") -> tuple[list, NmeaReader]:
    reader = NmeaReader(vehicle_id)
    reports = list(reader.feed(lines))
    reports += reader.flush()
    return reports, reader


def utc(*args: int) -> float:
    return datetime(*args, tzinfo=UTC).timestamp()


def course_error(a: float, b: float) -> float:
    d = abs(a - b) % 360.0
    return min(d, 360.0 - d)


# ---------------------------------------------------------------- real-looking streams
def test_classic_gp_epoch_values() -> None:
    reports, reader = read_all([CLASSIC_RMC, CLASSIC_VTG, CLASSIC_GGA])
    assert len(reports) == 1
    r = reports[0]
    assert r.vehicle_id == "tram7"
    assert r.t == CLASSIC_T
    assert r.lat == pytest.approx(48 + 7.038 / 60, abs=1e-9)
    assert r.lon == pytest.approx(11 + 31.000 / 60, abs=1e-9)
    assert r.speed_mps == pytest.approx(22.4 * 1852 / 3600, rel=1e-12)
    assert r.course_deg == pytest.approx(84.4)
    # First epoch: the reader has not yet seen GGA, so the report goes out on RMC.
    assert r.hdop is None
    assert reader.stats.accepted == 1
    assert reader.stats.skipped == {"unpaired": 2}


def test_ublox_order_rmc_vtg_gga_gn_talker() -> None:
    lines: list[str | bytes] = []
    for sec in range(5):
        hhmmss = f"1200{sec:02d}.00"
        lines += [
            rmc(hhmmss, knots=f"{sec}.000", course=f"{90 + sec}.00"),
            vtg(f"{90 + sec}.00", f"{sec}.000", f"{sec * 1.852:.3f}"),
            gga(hhmmss, quality="4", hdop=f"0.{sec + 5}"),
            nmea("GNGSA,A,3,10,12,15,,,,,,,,,,1.5,0.9,1.2,1"),
            nmea("GPGSV,1,1,03,10,45,120,40,12,30,200,38,15,10,300,30,1"),
            nmea("GNGLL,5423.41200,N,01838.15400,E," + hhmmss + ",A,A"),
        ]
    reader = NmeaReader("tram7")
    emitted_per_line = [len(reader.feed_line(line)) for line in lines]
    assert reader.flush() == []  # every epoch closed on its own GGA
    # Epoch 0 is emitted on its RMC (GGA not yet known), later epochs on their GGA.
    assert [i for i, n in enumerate(emitted_per_line) if n] == [0, 8, 14, 20, 26]
    assert reader.stats.accepted == 5
    assert reader.stats.skipped["unsupported"] == 15
    assert reader.stats.skipped["unpaired"] == 2  # VTG and GGA of epoch 0
    assert reader.stats.used + reader.stats.total_skipped == len(lines)


def test_order_gga_rmc_vtg_gp_talker_all_have_hdop() -> None:
    lines: list[str | bytes] = []
    for sec in range(3):
        hhmmss = f"0815{sec:02d}"
        lines += [gga(hhmmss, talker="GP", quality="2", hdop="1.20"), rmc(hhmmss, talker="GP")]
        lines.append(vtg(talker="GP"))
    reports, reader = read_all(lines)
    assert len(reports) == 3
    assert all(r.hdop == pytest.approx(1.2) and r.fix_quality == 2 for r in reports)
    assert [r.t for r in reports] == [utc(2024, 3, 15, 8, 15, s) for s in range(3)]
    assert reader.stats.skipped == {"unpaired": 3}  # each VTG came after its epoch closed


def test_glonass_rmc_only_stream_and_other_gnss_talkers() -> None:
    lines: list[str | bytes] = [
        rmc("100000", talker="GL"),
        rmc("100001", talker="GA"),
        rmc("100002", talker="GB"),
        rmc("100003", talker="BD"),
        rmc("100004", talker="II"),  # instrument talker, not a GNSS receiver
    ]
    reports, reader = read_all(lines)
    assert [r.t - utc(2024, 3, 15, 10, 0, 0) for r in reports] == [0.0, 1.0, 2.0, 3.0]
    assert reader.stats.skipped == {"unsupported": 1}


def test_gga_adds_hdop_and_fix_quality() -> None:
    lines: list[str | bytes] = [
        gga("120000", quality="5", hdop="2.35"),
        rmc("120000"),
        rmc("120001"),  # the reader now waits for this epoch's GGA
        gga("120001", quality="4", hdop="0.51"),
    ]
    reports, _ = read_all(lines)
    assert [(r.hdop, r.fix_quality) for r in reports] == [(2.35, 5), (0.51, 4)]


def test_gga_of_another_time_does_not_enrich() -> None:
    # The GGA belongs to the next second: it closes the RMC epoch instead of enriching it.
    reports, reader = read_all([gga("115959"), rmc("115959"), rmc("120000"), gga("120001")])
    assert [r.hdop for r in reports] == [pytest.approx(0.9), None]
    assert reader.stats.skipped == {"unpaired": 1}


def test_epoch_waits_for_gga_then_closes_at_flush_or_next_epoch() -> None:
    reader = NmeaReader("tram7")
    assert reader.feed_line(gga("120000")) == []
    assert len(reader.feed_line(rmc("120000"))) == 1
    # Epoch 2 has no GGA yet: held until another epoch starts or flush().
    assert reader.feed_line(rmc("120001")) == []
    closed = reader.feed_line(rmc("120002"))
    assert [r.t for r in closed] == [utc(2024, 3, 15, 12, 0, 1)]
    assert closed[0].hdop is None
    flushed = reader.flush()
    assert [r.t for r in flushed] == [utc(2024, 3, 15, 12, 0, 2)]
    assert reader.flush() == []


# ------------------------------------------------------------------------------ units
def test_knot_factor_is_exact() -> None:
    assert KNOT_MPS == 1852 / 3600
    reports, _ = read_all([rmc("120000", knots="1.000"), rmc("120001", knots="36.000")])
    assert reports[0].speed_mps == pytest.approx(0.5144444444444444, rel=1e-15)
    assert reports[1].speed_mps == pytest.approx(18.52, rel=1e-15)


def test_vtg_kmh_only_divides_by_3_6() -> None:
    lines: list[str | bytes] = [
        rmc("120000", knots="", course=""),
        vtg("180.00", knots="", kmh="36.000"),
    ]
    reports, _ = read_all(lines)
    assert len(reports) == 1
    assert reports[0].speed_mps == pytest.approx(10.0, rel=1e-15)
    assert reports[0].course_deg == pytest.approx(180.0)


def test_vtg_knots_preferred_over_kmh() -> None:
    reports, _ = read_all([rmc("120000", knots=""), vtg(knots="2.000", kmh="99.000")])
    assert reports[0].speed_mps == pytest.approx(2 * 1852 / 3600, rel=1e-15)


# ------------------------------------------------------------------------- VTG filling
def test_vtg_fills_missing_rmc_course_and_speed() -> None:
    lines: list[str | bytes] = [
        gga("120000"),
        rmc("120000", knots="", course=""),
        vtg("271.50", "20.000", "37.040"),
    ]
    reports, reader = read_all(lines)
    assert len(reports) == 1
    assert reports[0].course_deg == pytest.approx(271.5)
    assert reports[0].speed_mps == pytest.approx(20 * KNOT_MPS)
    assert reader.stats.used == 3


def test_rmc_values_win_over_vtg() -> None:
    lines: list[str | bytes] = [
        rmc("120000"),
        gga("120000"),
        rmc("120001", knots="4.000", course="10.00"),
        vtg("300.00", "8.000", "14.816"),  # joins the epoch, which waits for its GGA
        gga("120001"),
    ]
    reports, reader = read_all(lines)
    assert reader.stats.used == 4  # RMC of epoch 0, then RMC, VTG and GGA of epoch 1
    assert reader.stats.skipped == {"unpaired": 1}  # the late GGA of epoch 0
    assert reports[1].course_deg == pytest.approx(10.0)
    assert reports[1].speed_mps == pytest.approx(4 * KNOT_MPS)


# ----------------------------------------------------------------- hemispheres, midnight
@pytest.mark.parametrize(
    ("lat", "lon", "ns", "ew"),
    [(-33.8688, 151.2093, "S", "E"), (-34.6037, -58.3816, "S", "W"), (40.4168, -3.7038, "N", "W")],
)
def test_hemisphere_signs(lat: float, lon: float, ns: str, ew: str) -> None:
    report = VehicleReport("v", utc(2024, 1, 2, 3, 4, 5), lat, lon, 3.0, 200.0)
    sentence = format_rmc(report)
    fields = sentence.split(",")
    assert (fields[4], fields[6]) == (ns, ew)
    (back,), _ = read_all([sentence])
    assert back.lat == pytest.approx(lat, abs=1e-6)
    assert back.lon == pytest.approx(lon, abs=1e-6)


def test_hand_written_south_west() -> None:
    (r,), _ = read_all([rmc("120000", lat="3351.12800,S", lon="07037.80000,W")])
    assert r.lat == pytest.approx(-(33 + 51.128 / 60))
    assert r.lon == pytest.approx(-(70 + 37.8 / 60))


def test_date_rollover_at_midnight() -> None:
    lines: list[str | bytes] = [
        gga("235959.50"),
        rmc("235959.50", "311224"),
        gga("000000.50"),
        rmc("000000.50", "010125"),
    ]
    reports, reader = read_all(lines)
    assert [r.t for r in reports] == [
        utc(2024, 12, 31, 23, 59, 59) + 0.5,
        utc(2025, 1, 1, 0, 0, 0) + 0.5,
    ]
    assert reports[1].t - reports[0].t == pytest.approx(1.0)
    assert all(r.hdop is not None for r in reports)
    assert reader.stats.total_skipped == 0


# ---------------------------------------------------------------------- rejections
def test_void_rmc_skipped_and_counted() -> None:
    lines: list[str | bytes] = [
        rmc("120000", status="V", knots="", course="", mode="N"),
        nmea("GPRMC,,V,,,,,,,,,,N"),
        rmc("120002", mode="N"),  # status A but mode N (no fix)
        rmc("120003"),
    ]
    reports, reader = read_all(lines)
    assert [r.t for r in reports] == [utc(2024, 3, 15, 12, 0, 3)]
    assert reader.stats.skipped == {"void_fix": 3}


def test_gga_quality_zero_voids_the_whole_epoch() -> None:
    lines: list[str | bytes] = [
        gga("120000"),
        rmc("120000"),
        rmc("120001"),
        vtg(),
        gga("120001", quality="0", hdop="99.99"),
        nmea("GPGGA,,,,,,0,00,99.99,,,,,,"),
        gga("120002"),
        rmc("120002"),
    ]
    reports, reader = read_all(lines)
    assert [r.t for r in reports] == [utc(2024, 3, 15, 12, 0, s) for s in (0, 2)]
    # The void GGA, the epoch's RMC and VTG, and the time-less void GGA.
    assert reader.stats.skipped == {"void_fix": 4}


def test_vtg_mode_n_is_void() -> None:
    lines: list[str | bytes] = [
        rmc("120000"),
        vtg(),
        rmc("120001", knots="", course=""),
        nmea("GNVTG,,T,,M,,N,,K,N"),
    ]
    reports, reader = read_all(lines)
    assert len(reports) == 1
    assert reader.stats.skipped["void_fix"] == 1
    assert reader.stats.skipped["no_speed"] == 1


def test_bad_checksum_counted() -> None:
    good = rmc("120000")
    bad = good[:-2] + ("00" if good[-2:] != "00" else "01")
    reports, reader = read_all([bad, CLASSIC_RMC[:-2] + "6B"])
    assert reports == []
    assert reader.stats.skipped == {"checksum": 2}


def test_lowercase_checksum_accepted() -> None:
    reports, _ = read_all([CLASSIC_RMC[:-2] + "6a"])
    assert len(reports) == 1


def test_missing_checksum_and_truncation_are_garbled() -> None:
    lines: list[str | bytes] = [
        CLASSIC_RMC[:-3],  # no '*hh'
        CLASSIC_RMC[:40],
        CLASSIC_RMC + "junk",
        "$",
        "$$$",
    ]
    reports, reader = read_all(lines)
    assert reports == []
    assert reader.stats.skipped == {"garbled": 7}  # "$$$" holds three empty sentences


@pytest.mark.parametrize("cut", range(1, len(CLASSIC_RMC)))
def test_every_truncation_of_a_sentence_is_rejected(cut: int) -> None:
    reports, reader = read_all([CLASSIC_RMC[:cut]])
    assert reports == []
    assert reader.stats.total_skipped == 1
    assert set(reader.stats.skipped) <= {"garbled", "not_nmea", "checksum"}


def test_line_cut_before_its_dollar_is_not_nmea() -> None:
    reports, reader = read_all([CLASSIC_RMC[10:], "Booting receiver v1.2", ""])
    assert reports == []
    assert reader.stats.skipped == {"not_nmea": 2, "empty": 1}


def test_unsupported_sentences_counted() -> None:
    lines: list[str | bytes] = [
        nmea("GPGSA,A,3,04,05,,09,12,,,24,,,,,2.5,1.3,2.1"),
        nmea("GPGSV,2,1,08,01,40,083,46,02,17,308,41,12,07,344,39,14,22,228,45"),
        nmea("GPGLL,4916.45,N,12311.12,W,225444,A"),
        nmea("PUBX,00,081350.00,4717.113210,N,00833.915187,E,546.589,G3,2.1,2.0"),
        nmea("GPZDA,201530.00,04,07,2002,00,00"),
        nmea("IIRMC,120000,A,5423.41200,N,01838.15400,E,10.000,45.00,150324,,,A,V"),
    ]
    reports, reader = read_all(lines)
    assert reports == []
    assert reader.stats.skipped == {"unsupported": 6}


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        (rmc("120000", lat="9100.00000,N"), "invalid_value"),
        (rmc("120000", lon="18100.00000,E"), "invalid_value"),
        (rmc("120000", lat="5461.00000,N"), "invalid_value"),  # 61 minutes
        (rmc("120000", knots="nan"), "invalid_value"),
        (rmc("120000", knots="inf"), "invalid_value"),
        (rmc("120000", knots="-1.0"), "invalid_value"),
        (rmc("120000", knots="500.0"), "invalid_value"),  # 257 m/s
        (rmc("120000", course="nan"), "invalid_value"),
        (rmc("120000", course="361.00"), "invalid_value"),
        (rmc("120000", course="-5.00"), "invalid_value"),
        (rmc("120000", lat="5423.41200,X"), "garbled"),
        (rmc("120000", lat="54.2341200,N"), "garbled"),
        (rmc("120000", lat=",N"), "garbled"),
        (rmc("120000", knots="1_0"), "garbled"),
        (rmc("120000", knots="abc"), "garbled"),
        (rmc("120000", status="X"), "garbled"),
        (rmc("", "150324"), "no_time"),
        (rmc("120000", ""), "no_time"),
        (rmc("250000"), "no_time"),
        (rmc("120000", "320124"), "no_time"),
        (rmc("1200", "1503"), "no_time"),
        (nmea("GPRMC,120000,A,5423.412,N"), "garbled"),  # valid checksum, truncated fields
    ],
)
def test_rmc_rejections(line: str, reason: str) -> None:
    reports, reader = read_all([line])
    assert reports == []
    assert reader.stats.skipped == {reason: 1}


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        (gga("120000", hdop="nan"), "invalid_value"),
        (gga("120000", hdop="-1.0"), "invalid_value"),
        (gga("120000", quality="12"), "invalid_value"),
        (gga("120000", quality=""), "garbled"),
        (gga("", quality="1"), "no_time"),
        (nmea("GNVTG,45.00,X,,M,10.0,N,18.52,K,A"), "garbled"),
        (vtg(knots="nan"), "invalid_value"),
        (vtg(course="999"), "invalid_value"),
    ],
)
def test_gga_vtg_rejections(line: str, reason: str) -> None:
    reader = NmeaReader("tram7")
    reader.feed_line(rmc("115959"))  # a VTG needs an epoch in progress
    reader.feed_line(vtg())
    assert reader.stats.accepted == 1
    reader.feed_line(rmc("120000"))
    reader.feed_line(line)
    assert reader.stats.skipped[reason] == 1


def test_rejected_gga_leaves_report_without_hdop() -> None:
    reports, reader = read_all(
        [gga("115959"), rmc("115959"), rmc("120000"), gga("120000", quality="x")]
    )
    assert [r.hdop for r in reports] == [pytest.approx(0.9), None]
    assert reader.stats.skipped == {"garbled": 1}


def test_missing_course_while_stopped_carries_last_course() -> None:
    lines: list[str | bytes] = [
        rmc("120000", knots="2.000", course="123.40"),
        rmc("120001", knots="0.100", course=""),  # 0.05 m/s, receiver drops COG
        rmc("120002", knots="0.000", course=""),
    ]
    reports, reader = read_all(lines)
    assert [r.course_deg for r in reports] == pytest.approx([123.4, 123.4, 123.4])
    assert reader.stats.flagged == {"course_missing": 2}
    assert reader.stats.skipped == {}


def test_missing_course_while_stopped_without_history_is_zero() -> None:
    (r,), reader = read_all([rmc("120000", knots="0.000", course="")])
    assert r.course_deg == 0.0
    assert r.speed_mps == 0.0
    assert reader.stats.flagged == {"course_missing": 1}


def test_missing_course_while_moving_is_skipped() -> None:
    # 1 kn = 0.514 m/s is at or above the 0.5 m/s threshold.
    reports, reader = read_all([rmc("120000", knots="1.000", course="")])
    assert reports == []
    assert reader.stats.skipped == {"no_course": 1}


def test_stopped_speed_threshold_is_configurable() -> None:
    reader = NmeaReader("tram7", stopped_speed_mps=1.0)
    reports = reader.feed_line(rmc("120000", knots="1.000", course="")) + reader.flush()
    assert len(reports) == 1
    with pytest.raises(ValueError):
        NmeaReader("tram7", stopped_speed_mps=-1.0)


def test_missing_speed_is_skipped() -> None:
    reports, reader = read_all([rmc("120000", knots="", course="12.00")])
    assert reports == []
    assert reader.stats.skipped == {"no_speed": 1}


def test_duplicate_and_backwards_times() -> None:
    lines: list[str | bytes] = [
        rmc("120000", talker="GP"),
        rmc("120000", talker="GN"),  # same fix from a second talker
        rmc("120001"),
        rmc("115959"),
        rmc("120002"),
    ]
    reports, reader = read_all(lines)
    assert [r.t - utc(2024, 3, 15, 12, 0, 0) for r in reports] == [0.0, 1.0, 2.0]
    assert reader.stats.skipped == {"duplicate": 1, "time_backwards": 1}


def test_one_rmc_dated_a_year_ahead_costs_one_epoch_not_the_rest() -> None:
    lines: list[str | bytes] = [rmc("120000"), rmc("120001", "150325")]
    lines += [rmc(f"1200{s:02d}") for s in range(2, 10)]
    reports, reader = read_all(lines)
    base = utc(2024, 3, 15, 12, 0, 0)
    assert [r.t - base for r in reports] == [0.0, *range(2, 10)]
    assert reader.stats.skipped == {"time_jump": 1}
    assert "time_reset" not in reader.stats.flagged


def test_a_wrong_first_fix_is_outvoted_and_a_real_jump_adopted() -> None:
    # the very first fix is a year ahead: the genuine timeline is adopted at its second fix
    lines: list[str | bytes] = [rmc("120000", "150325"), rmc("120001"), rmc("120002")]
    reports, reader = read_all(lines)
    assert [r.t for r in reports] == [utc(2025, 3, 15, 12, 0, 0), utc(2024, 3, 15, 12, 0, 2)]
    assert reader.stats.flagged["time_reset"] == 1
    # after a 10-minute outage the first fix is held back, the second one adopted
    lines = [rmc("120000"), rmc("121000"), rmc("121001"), rmc("121002")]
    reports, reader = read_all(lines)
    assert [r.t - utc(2024, 3, 15, 12, 0, 0) for r in reports] == [0.0, 601.0, 602.0]
    assert reader.stats.skipped == {"time_jump": 1}


def test_late_and_early_date_change_at_midnight_keep_the_fix() -> None:
    late: list[str | bytes] = [rmc("235959", "311224"), rmc("000000", "311224")]
    late.append(rmc("000001", "010125"))
    reports, reader = read_all(late)
    assert [r.t for r in reports] == [utc(2024, 12, 31, 23, 59, 59) + k for k in range(3)]
    assert reader.stats.flagged["date_late"] == 1 and reader.stats.total_skipped == 0
    early: list[str | bytes] = [rmc("235958", "311224"), rmc("235959", "010125")]
    early.append(rmc("000000", "010125"))
    reports, reader = read_all(early)
    assert [r.t for r in reports] == [utc(2024, 12, 31, 23, 59, 58) + k for k in range(3)]
    assert reader.stats.flagged["date_early"] == 1 and reader.stats.total_skipped == 0


def test_leap_second_is_kept_between_its_neighbours() -> None:
    lines: list[str | bytes] = [
        gga("235959.50"),
        rmc("235959.50", "311216"),
        gga("235960.00"),
        rmc("235960.00", "311216"),
        gga("235960.50"),
        rmc("235960.50", "311216"),
        gga("000000.00"),
        rmc("000000.00", "010117"),
    ]
    reports, reader = read_all(lines)
    midnight = utc(2017, 1, 1, 0, 0, 0)
    assert [r.t - midnight for r in reports] == pytest.approx(
        [-0.5, -0.001, -0.0005, 0.0], abs=1e-6
    )
    assert all(r.hdop is not None for r in reports)  # GGA of the leap second paired
    assert reader.stats.flagged["leap_second"] == 2 and reader.stats.total_skipped == 0


def test_duplicate_sentence_within_open_epoch() -> None:
    lines: list[str | bytes] = [
        gga("120000"),
        rmc("120000", talker="GP", knots="", course=""),  # waits for a VTG
        gga("120000", talker="GL"),
        rmc("120000", talker="GN"),
        vtg(),
        gga("120001"),
        rmc("120001"),
    ]
    reports, reader = read_all(lines)
    assert len(reports) == 2
    assert reader.stats.skipped == {"duplicate": 2}
    assert reader.stats.used + reader.stats.total_skipped == len(lines)


# ------------------------------------------------------------------- line robustness
def test_crlf_bytes_leading_garbage_and_glued_sentences() -> None:
    lines: list[str | bytes] = [
        (CLASSIC_RMC + "\r\n").encode(),
        b"\xff\xfe\x00garbage" + rmc("123520", "230394").encode() + b"\r\n",
        rmc("123521", "230394") + rmc("123522", "230394") + "\n",
        "2024-03-15T12:00:00Z " + rmc("123523", "230394"),
    ]
    reports, reader = read_all(lines)
    assert [r.t - CLASSIC_T for r in reports] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert reader.stats.total_skipped == 0
    assert reader.stats.lines == 4


def test_invalid_utf8_inside_sentence_is_garbled() -> None:
    broken = CLASSIC_RMC.encode().replace(b"4807", b"48\xc3\x28")
    reports, reader = read_all([broken])
    assert reports == []
    assert reader.stats.skipped == {"garbled": 1}


line_texts = st.one_of(
    st.text(max_size=120),
    st.text(max_size=120).map(lambda s: "$" + s),
    st.text(alphabet="$*,.0123456789ABCDEFGNPRMVTSWX\r\n", max_size=120),
    st.builds(lambda a, b: a + CLASSIC_RMC[:b], st.text(max_size=10), st.integers(0, 60)),
)


@given(line_texts)
def test_arbitrary_text_never_raises_or_reports(line: str) -> None:
    assume(CLASSIC_RMC not in line)
    reports, reader = read_all([line])
    assert reports == []
    assert reader.stats.accepted == 0
    assert reader.stats.total_skipped >= 1


@given(st.binary(max_size=200))
def test_arbitrary_bytes_never_raise_or_report(data: bytes) -> None:
    reports, reader = read_all([data])
    assert reports == []
    assert reader.stats.total_skipped >= 1


@given(
    st.integers(0, len(CLASSIC_RMC) - 1),
    st.characters(codec="ascii") | st.characters(),
)
def test_single_character_mutation(position: int, char: str) -> None:
    mutated = CLASSIC_RMC[:position] + char + CLASSIC_RMC[position + 1 :]
    reports, reader = read_all([mutated])
    # Only an unchanged sentence, or a checksum digit written in lower case, stays valid.
    survivable = mutated == CLASSIC_RMC or (
        position >= len(CLASSIC_RMC) - 2 and mutated.upper() == CLASSIC_RMC
    )
    assert len(reports) == (1 if survivable else 0)
    assert reader.stats.accepted + reader.stats.total_skipped >= 1


@given(st.lists(st.one_of(line_texts, st.binary(max_size=80)), max_size=20))
def test_arbitrary_streams_keep_accounts(lines: list[str | bytes]) -> None:
    reports, reader = read_all([*lines, rmc("120000")])
    assert all(isinstance(r, VehicleReport) for r in reports)
    assert reader.stats.lines == len(lines) + 1
    # The trailing valid RMC is never lost to what came before it.
    assert reports and reports[-1].t == utc(2024, 3, 15, 12, 0, 0)


field_text = st.text(alphabet="0123456789.-+eEnaifNSEWAVTKMX_ ", max_size=12)


@given(
    st.sampled_from(["GPRMC", "GNGGA", "GLVTG", "GARMC", "BDGGA"]),
    st.lists(field_text, max_size=16),
)
def test_checksummed_sentences_with_arbitrary_fields_never_raise(
    header: str, fields: list[str]
) -> None:
    sentence = nmea(",".join([header, *fields]))
    reader = NmeaReader("tram7")
    reports = reader.feed_line(sentence) + reader.feed_line(rmc("120000")) + reader.flush()
    for r in reports:
        assert math.isfinite(r.t) and abs(r.lat) <= 90.0 and 0.0 <= r.speed_mps <= 100.0
    assert reader.stats.lines == 2
    assert reader.stats.used + reader.stats.total_skipped == 2


def test_constructor_validates_vehicle_fields() -> None:
    with pytest.raises(InvalidReportError) as err:
        NmeaReader("x" * 40)
    assert err.value.field == "vehicle_id"
    with pytest.raises(InvalidReportError) as err:
        NmeaReader("tram7", length_m=-3.0)
    assert err.value.field == "length_m"
    reader = NmeaReader("tram7", length_m=32.0, antenna_offset_m=5.0)
    (r,) = reader.feed_line(CLASSIC_RMC)
    assert (r.length_m, r.antenna_offset_m) == (32.0, 5.0)


def test_rejections_are_logged_at_debug(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.DEBUG, logger="antikol.ingest.nmea"):
        read_all([CLASSIC_RMC[:-2] + "00"])
    assert any(
        "checksum" in rec.getMessage() and rec.levelno == logging.DEBUG for rec in caplog.records
    )


def test_skip_reasons_are_documented() -> None:
    lines: list[str | bytes] = [
        "",
        "hello",
        "$GPRMC",
        CLASSIC_RMC[:-2] + "00",
        nmea("GPGSV,1,1,00"),
        rmc("120000", status="V"),
        rmc("", "150324"),
        rmc("120001", knots="nan"),
        rmc("120002", knots=""),
        rmc("120003", knots="5.0", course=""),
        vtg(course=""),
        rmc("120004"),
        vtg(),
        rmc("120004", talker="GP"),
        rmc("120003"),
        rmc("120004", "150325"),  # a year ahead
        "$" + "x" * MAX_LINE_BYTES,
    ]
    _, reader = read_all(lines)
    assert set(reader.stats.skipped) == set(SKIP_REASONS)
    assert reader.stats.used + reader.stats.total_skipped == len(lines)
    assert reader.stats.as_dict()["lines"] == len(lines)


# ------------------------------------------------------------------ writer round trip
reports_strategy = st.builds(
    VehicleReport,
    vehicle_id=st.just("tram7"),
    t=st.floats(0.0, 3.0e9),
    lat=st.floats(-90.0, 90.0),
    lon=st.floats(-180.0, 180.0),
    speed_mps=st.floats(0.0, 100.0),
    course_deg=st.floats(0.0, 360.0, exclude_max=True),
    hdop=st.floats(0.0, 99.99),
    fix_quality=st.integers(1, 9),
)


def assert_matches(back: VehicleReport, sent: VehicleReport) -> None:
    assert back.t == pytest.approx(sent.t, abs=0.005 + 1e-6)
    assert back.lat == pytest.approx(sent.lat, abs=1e-6)  # 0.00001' = 1.7e-7 degrees
    assert back.lon == pytest.approx(sent.lon, abs=1e-6)
    assert back.speed_mps == pytest.approx(sent.speed_mps, abs=0.0005 * KNOT_MPS + 1e-9)
    assert course_error(back.course_deg, sent.course_deg) <= 0.005 + 1e-9


@given(reports_strategy)
def test_rmc_round_trip(report: VehicleReport) -> None:
    (back,), reader = read_all([format_rmc(report)])
    assert_matches(back, report)
    assert back.vehicle_id == "tram7"
    assert reader.stats.used == 1


@given(reports_strategy, st.sampled_from(["GP", "GN", "GL"]))
def test_full_epoch_round_trip(report: VehicleReport, talker: str) -> None:
    lines: list[str | bytes] = [
        format_gga(report, talker=talker),
        format_rmc(report, talker=talker, include_speed=False, include_course=False),
        format_vtg(report, talker=talker),
    ]
    (back,), reader = read_all(lines)
    assert_matches(back, report)
    assert back.fix_quality == report.fix_quality
    assert back.hdop == pytest.approx(report.hdop, abs=0.005 + 1e-9)
    assert reader.stats.skipped == {}


@given(reports_strategy)
def test_vtg_kmh_round_trip(report: VehicleReport) -> None:
    lines: list[str | bytes] = [
        format_rmc(report, include_speed=False),
        format_vtg(report, units="kmh"),
    ]
    (back,), _ = read_all(lines)
    assert back.speed_mps == pytest.approx(report.speed_mps, abs=0.0005 / 3.6 + 1e-9)


@given(reports_strategy)
def test_written_sentences_are_valid_nmea(report: VehicleReport) -> None:
    for sentence in (format_rmc(report), format_gga(report), format_vtg(report)):
        assert "\r" not in sentence and "\n" not in sentence
        body, checksum = sentence[1:].split("*")
        assert checksum == calc_checksum(body)
        msg = NMEAReader.parse(sentence.encode(), validate=VALCKSUM | VALMSGID)
        assert msg is not None


@given(reports_strategy)
def test_written_coordinates_never_carry_sixty_minutes(report: VehicleReport) -> None:
    fields = format_rmc(report).split(",")
    assert float(fields[3][2:]) < 60.0 and float(fields[5][3:]) < 60.0


def test_writer_known_sentence() -> None:
    report = VehicleReport(
        "v", CLASSIC_T, 48 + 7.038 / 60, 11 + 31 / 60, 22.4 * KNOT_MPS, 84.4, fix_quality=1
    )
    sentence = format_rmc(report, talker="GP")
    assert sentence.startswith("$GPRMC,123519.00,A,4807.03800,N,01131.00000,E,22.4,84.4,230394,")
    assert format_gga(report, talker="GP", hdop=0.9, num_satellites=8).startswith(
        "$GPGGA,123519.00,4807.03800,N,01131.00000,E,1,8,0.9,"
    )
    assert format_vtg(report, talker="GP").startswith("$GPVTG,84.4,T,,M,22.4,N,41.485,K,A*")


def test_writer_void_and_empty_fields() -> None:
    report = VehicleReport("v", CLASSIC_T, 1.0, 2.0, 0.0, 0.0)
    reports, reader = read_all([format_rmc(report, void=True)])
    assert reports == []
    assert reader.stats.skipped == {"void_fix": 1}
    fields = format_rmc(report, include_speed=False, include_course=False).split(",")
    assert fields[7:9] == ["", ""]
    reports, reader = read_all([format_rmc(report), format_gga(report, fix_quality=0)])
    assert len(reports) == 1  # first epoch leaves on its RMC
    assert reader.stats.skipped == {"void_fix": 1}


def test_writer_rounds_minutes_without_sixty() -> None:
    report = VehicleReport("v", 0.0, 12.9999999999, -0.0000000001, 0.0, 359.999)
    fields = format_rmc(report).split(",")
    assert fields[3:7] == ["1300.00000", "N", "00000.00000", "E"]
    assert fields[8] == "360.0"
    (back,), _ = read_all([format_rmc(report)])
    assert back.course_deg == 0.0
    assert back.t == 0.0


def test_writer_errors() -> None:
    report = VehicleReport("v", 0.0, 1.0, 2.0, 0.0, 0.0)
    with pytest.raises(ProtocolError):
        format_rmc(report, talker="XX")
    with pytest.raises(ProtocolError):
        format_rmc(VehicleReport("v", 4.0e9, 1.0, 2.0, 0.0, 0.0))  # year 2096
    with pytest.raises(ProtocolError):
        format_gga(report, fix_quality=12)
    with pytest.raises(ProtocolError):
        format_vtg(report, units="mph")  # type: ignore[arg-type]


# ---------------------------------------------------------------------------- files
def write_log(path: Path, lines: list[str], newline: str = "\r\n") -> Path:
    path.write_bytes(newline.join(lines).encode() + newline.encode())
    return path


def test_read_nmea_file_defaults_vehicle_id_to_stem(tmp_path: Path) -> None:
    path = write_log(tmp_path / "tram_12.nmea", [gga("120000"), rmc("120000"), rmc("120001")])
    reports, stats = read_nmea_file(path)
    assert [r.vehicle_id for r in reports] == ["tram_12", "tram_12"]
    assert [r.hdop for r in reports] == [pytest.approx(0.9), None]  # last one closed by EOF
    assert stats.accepted == 2
    assert stats.lines == 3


def test_read_nmea_file_explicit_id_and_line_endings(tmp_path: Path) -> None:
    lines = [CLASSIC_RMC, "garbage", CLASSIC_GGA]
    for newline in ("\n", "\r\n", "\r"):
        path = write_log(tmp_path / "log.txt", lines, newline)
        reports, stats = read_nmea_file(str(path), vehicle_id="T1", length_m=30.0)
        assert [(r.vehicle_id, r.t, r.length_m) for r in reports] == [("T1", CLASSIC_T, 30.0)]
        assert stats.lines == 3
        assert stats.skipped == {"not_nmea": 1, "unpaired": 1}


def test_an_over_long_line_is_one_problem_and_never_held(tmp_path: Path) -> None:
    long = b"$GPRMC," + b"x" * (20 << 20)  # 20 MB; a sentence has at most 82 characters
    for newline in (b"\n", b"\r\n", b"\r"):
        path = tmp_path / "t1.nmea"
        head, tail = rmc("120000").encode(), rmc("120001").encode()
        path.write_bytes(newline.join([head, long, tail, long]))  # the last one unended
        (reports, stats), peak = traced_peak(partial(read_nmea_file, path))
        assert peak < 2 << 20, peak
        assert [r.t for r in reports] == [utc(2024, 3, 15, 12, 0, s) for s in (0, 1)]
        assert stats.lines == 4 and stats.skipped == {"too_long": 2}
    assert NmeaReader("t1").feed_line("$" + "x" * MAX_LINE_BYTES) == []


def test_a_cr_only_log_longer_than_a_line_is_read_line_by_line(tmp_path: Path) -> None:
    lines = [rmc(f"12{m:02d}{s:02d}") for m in range(60) for s in range(60)]
    path = write_log(tmp_path / "t1.nmea", lines, "\r")
    assert path.stat().st_size > 2 << 16  # several lines' and reads' worth
    reports, stats = read_nmea_file(path)
    assert len(reports) == len(lines) and stats.total_skipped == 0


@given(
    data=st.lists(st.sampled_from([b"ab", b"\r", b"\n", b"\r\n", b"x" * 7, b""]), max_size=40),
    limit=st.integers(1, 9),
    chunk=st.integers(1, 12),
)
def test_log_lines_split_at_any_line_end_and_cut_long_lines(
    data: list[bytes], limit: int, chunk: int
) -> None:
    blob = b"".join(data)
    want = re.split(rb"\r\n|\r|\n", blob)
    if want[-1] == b"":  # the end of the last line, or an empty file
        want.pop()
    got = list(log_lines(io.BufferedReader(io.BytesIO(blob), 1), limit, chunk_bytes=chunk))
    assert got == [line[: limit + 1] for line in want]


def test_read_nmea_file_missing_raises_input_file_error(tmp_path: Path) -> None:
    missing = tmp_path / "nope.nmea"
    with pytest.raises(InputFileError, match=r"nope\.nmea") as err:
        read_nmea_file(missing)
    assert isinstance(err.value, OSError)
    with pytest.raises(OSError):
        read_nmea_file(tmp_path, vehicle_id="x")  # a directory is not a readable file


def test_read_nmea_directory(tmp_path: Path) -> None:
    write_log(tmp_path / "a1.nmea", [rmc("120000"), rmc("120001")])
    write_log(tmp_path / "b2.LOG", [rmc("120000", talker="GP")])
    write_log(tmp_path / "c3.txt", ["nothing useful"])
    write_log(tmp_path / "notes.csv", [rmc("120000")])
    (tmp_path / "sub.nmea").mkdir()
    reports, stats = read_nmea_directory(tmp_path)
    assert list(reports) == ["a1", "b2", "c3"]
    assert [len(reports[k]) for k in reports] == [2, 1, 0]
    assert all(r.vehicle_id == "a1" for r in reports["a1"])
    assert stats["c3"].skipped == {"not_nmea": 1}


def test_read_nmea_directory_errors(tmp_path: Path) -> None:
    with pytest.raises(InputFileError):
        read_nmea_directory(tmp_path / "missing")
    file = write_log(tmp_path / "x.nmea", [CLASSIC_RMC])
    with pytest.raises(InputFileError):
        read_nmea_directory(file)
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.md").write_text("hi")
    with pytest.raises(InputFileError, match="no NMEA files"):
        read_nmea_directory(empty)
    write_log(tmp_path / "x.log", [CLASSIC_RMC])
    with pytest.raises(InputFileError, match="two files"):
        read_nmea_directory(tmp_path)


def test_simulated_log_round_trip(tmp_path: Path) -> None:
    t0 = utc(2024, 6, 1, 23, 59, 58)
    sent = [
        VehicleReport("sim", t0 + 0.2 * i, 54.35 + 1e-5 * i, 18.64 - 1e-5 * i, 0.3 * i, 300.0)
        for i in range(20)
    ]
    lines = []
    for r in sent:
        lines += [format_rmc(r), format_vtg(r), format_gga(r, hdop=0.7)]
    path = write_log(tmp_path / "sim.nmea", lines)
    back, stats = read_nmea_file(path)
    assert len(back) == len(sent)
    for b, s in zip(back, sent, strict=True):
        assert_matches(b, s)
    assert [b.hdop for b in back[1:]] == pytest.approx([0.7] * 19)
    assert stats.used + stats.total_skipped == stats.lines
    assert math.isclose(back[-1].t - back[0].t, 3.8, abs_tol=1e-6)
