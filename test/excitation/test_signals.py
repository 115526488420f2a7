from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from modal_twin.errors import ConfigError, OptionError, SignalError
from modal_twin.excitation import signals
from modal_twin.excitation.drive import ExcitationConfig, make_drive


def test_band_limited_random_rms_and_band() -> None:
    rng = np.random.default_rng(0)
    x = signals.band_limited_random(3, 20.0, 200.0, f_min_hz=2.0, f_max_hz=20.0,
                                    rms=[1.0, 0.5, 2.0], rng=rng)
    assert x.shape == (3, 4000)
    np.testing.assert_allclose(x.std(axis=1), [1.0, 0.5, 2.0], rtol=1e-12)
    spec = np.abs(np.fft.rfft(x, axis=1)) ** 2
    f = np.fft.rfftfreq(4000, 1 / 200.0)
    out_band = spec[:, (f < 2.0) | (f > 20.0)].sum() / spec.sum()
    assert out_band < 1e-20  # nothing outside the band


def test_multisine_is_periodic_flat_and_chirp_sweeps() -> None:
    rng = np.random.default_rng(1)
    x = signals.multisine(10.0, 100.0, f_min_hz=1.0, f_max_hz=10.0, rms=1.0, rng=rng)[0]
    mag = np.abs(np.fft.rfft(x))
    f = np.fft.rfftfreq(x.size, 0.01)
    band = (f >= 1.0) & (f <= 10.0)
    assert np.ptp(mag[band]) < 1e-9 * mag[band].max()  # flat amplitude spectrum
    c = signals.chirp(10.0, 1000.0, f_min_hz=1.0, f_max_hz=50.0, amplitude=2.0)[0]
    assert np.max(np.abs(c)) == pytest.approx(2.0, rel=1e-3)
    # instantaneous frequency from zero crossings in the last second ~ 45-50 Hz
    last = c[-1000:]
    crossings = np.sum(np.diff(np.signbit(last)) != 0)
    assert 88 <= crossings <= 101


def test_impact_and_record_playback(tmp_path: Path) -> None:
    p = signals.impact(1.0, 1000.0, peak=100.0, width_s=0.004, at_s=0.1)
    assert p.max() == pytest.approx(100.0, rel=1e-3)
    assert np.count_nonzero(p > 1e-9 * 100.0) == 3  # interior of the 4 ms pulse at 1 kHz
    t = np.arange(500) / 50.0
    rec = np.vstack([np.sin(t), np.cos(t)])
    np.savez(tmp_path / "r.npz", data=rec, fs_hz=50.0, channels=["ax", "ay"])
    data, fs, names = signals.load_record(tmp_path / "r.npz")
    assert (fs, names) == (50.0, ["ax", "ay"])
    np.testing.assert_array_equal(data, rec)
    csv = tmp_path / "r.csv"
    csv.write_text("t,ax,ay\n" + "\n".join(f"{ti},{a},{b}" for ti, a, b in zip(t, *rec,
                                                                              strict=True)))
    _, fs2, names2 = signals.load_record(csv)
    assert fs2 == pytest.approx(50.0) and names2 == ["ax", "ay"]
    cfg = ExcitationConfig(kind="record", channels=("ax", "ay"), fs_hz=200.0,
                           record_path=str(tmp_path / "r.npz"), record_scale=2.0)
    drive = make_drive(cfg)
    assert drive.shape == (2, 2000)
    np.testing.assert_allclose(drive[:, ::4][:, 50:-50], 2 * rec[:, 50:-50], atol=2e-3)


def test_bad_excitation_input(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    with pytest.raises(OptionError, match="f_max_hz < fs_hz / 2"):
        signals.band_limited_random(1, 1.0, 100.0, f_min_hz=1.0, f_max_hz=60.0, rng=rng)
    with pytest.raises(ConfigError, match="no such file"):
        signals.load_record(tmp_path / "none.npz")
    np.savez(tmp_path / "nan.npz", data=np.array([[0.0, np.nan]]), fs_hz=10.0)
    with pytest.raises(SignalError, match="non-finite sample in channel ch0 at index 1"):
        signals.load_record(tmp_path / "nan.npz")
    (tmp_path / "x.txt").write_text("1")
    with pytest.raises(ConfigError, match="unknown format"):
        signals.load_record(tmp_path / "x.txt")
    with pytest.raises(OptionError, match="kind: expected one of"):
        ExcitationConfig(kind="sweep")
    with pytest.raises(OptionError, match="rms: expected 1 or 6 values"):
        ExcitationConfig(rms=(1.0, 2.0))


def test_earthquake_like_peak_envelope_and_band() -> None:
    rng = np.random.default_rng(5)
    x = signals.earthquake_like(40.0, 100.0, pga=3.0, rng=rng)[0]
    assert np.max(np.abs(x)) == pytest.approx(3.0)
    n = x.size
    rms = [np.sqrt(np.mean(x[i:i + n // 10] ** 2)) for i in range(0, n, n // 10)]
    assert rms[0] < 0.5 * max(rms[2:5])  # rise
    assert rms[-1] < 0.3 * max(rms[2:5])  # decay
    f = np.fft.rfftfreq(n, 0.01)
    p = np.abs(np.fft.rfft(x)) ** 2
    f_mean = np.sum(f * p) / np.sum(p)
    assert 1.0 < f_mean < 8.0  # soil-filtered around f_g = 2.5 Hz
    cfg = ExcitationConfig(kind="earthquake", duration_s=10.0, fs_hz=100.0,
                           rms=(3.0, 2.0, 1.0, 0.0, 0.0, 0.0))
    d = make_drive(cfg)
    np.testing.assert_allclose(np.max(np.abs(d), axis=1), [3, 2, 1, 0, 0, 0], atol=1e-12)


def test_track_drive_delays_the_irregularity_between_wheelsets() -> None:
    from modal_twin.excitation.drive import TRACK_CHANNELS, ExcitationConfig, make_drive
    from modal_twin.models.vehicle_spec import load_vehicle

    cfg = ExcitationConfig(kind="track", channels=TRACK_CHANNELS, fs_hz=400.0,
                           duration_s=4.0, speed_kmh=300.0, seed=3)
    u = make_drive(cfg)
    assert u.shape == (8, 1601)
    x = load_vehicle().axle_x
    # wheelset 2 meets the track that wheelset 1 met (x1 - x2) / v earlier
    lag = round((x[0] - x[1]) / (300.0 / 3.6) * 400.0)
    np.testing.assert_allclose(u[1, lag:], u[0, :-lag], atol=2e-3 * np.abs(u[0]).max())
    # rates are the time derivative of the displacements
    np.testing.assert_allclose(np.gradient(u[0], 1 / 400.0)[10:-10], u[4, 10:-10],
                               atol=0.05 * np.abs(u[4]).max())
    with pytest.raises(OptionError, match=r"kind=track drives the track irregularity"):
        ExcitationConfig(kind="track")


def test_track_drive_of_the_3d_car_has_three_delayed_components() -> None:
    """The 3D car's file takes the 24 track channels: profile, cross level and alignment
    under each wheelset (wheelset 2 meets what wheelset 1 met 2.5 m / V earlier: 60
    samples at 300 km/h and 2 kHz), then their rates (the time derivatives; 2 kHz so that
    the central difference resolves the 1 m wavelengths, 83 Hz, to 1 %)."""
    from modal_twin.excitation.drive import TRACK_CHANNELS, TRACK_CHANNELS_3D
    from modal_twin.models.vehicle3d_factory import INPUT_NAMES_3D

    assert TRACK_CHANNELS_3D == INPUT_NAMES_3D  # the drive's rows are the 3D plant's inputs
    car3d = "config/vehicles/trailer_car_3d.yaml"
    cfg = ExcitationConfig(kind="track", channels=TRACK_CHANNELS_3D, fs_hz=2000.0,
                           duration_s=1.0, speed_kmh=300.0, seed=3, vehicle_file=car3d)
    u = make_drive(cfg)
    assert u.shape == (24, 2001)
    for first in (0, 4, 8):  # zt1, phit1, yat1 against zt2, phit2, yat2
        a, b = u[first], u[first + 1]
        np.testing.assert_allclose(b[60:], a[:-60], atol=1e-9 * np.abs(a).max())
        rate = u[first + 12, 10:-10]
        assert np.std(np.gradient(a, 1 / 2000.0)[10:-10] - rate) < 0.02 * np.std(rate)
    assert 1e-4 < np.std(u[8]) < 1e-2  # alignment: millimetres on a low-interference track
    with pytest.raises(OptionError, match=r"a 3D car, its track channels are"):
        make_drive(ExcitationConfig(kind="track", channels=TRACK_CHANNELS, vehicle_file=car3d))
    with pytest.raises(OptionError, match=r"a vertical-plane car"):
        make_drive(ExcitationConfig(kind="track", channels=TRACK_CHANNELS_3D))
    with pytest.raises(OptionError, match=r"built at its file's speed_kmh 300, got 250"):
        make_drive(replace(cfg, speed_kmh=250.0))
