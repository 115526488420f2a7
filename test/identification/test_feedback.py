"""Inputs fed back by the structure (a foundation on soil) choose output-only, said.

A three-storey shear frame (closed-form frequencies from its matrices) either on a rigid
base driven by a measured ground acceleration (exogenous input) or on a foundation mass
on a soil spring, the ground driving the soil and the foundation's acceleration measured
as the "input" (as a building's basement channel on an earthquake record). From the
foundation's motion to the floors the system is the frame on a fixed base (frequencies
of the 3 x 3 matrices); the floors' spectra show the soil-frame system (those of the
4 x 4 matrices, lower). Granger's feedback share tells the two records apart; the
default method asks it on transient (earthquake-like) records only.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.channels import ChannelSpec
from modal_twin.identification.feedback import FEEDBACK, input_feedback
from modal_twin.identification.record import IdentifyOptions, identify_record
from modal_twin.signal_block import SignalBlock

FLOORS = np.array([2000.0, 1800.0, 1500.0])
STOREYS = np.array([4.0e6, 3.0e6, 2.0e6])
FOUNDATION, SOIL = 3000.0, 3.0e6
FS, SECONDS = 100.0, 200.0


def _chain(m: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mass and stiffness of a chain whose first spring goes to the ground."""
    kk = np.r_[k, 0.0]
    return np.diag(m), np.diag(kk[:-1] + kk[1:]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)


def _f_hz(m: np.ndarray, k: np.ndarray) -> np.ndarray:
    M, K = _chain(m, k)
    return np.sqrt(sla.eigh(K, M, eigvals_only=True)) / (2 * np.pi)


def _absolute_accelerations(m: np.ndarray, k: np.ndarray, ag: np.ndarray,
                            rng: np.random.Generator) -> np.ndarray:
    """Absolute accelerations of every mass under ground acceleration ag (2 % modal damping)."""
    M, K = _chain(m, k)
    n = m.size
    w2, V = sla.eigh(K, M)
    C = M @ V @ np.diag(2 * 0.02 * np.sqrt(w2)) @ V.T @ M
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])
    B = np.vstack([np.zeros((n, 1)), -np.ones((n, 1))])
    Cy = np.hstack([-Mi @ K, -Mi @ C])
    sysd = sig.cont2discrete((A, B, Cy, np.zeros((n, 1))), 1 / FS)
    _, y, _ = sig.dlsim((*sysd[:4], 1 / FS), ag)
    return np.asarray(y.T + 0.02 * y.std(axis=0)[:, None] * rng.standard_normal(y.T.shape))


def _record(on_soil: bool, band_passed: bool = False, transient: bool = True
            ) -> tuple[SignalBlock, list[ChannelSpec]]:
    """Transient: white noise under an earthquake-like envelope (peak at 20 s of 200)."""
    rng = np.random.default_rng(5)
    ag = rng.standard_normal(int(FS * SECONDS))
    if transient:
        t = np.arange(ag.size) / FS
        ag *= (t / 20.0) ** 2 * np.exp(2.0 * (1.0 - t / 20.0))
    if band_passed:  # a coloured ground motion, still exogenous
        ag = sig.sosfilt(sig.butter(2, [0.5, 8.0], btype="band", fs=FS, output="sos"), ag)
    if on_soil:
        y = _absolute_accelerations(np.r_[FOUNDATION, FLOORS], np.r_[SOIL, STOREYS], ag, rng)
        data = y  # the foundation's acceleration is the measured "input"
    else:
        data = np.vstack([ag, _absolute_accelerations(FLOORS, STOREYS, ag, rng)])
    names = ("base", "floor1", "floor2", "floor3")
    chans = [ChannelSpec(n, "acceleration", direction="x", role="input" if k == 0 else "output")
             for k, n in enumerate(names)]
    return SignalBlock(names, FS, 0, data, source="frame"), chans


@pytest.mark.parametrize(("band_passed", "transient"),
                         [(False, False), (True, False), (False, True), (True, True)])
def test_an_exogenous_base_is_not_fed_back(band_passed: bool, transient: bool) -> None:
    block, _ = _record(on_soil=False, band_passed=band_passed, transient=transient)
    assert input_feedback(block.data[:1], block.data[1:]) < 0.2 * FEEDBACK


@pytest.mark.parametrize("transient", [False, True])
def test_a_foundation_on_soil_is_fed_back(transient: bool) -> None:
    block, _ = _record(on_soil=True, transient=transient)
    assert input_feedback(block.data[:1], block.data[1:]) > 1.5 * FEEDBACK


def test_fed_back_inputs_choose_output_only_and_its_modes_are_the_soil_frame_ones() -> None:
    """Default: SSI-cov, said, at the soil-frame frequencies; N4SID: the fixed-base frame's."""
    block, chans = _record(on_soil=True)
    rec = identify_record(block, chans, IdentifyOptions(f_max_hz=14.0))
    assert rec.method == "ssi-cov" and rec.inputs == ()
    assert any("fed back" in n and "output-only" in n for n in rec.notes)
    f_sys = _f_hz(np.r_[FOUNDATION, FLOORS], np.r_[SOIL, STOREYS])  # 2.34, 5.60, 8.78, 11.74
    near = [int(np.argmin(np.abs(rec.modes.f_hz - f))) for f in f_sys]
    np.testing.assert_allclose(rec.modes.f_hz[near], f_sys, rtol=0.01)
    io = identify_record(block, chans, IdentifyOptions(method="n4sid", f_max_hz=14.0))
    f_fixed = _f_hz(FLOORS, STOREYS)  # 3.16, 7.60, 11.18: above, as on the real records
    near = [int(np.argmin(np.abs(io.modes.f_hz - f))) for f in f_fixed]
    np.testing.assert_allclose(io.modes.f_hz[near], f_fixed, rtol=0.01)


def test_a_stationary_drive_is_not_tested_for_feedback() -> None:
    """A rig's drive (stationary): the soil frame's foundation stays the input; the test
    would misread band-limited drives (the module's limits)."""
    block, chans = _record(on_soil=True, transient=False)
    rec = identify_record(block, chans, IdentifyOptions(f_max_hz=14.0))
    assert rec.method == "n4sid" and [c.name for c in rec.inputs] == ["base"]


def test_an_exogenous_coherent_base_keeps_input_output() -> None:
    block, chans = _record(on_soil=False)
    rec = identify_record(block, chans, IdentifyOptions(f_max_hz=14.0))
    assert rec.method == "n4sid"
    assert any("not fed back" in n and "input-output" in n for n in rec.notes)
    f_fixed = _f_hz(FLOORS, STOREYS)
    near = [int(np.argmin(np.abs(rec.modes.f_hz - f))) for f in f_fixed]
    np.testing.assert_allclose(rec.modes.f_hz[near], f_fixed, rtol=0.01)


def test_polymax_on_a_short_exogenous_record_runs_output_only_for_its_coarse_h1_lines() -> None:
    """40 s: coherent, not fed back, but H1 lines 0.2 Hz apart (>= 8 averages) do not
    resolve a 1 %-damped mode at the band's centre (half-power width 0.15 Hz)."""
    block, chans = _record(on_soil=False, transient=False)
    short = SignalBlock(block.channel_names, FS, 0, block.data[:, : int(40 * FS)])
    pm = identify_record(short, chans, IdentifyOptions(method="polymax", f_max_hz=14.0))
    assert pm.inputs == ()
    assert any("PolyMAX output-only" in n and "do not resolve a 1 %-damped mode" in n
               for n in pm.notes), pm.notes
