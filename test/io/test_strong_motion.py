from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import SignalError
from modal_twin.io.strong_motion import read_smc, read_v2, read_zip

SAMPLES = np.array([-0.000102, 1.5, -17.433102, 0.25, 3.0, -2.0, 0.125, 9.5, 1.0, -1.0])


def _v2(unit: str = "cm/sec2", n: int = 10) -> str:
    vals = "".join(f"{v:10.6f}" for v in SAMPLES)
    body = "\n".join(vals[k : k + 80] for k in range(0, len(vals), 80))
    return (
        "Corrected accelerogram   58658-G0133-21116.07       Chan  4:  Long\n"
        "58658-G0133-21116.07                 Start time:  4/26/21, 17:09:54.0 UTC (GPS)\n"
        "Station No. 58658   37.691N, 122.099W    Granit  s/n  133 (18 Chns of 20 at Sta)\n"
        "Chan  4:  Long    (Sta Chn:  6)     Location: Bent 3: South Column, Grnd Level  \n"
        f" {n} points of accel data equally spaced at 0.005 sec, in {unit}. (8f10.6)\n"
        f"{body}\n"
        " 10 points of veloc data equally spaced at 0.005 sec, in cm/sec.  (8f10.7)\n"
    )


def _e10(v: float) -> str:
    """SMC sample field (E10.4 with a one-digit exponent, as in the NSMP files)."""
    m, e = f"{v:.4E}".split("E")
    return f"{m}E{int(e)}".rjust(10)


def _smc(kind: str = "2 CORRECTED ACCELEROGRAM", peak: str = "-1.74E+1") -> str:
    text = [kind, "*", "1103f", "     2018  01  04    1039 22 KM SE", "Moment Mag= 4.4",
            "station = CA:Berkeley;Great Western Sav  component= 351     ",
            f"epicentral dist =      2.0       pk acc = {peak}", "inst type=WHITN", "*", "*",
            "*"]
    ints = [-32768, 2018, 1, 4, 10, 39, 0, 164] + [-32768] * 7 + [2, 10] + [-32768] * 31
    reals = [1.7e38, 200.0] + [1.7e38] * 48
    il = ["".join(f"{v:10d}" for v in ints[k : k + 8]) for k in range(0, 48, 8)]
    rl = ["".join(f"{v:15.7E}" for v in reals[k : k + 5]) for k in range(0, 50, 5)]
    com = ["|<SCNL>1103.HN2.NP.BE", "|<loclbl=>Basement, east side<end>"]
    vals = "".join(_e10(v) for v in SAMPLES)
    data = [vals[k : k + 80] for k in range(0, len(vals), 80)]
    return "\n".join(text + il + rl + com + data) + "\n"


def test_v2_header_fields_and_si_data() -> None:
    c = read_v2(_v2(), "chan006.v2")
    assert (c.name, c.station, c.orientation) == ("58658.ch06", "58658", "Long")
    assert c.location == "Bent 3: South Column, Grnd Level"
    assert c.fs_hz == pytest.approx(200.0)
    assert c.start_utc.startswith("4/26/21, 17:09:54.0")
    assert c.unit_in_file == "cm/sec2"
    assert np.isnan(c.azimuth_deg)
    np.testing.assert_allclose(c.data, SAMPLES * 0.01)  # cm/s^2 -> m/s^2
    g = read_v2(_v2(unit="g"))
    np.testing.assert_allclose(g.data, SAMPLES * 9.80665)


def test_smc_header_fields_and_si_data() -> None:
    c = read_smc(_smc(), "x_a.smc")
    assert (c.name, c.orientation, c.azimuth_deg) == ("1103.HN2.NP.BE", "351", 351.0)
    assert c.location == "Basement, east side"
    assert c.station.startswith("CA:Berkeley")
    assert c.fs_hz == 200.0
    assert c.start_utc == "2018-01-04 10:39:00.164"
    np.testing.assert_allclose(c.data, SAMPLES * 0.01, rtol=1e-4)


def test_zip_reads_v2_and_acceleration_smc_only(tmp_path: Path) -> None:
    p = tmp_path / "rec.zip"
    with zipfile.ZipFile(p, "w") as z:
        z.writestr("chan006.V2", _v2())
        z.writestr("1103.HN2.NP.BE_a.smc", _smc())
        z.writestr("1103.HN2.NP.BE_v.smc", "not read")
    chs = read_zip(p)
    assert [c.name for c in chs] == ["1103.HN2.NP.BE", "58658.ch06"]
    empty = tmp_path / "empty.zip"
    with zipfile.ZipFile(empty, "w") as z:
        z.writestr("readme.txt", "x")
    with pytest.raises(SignalError, match=r"expected \.v2 or _a\.smc files"):
        read_zip(empty)


def test_bad_files() -> None:
    with pytest.raises(SignalError, match="expected an acceleration unit"):
        read_v2(_v2(unit="furlongs"))
    with pytest.raises(SignalError, match="expected 12 samples, found 10"):
        read_v2(_v2(n=12).split(" 10 points of veloc")[0])  # truncated file
    with pytest.raises(SignalError, match="expected a channel"):
        read_v2("no header at all")
    with pytest.raises(SignalError, match="expected a positive sample interval"):
        read_v2(_v2().replace("spaced at 0.005", "spaced at 0.000"))
    with pytest.raises(SignalError, match="malformed sample field"):
        read_v2(_v2().replace(" -0.000102", " -0.0x0102"))
    with pytest.raises(SignalError, match="CORRECTED ACCELEROGRAM"):
        read_smc(_smc(kind="1 UNCORRECTED ACCELEROGRAM"))
    with pytest.raises(SignalError, match="pk acc"):
        read_smc(_smc(peak="-1.74E+3"))  # data not in the unit the header implies
    bad_fs = _smc().replace(f"{200.0:15.7E}", f"{0.0:15.7E}")
    with pytest.raises(SignalError, match="sample rate in"):
        read_smc(bad_fs)


def _ch(name: str, loc: str, orient: str, az: float, data: np.ndarray):
    from modal_twin.io.strong_motion import StrongMotionChannel

    return StrongMotionChannel(name, "1", loc, orient, az, 100.0, "", "cm/s^2", data)


def test_rotation_to_structure_frame_sign_and_pairs() -> None:
    from modal_twin.io.strong_motion import StructureFrame, default_frame, to_structure_frame

    rng = np.random.default_rng(0)
    ax_true, ay_true = rng.standard_normal(50), rng.standard_normal(50)
    # structure x at azimuth 171, y at 81; a sensor at azimuth a reads
    # cos(a - 171) a_x - sin(a - 171) a_y
    def reading(az: float) -> np.ndarray:
        th = np.radians(az - 171.0)
        return np.cos(th) * ax_true - np.sin(th) * ay_true

    chans = (
        _ch("R.x", "roof", "351", 351.0, reading(351.0)),  # -x
        _ch("R.y", "roof", "81", 81.0, reading(81.0)),  # +y
        _ch("B.1", "basement", "200", 200.0, reading(200.0)),  # a pair off the axes
        _ch("B.2", "basement", "290", 290.0, reading(290.0)),
        _ch("S.1", "stair", "216", 216.0, reading(216.0)),  # a single one off the axes
        _ch("Z", "roof", "UP", np.nan, ay_true * 0.0),
    )
    assert default_frame(chans).x_azimuth_deg in (171.0, 20.0, 36.0, 81.0, 110.0)
    out, dirs, fr = to_structure_frame(chans, StructureFrame(171.0))
    assert fr.x_azimuth_deg == 171.0
    assert dirs[:2] == ["x", "y"]
    np.testing.assert_allclose(out[0].data, ax_true, atol=1e-12)  # sign corrected
    np.testing.assert_allclose(out[1].data, ay_true, atol=1e-12)
    assert sorted(dirs[2:4]) == ["x", "y"]
    bx = out[2].data if dirs[2] == "x" else out[3].data
    np.testing.assert_allclose(bx, ax_true, atol=1e-10)  # the pair rotated
    assert dirs[4] == f"{np.cos(np.radians(45)):.4f},{-np.sin(np.radians(45)):.4f},0"
    np.testing.assert_array_equal(out[4].data, chans[4].data)
    assert dirs[5] == "z"


def test_v1_v3_and_filter_corners(tmp_path: Path) -> None:
    from modal_twin.io.strong_motion import read_record, read_v3

    v2 = _v2().replace("(8f10.6)\n", "(8f10.6)\n", 1)
    v2 = v2.replace(" 10 points of accel", "Accelerogram bandpass filtered with 3 dB pts at  "
                    "0.30 and 40.00 cyc/sec\n 10 points of accel", 1)
    v1 = ("Uncorrected accelerogram" + _v2()[len("Corrected accelerogram"):]).replace(
        "accel data", "data")
    v3 = ("Response and Fourier amplitude spectra (** periods,  .04 - 32.0 sec)   for\n"
          + _v2().split(" 10 points")[0])
    h = read_v3(v3, "chan006.v3")
    assert h["channel"] == "58658.ch06"
    assert h["periods_s"] == [0.04, 32.0]
    p = tmp_path / "rec.zip"
    with zipfile.ZipFile(p, "w") as z:
        z.writestr("chan006.v1", v1)
        z.writestr("chan006.v2", v2)
        z.writestr("chan006.v3", v3)
        z.writestr("chan007.v1", v1.replace("(Sta Chn:  6)", "(Sta Chn:  7)"))
    chans, spectra = read_record(p)
    assert [(c.name, c.volume) for c in chans] == [("58658.ch06", "V2"), ("58658.ch07", "V1")]
    assert chans[0].filter_hz == (0.30, 40.0)
    assert spectra["58658.ch06"]["file"] == "chan006.v3"
    q = tmp_path / "none.zip"
    with zipfile.ZipFile(q, "w") as z:
        z.writestr("readme.txt", "x")
    with pytest.raises(SignalError, match=r"expected V1 / V2 or _a\.smc"):
        read_record(q)


def test_start_lines_give_the_utc_start() -> None:
    from datetime import UTC, datetime

    from modal_twin.io.strong_motion import start_ns

    v2 = read_v2(_v2())
    want = datetime(2021, 4, 26, 17, 9, 54, tzinfo=UTC).timestamp()
    assert start_ns(v2.start_utc) == round(want * 1e9)
    smc = read_smc(_smc())  # integer header 2018 1 4 10 39 0 164
    want = datetime(2018, 1, 4, 10, 39, 0, 164_000, tzinfo=UTC).timestamp()
    assert start_ns(smc.start_utc) == round(want * 1e9)
    assert start_ns("") is None and start_ns("13/45/21, 10:00:00") is None
