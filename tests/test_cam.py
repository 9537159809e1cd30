"""Reports as ETSI C-ITS CAMs (antikol.ingest.cam): units, unavailable values, errors.

Every test but the missing-dependency one needs pycrate (the ``cits`` extra) and is skipped
without it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from antikol.errors import InvalidArgumentError, ProtocolError
from antikol.ingest import EncodeError, FrameError, decode_cam, encode_cam
from antikol.ingest.cam import ITS_EPOCH_UNIX_S, ITS_LEAP_SECONDS, STATION_TYPE_TRAM
from antikol.report import VehicleReport

ROOT = Path(__file__).resolve().parent.parent

try:
    from pycrate_asn1dir import ITS_CAM_2
except ImportError:
    ITS_CAM_2 = None

needs_pycrate = pytest.mark.skipif(ITS_CAM_2 is None, reason="pycrate (antikol[cits]) missing")

#: 2025-06-01T12:00:00Z as Unix time
T_2025 = 1_748_779_200.0


def _report(**changes: Any) -> VehicleReport:
    fields: dict[str, Any] = {
        "vehicle_id": "tram-7",
        "t": T_2025 + 0.25,
        "lat": 50.0630612,
        "lon": 19.9326049,
        "speed_mps": 8.34,
        "course_deg": 123.4,
        "length_m": 32.0,
    }
    fields.update(changes)
    return VehicleReport(**fields)


@pytest.fixture(scope="module")
def cam_pdu() -> Any:
    """pycrate's CAM PDU object, to look at encoded messages independently of decode_cam."""
    module = pytest.importorskip("pycrate_asn1dir.ITS_CAM_2")
    return module.CAM_PDU_Descriptions.CAM


def _pycrate_decode(cam_pdu: Any, data: bytes) -> dict[str, Any]:
    cam_pdu.from_uper(data)
    return cam_pdu.get_val()


def _patched(cam_pdu: Any, data: bytes, path: tuple[Any, ...], value: Any) -> bytes:
    """``data`` re-encoded by pycrate with the field at ``path`` set to ``value``."""
    message = _pycrate_decode(cam_pdu, data)
    node = message
    for key in path[:-1]:
        node = node[key][1] if isinstance(node[key], tuple) else node[key]
    node[path[-1]] = value
    cam_pdu.set_val(message)
    return cam_pdu.to_uper()


HIGH = ("cam", "camParameters", "highFrequencyContainer")
POSITION = ("cam", "camParameters", "basicContainer", "referencePosition")


@st.composite
def cam_reports(draw: st.DrawFn) -> VehicleReport:
    """Valid reports whose length fits the CAM (below its out-of-range code)."""
    return VehicleReport(
        vehicle_id="x",
        t=draw(st.floats(min_value=1.2e9, max_value=4.0e9)),
        lat=draw(st.floats(min_value=-90.0, max_value=90.0)),
        lon=draw(st.floats(min_value=-180.0, max_value=180.0)),
        speed_mps=draw(st.floats(min_value=0.0, max_value=100.0)),
        course_deg=draw(st.floats(min_value=0.0, max_value=360.0)),
        braking=draw(st.sampled_from(["none", "service", "emergency"])),
        length_m=draw(st.none() | st.floats(min_value=0.05, max_value=102.1)),
    )


@needs_pycrate
@given(
    cam_reports(),
    st.integers(min_value=0, max_value=2**32 - 1),
    st.floats(min_value=-32.0, max_value=32.0),
)
def test_round_trip_within_resolution(report, station_id, skew_s):
    data = encode_cam(report, station_id=station_id)
    back = decode_cam(data, t_reference=report.t + skew_s)
    assert back.vehicle_id == str(station_id)
    assert abs(back.t - report.t) <= 0.0005 + 1e-6
    assert abs(back.lat - report.lat) <= 0.5e-7 + 1e-12
    assert abs(back.lon - report.lon) <= 0.5e-7 + 1e-12
    assert abs(back.speed_mps - report.speed_mps) <= 0.005 + 1e-9
    course_error = abs(back.course_deg - report.course_deg) % 360.0
    assert min(course_error, 360.0 - course_error) <= 0.05 + 1e-9
    assert back.braking == report.braking
    if report.length_m is None:
        assert back.length_m is None
    else:
        assert back.length_m is not None
        assert abs(back.length_m - report.length_m) <= 0.05 + 1e-9


@needs_pycrate
def test_station_type_and_header_in_decoded_pdu(cam_pdu):
    message = _pycrate_decode(cam_pdu, encode_cam(_report(), station_id=4242))
    assert message["header"] == {"protocolVersion": 2, "messageID": 2, "stationID": 4242}
    basic = message["cam"]["camParameters"]["basicContainer"]
    assert basic["stationType"] == STATION_TYPE_TRAM == 11


@needs_pycrate
def test_wire_encoding_of_known_values(cam_pdu):
    # t = 1.5 s after the ITS epoch (no leap seconds): TimestampIts 1500 ms
    report = _report(t=1.5, lat=50.0630612, speed_mps=8.34, course_deg=123.4)
    data = encode_cam(report, station_id=0x01020304, epoch_unix_s=ITS_EPOCH_UNIX_S, leap_seconds=0)
    # UPER: protocolVersion and messageID are 8 bits each, stationID 32, then the 16-bit
    # generationDeltaTime: all whole bytes at the start of the message
    assert data[:8] == bytes([2, 2, 1, 2, 3, 4]) + (1500).to_bytes(2, "big")
    message = _pycrate_decode(cam_pdu, data)
    assert message["cam"]["generationDeltaTime"] == 1500
    assert message["cam"]["camParameters"]["basicContainer"]["referencePosition"]["latitude"] == (
        500630612
    )
    choice, high = message["cam"]["camParameters"]["highFrequencyContainer"]
    assert choice == "basicVehicleContainerHighFrequency"
    assert high["speed"]["speedValue"] == 834
    assert high["heading"]["headingValue"] == 1234
    assert high["vehicleLength"]["vehicleLengthValue"] == 320


@needs_pycrate
def test_generation_delta_time_is_timestamp_its_mod_65536(cam_pdu):
    # Unix time with the default 5 leap seconds: TimestampIts = (t - 2004 + 5 s) in ms
    expected = round((T_2025 + 0.25 - ITS_EPOCH_UNIX_S + ITS_LEAP_SECONDS) * 1000) % 65536
    message = _pycrate_decode(cam_pdu, encode_cam(_report(), station_id=1))
    assert message["cam"]["generationDeltaTime"] == expected


@needs_pycrate
def test_time_resolved_across_the_wrap():
    report = _report(t=T_2025 + 65.5)
    data = encode_cam(report, station_id=1)
    for reference in (report.t - 32.0, report.t, report.t + 32.0):
        assert decode_cam(data, t_reference=reference).t == pytest.approx(report.t, abs=1e-3)
    # a reference more than half a wrap away lands on a neighbouring period
    later = decode_cam(data, t_reference=report.t + 40.0).t
    assert later == pytest.approx(report.t + 65.536, abs=1e-3)


@needs_pycrate
def test_caller_epoch_for_relative_times():
    report = _report(t=12.345)
    epoch = T_2025
    data = encode_cam(report, station_id=1, epoch_unix_s=epoch)
    assert decode_cam(data, t_reference=10.0, epoch_unix_s=epoch).t == pytest.approx(12.345)
    with pytest.raises(EncodeError, match="epoch_unix_s") as info:
        encode_cam(report, station_id=1)  # t = 12 s of Unix time is before 2004
    assert info.value.field == "t"


@needs_pycrate
def test_missing_length_is_unavailable(cam_pdu):
    data = encode_cam(_report(length_m=None), station_id=1)
    _, high = _pycrate_decode(cam_pdu, data)["cam"]["camParameters"]["highFrequencyContainer"]
    assert high["vehicleLength"] == {
        "vehicleLengthValue": 1023,
        "vehicleLengthConfidenceIndication": "unavailable",
    }
    assert high["speed"]["speedConfidence"] == 127
    assert high["heading"]["headingConfidence"] == 127
    assert high["vehicleWidth"] == 62
    assert decode_cam(data, t_reference=T_2025).length_m is None


@needs_pycrate
def test_long_vehicle_clamped_to_out_of_range(cam_pdu):
    data = encode_cam(_report(length_m=150.0), station_id=1)
    _, high = _pycrate_decode(cam_pdu, data)["cam"]["camParameters"]["highFrequencyContainer"]
    assert high["vehicleLength"]["vehicleLengthValue"] == 1022
    assert decode_cam(data, t_reference=T_2025).length_m == pytest.approx(102.2)
    tiny = encode_cam(_report(length_m=0.01), station_id=1)
    assert decode_cam(tiny, t_reference=T_2025).length_m == pytest.approx(0.1)


@needs_pycrate
def test_width(cam_pdu):
    for width, code in ((2.4, 24), (9.0, 61)):
        data = encode_cam(_report(), station_id=1, width_m=width)
        _, high = _pycrate_decode(cam_pdu, data)["cam"]["camParameters"]["highFrequencyContainer"]
        assert high["vehicleWidth"] == code
    with pytest.raises(EncodeError, match="width_m"):
        encode_cam(_report(), station_id=1, width_m=-1.0)


@needs_pycrate
@pytest.mark.parametrize(
    ("path", "value", "field"),
    [
        ((*HIGH, "speed", "speedValue"), 16383, "speedValue"),
        ((*HIGH, "heading", "headingValue"), 3601, "headingValue"),
        ((*POSITION, "latitude"), 900000001, "latitude"),
        ((*POSITION, "longitude"), 1800000001, "longitude"),
    ],
)
def test_unavailable_speed_heading_or_position_is_refused(cam_pdu, path, value, field):
    data = _patched(cam_pdu, encode_cam(_report(), station_id=1), path, value)
    with pytest.raises(FrameError, match=field) as info:
        decode_cam(data, t_reference=T_2025)
    assert info.value.reason == "invalid_value"


@needs_pycrate
def test_speed_beyond_report_range_is_refused(cam_pdu):
    data = _patched(
        cam_pdu, encode_cam(_report(), station_id=1), (*HIGH, "speed", "speedValue"), 16000
    )
    with pytest.raises(FrameError, match="speed_mps") as info:
        decode_cam(data, t_reference=T_2025)
    assert info.value.reason == "invalid_value"


@needs_pycrate
def test_other_station_types_and_messages(cam_pdu):
    data = encode_cam(_report(), station_id=1)
    bus = _patched(cam_pdu, data, ("cam", "camParameters", "basicContainer", "stationType"), 6)
    with pytest.raises(FrameError, match="stationType") as info:
        decode_cam(bus, t_reference=T_2025)
    assert info.value.reason == "invalid_value"
    assert decode_cam(bus, t_reference=T_2025, require_tram=False).speed_mps == 8.34
    denm = _patched(cam_pdu, data, ("header", "messageID"), 1)
    with pytest.raises(FrameError, match="messageID") as info:
        decode_cam(denm, t_reference=T_2025)
    assert info.value.reason == "bad_version"
    v1 = _patched(cam_pdu, data, ("header", "protocolVersion"), 1)
    with pytest.raises(FrameError, match="protocolVersion"):
        decode_cam(v1, t_reference=T_2025)


@needs_pycrate
def test_vehicle_id_given_or_from_station_id():
    data = encode_cam(_report(), station_id=77)
    assert decode_cam(data, t_reference=T_2025).vehicle_id == "77"
    assert decode_cam(data, t_reference=T_2025, vehicle_id="tram-7").vehicle_id == "tram-7"


@needs_pycrate
def test_truncated_and_padded_messages():
    data = encode_cam(_report(), station_id=1)
    for end in range(len(data)):
        with pytest.raises(FrameError) as info:
            decode_cam(data[:end], t_reference=T_2025)
        assert info.value.reason in ("truncated", "bad_payload")
    with pytest.raises(FrameError, match="after the CAM") as info:
        decode_cam(data + b"\x00", t_reference=T_2025)
    assert info.value.reason == "bad_payload"


@needs_pycrate
@given(st.binary(max_size=80))
def test_garbage_raises_only_the_projects_error(data):
    try:
        report = decode_cam(data, t_reference=T_2025, require_tram=False)
    except FrameError:
        return
    assert isinstance(report, VehicleReport)


@needs_pycrate
@pytest.mark.parametrize("station_id", [-1, 2**32, True, 1.0, "1"])
def test_bad_station_id(station_id):
    with pytest.raises(EncodeError, match="station_id") as info:
        encode_cam(_report(), station_id=station_id)
    assert info.value.field == "station_id"
    assert isinstance(info.value, ProtocolError)


@needs_pycrate
def test_bad_time_arguments():
    data = encode_cam(_report(), station_id=1)
    with pytest.raises(InvalidArgumentError, match="t_reference"):
        decode_cam(data, t_reference=float("nan"))
    with pytest.raises(InvalidArgumentError, match="epoch_unix_s"):
        encode_cam(_report(), station_id=1, epoch_unix_s=float("inf"))
    with pytest.raises(InvalidArgumentError, match="leap_seconds"):
        decode_cam(data, t_reference=T_2025, leap_seconds=5.0)  # type: ignore[arg-type]


def test_missing_pycrate_names_the_extra():
    # a fresh interpreter in which pycrate cannot be imported
    script = textwrap.dedent(
        """
        import sys
        for name in ("pycrate_asn1dir", "pycrate_asn1rt", "pycrate_core"):
            sys.modules[name] = None
        import antikol.ingest
        from antikol import VehicleReport
        from trackmap.errors import MissingDependencyError
        report = VehicleReport("a", t=1.7e9, lat=50.0, lon=20.0, speed_mps=1.0, course_deg=0.0)
        for call in (
            lambda: antikol.ingest.encode_cam(report, station_id=1),
            lambda: antikol.ingest.decode_cam(b"\\x02\\x02", t_reference=1.7e9),
        ):
            try:
                call()
            except MissingDependencyError as exc:
                assert isinstance(exc, ImportError)
                print(exc)
            else:
                raise SystemExit("no MissingDependencyError")
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    assert len(lines) == 2
    assert all("antikol[cits]" in line for line in lines)


@needs_pycrate
@pytest.mark.parametrize(
    ("t_reference", "epoch_unix_s"),
    [
        (1e306, 0.0),
        (-1e306, 0.0),
        (1.7e308, 0.0),
        (0.0, 1e306),
        (1e308, 1e308),
        (10.0, 0.0),  # relative times without their epoch: before 2004
        (T_2025 + 1e9, T_2025 * 100),  # beyond TimestampIts
    ],
)
def test_reference_time_outside_timestamp_its_is_refused(t_reference, epoch_unix_s):
    """Found by a probe: a finite but huge t_reference or epoch_unix_s made the reference
    infinite in ms, and round() of it raised OverflowError."""
    data = encode_cam(_report(), station_id=1)
    with pytest.raises(InvalidArgumentError, match="t_reference") as info:
        decode_cam(data, t_reference=t_reference, epoch_unix_s=epoch_unix_s)
    assert "TimestampIts" in str(info.value) and info.value.name == "t_reference"


@needs_pycrate
def test_reference_times_at_the_ends_of_timestamp_its_decode():
    first = _report(t=float(ITS_EPOCH_UNIX_S - ITS_LEAP_SECONDS))  # TimestampIts 0
    data = encode_cam(first, station_id=1)
    for skew in (-32.0, 0.0, 32.0):
        back = decode_cam(data, t_reference=first.t + skew)
        assert back.t == pytest.approx(first.t, abs=1e-3)
