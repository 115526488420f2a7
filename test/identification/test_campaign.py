"""Monitoring campaign: windows, identification on any executor, tracks across a frequency step."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as sig

from modal_twin.errors import OptionError, ShapeError, SignalError
from modal_twin.identification.campaign import (
    CampaignWindow,
    WindowIdentifier,
    WindowModes,
    run_campaign,
    split_windows,
    track_modes,
)
from modal_twin.signal_block import SignalBlock

FS = 40.0
PHI = np.array([[1.0, 0.6, 0.3, -0.2], [0.4, -0.5, 1.0, 0.8]]).T  # (4 outputs, 2 modes)
ZETA = 0.02
CH = ("a1", "a2", "a3", "a4")


def modal_response(f_hz, n, rng):
    """Acceleration-like response of two modes to white noise (exact discrete resonators)."""
    q = np.empty((2, n))
    for r, f in enumerate(f_hz):
        w = 2 * np.pi * f
        sys_d = sig.cont2discrete(([w**2], [1.0, 2 * ZETA * w, w**2]), 1 / FS, method="zoh")
        q[r] = sig.lfilter(np.ravel(sys_d[0]), sys_d[1], rng.standard_normal(n))
    y = PHI @ q
    return y + 0.05 * y.std(axis=1, keepdims=True) * rng.standard_normal(y.shape)


@pytest.fixture(scope="module")
def step_record():
    """1200 s: modes at 1.5 and 4.0 Hz; the first drops 6 % to 1.41 Hz at 600 s."""
    rng = np.random.default_rng(7)
    n = int(600 * FS)
    y = np.hstack([modal_response((1.5, 4.0), n, rng), modal_response((1.41, 4.0), n, rng)])
    return SignalBlock(CH, FS, 0, y, stamp_ns=1_000_000_000_000, source="synthetic")


@pytest.fixture(scope="module")
def campaign(step_record):
    w = split_windows(step_record, 200.0, outputs=CH, source="synthetic")
    return run_campaign(w, CH, identifier=WindowIdentifier(f_range_hz=(0.5, 10.0)), executor=1)


def test_windows_cover_the_record_in_order(step_record):
    w = split_windows(step_record, 250.0, outputs=CH[:2])
    assert [x.index for x in w] == [0, 1, 2, 3]  # 1200 s // 250 s, the tail dropped
    assert [x.t_start_s for x in w] == [1000.0, 1250.0, 1500.0, 1750.0]
    np.testing.assert_array_equal(w[1].y, step_record.data[:2, 10000:20000])
    assert all(x.u is None and x.source == "synthetic" for x in w)


def test_campaign_recovers_the_frequency_step(campaign):
    assert len(campaign.windows) == 6
    assert campaign.n_tracks == 2  # the step continues its track (6 % < 10 %)
    t, f, z = campaign.track_series(0)
    assert t.size == 6
    np.testing.assert_allclose(f[:3], 1.5, rtol=0.01)
    np.testing.assert_allclose(f[3:], 1.41, rtol=0.01)
    step = f[3:].mean() / f[:3].mean() - 1
    assert step == pytest.approx(-0.06, abs=0.01)  # 200 s windows: ~0.5 % scatter
    np.testing.assert_allclose(z, ZETA, rtol=0.5)
    t2, f2, _ = campaign.track_series(1)
    np.testing.assert_allclose(f2, 4.0, rtol=0.01)
    assert t2.size == 6


def test_table_has_one_row_per_window_and_mode(campaign):
    rows = campaign.rows()
    assert len(rows) == 12
    assert {r["track"] for r in rows} == {0, 1}
    assert rows[0]["t_start_s"] == 1000.0
    assert all(0.8 <= r["mac_to_track"] <= 1.0 for r in rows)


def test_same_result_on_a_process_pool(step_record, campaign):
    w = split_windows(step_record, 200.0, outputs=CH, source="synthetic")
    pool = run_campaign(w, CH, identifier=WindowIdentifier(f_range_hz=(0.5, 10.0)), executor=2)
    assert pool.rows() == campaign.rows()


def test_tracking_splits_what_does_not_match():
    x, y = np.array([[1], [0]], complex), np.array([[0], [1]], complex)
    a = WindowModes("s", 0, 0.0, 1.0, np.array([2.0]), np.array([0.01]), x)
    b = WindowModes("s", 1, 1.0, 1.0, np.array([2.05]), np.array([0.01]), y)
    c = WindowModes("s", 2, 2.0, 1.0, np.array([2.5]), np.array([0.01]), y)
    track, macs = track_modes([a, b, c])
    assert [t.tolist() for t in track] == [[0], [1], [2]]  # shape change, then 22 % jump
    assert macs[0].tolist() == [1.0]
    with pytest.raises(OptionError, match="rel_tol_f, mac_min: expected > 0 and in"):
        track_modes([a], mac_min=1.0)


def test_bad_input_raises(step_record):
    with pytest.raises(OptionError, match="window_s: expected a positive duration"):
        split_windows(step_record, 0.0, outputs=CH)
    with pytest.raises(OptionError, match="window_s: expected at most the record's 1200 s"):
        split_windows(step_record, 2000.0, outputs=CH)
    with pytest.raises(SignalError, match="unknown channels"):
        split_windows(step_record, 100.0, outputs=("zz",))
    with pytest.raises(OptionError, match="windows: expected at least one window"):
        run_campaign([], CH)
    w = CampaignWindow("s", 0, 0.0, FS, np.zeros((3, 100)))
    with pytest.raises(ShapeError, match="windows: expected 4 outputs each, got \\[3\\]"):
        run_campaign([w], CH)
    with pytest.raises(OptionError, match="method: expected one of"):
        WindowIdentifier(method="ssi_cov")


def test_a_window_that_fails_gives_no_modes_and_its_error():
    w = CampaignWindow("s", 0, 0.0, FS, np.ones((4, 400)))  # constant channels
    out = WindowIdentifier()(w)
    assert out.f_hz.size == 0
    assert out.error
    n4 = WindowIdentifier(method="n4sid")(CampaignWindow("s", 0, 0.0, FS,
                                                         np.random.default_rng(0).
                                                         standard_normal((4, 400))))
    assert "n4sid needs inputs" in n4.error
