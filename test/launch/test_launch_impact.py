"""The impact test of [000] through the node graph: launch, FRFs, identify, update.

``modal-twin launch impact_tracking_frame`` hits the tracking frame (the truth: feet
contact stiffness 35 % lower, bearings 25 % higher than the nominal frame file) six times
over two hit points, one hit bouncing and one overloaded; the acquisition in impact mode
writes the FRF matrix of the four accepted hits. Known answers:

- the FRFs equal those of the same drive through the same rig and impact processing in
  one process (nothing lost or reordered on the way through ROS) to 1e-9 of each FRF's
  peak;
- they equal the closed form of the sampled test within 2 % (relative L2 per FRF over
  10-420 Hz): the truth's 30 modes (mass-normalised, 2 % modal damping, the rig's
  reduction) give :math:`H(s) = \\sum_r \\phi_{or} \\phi_{ir} s^2 / (s^2 + 2 \\zeta
  \\omega_r s + \\omega_r^2)`; the exponential window of :math:`\\tau` moves it to
  :math:`s = i\\omega + 1/\\tau`; the rig's force is linear between samples (first-order
  hold, the factor :math:`\\mathrm{sinc}^2(\\omega T / 2)`) and the sampled response
  holds the aliases :math:`\\omega + k \\omega_s`;
- the bounced and the overloaded hit are rejected, counted and named (hits.yaml, the
  launcher's lines); ``modal-twin impact`` on the run's bag gives the same FRFs;
- ``identify`` (PolyMAX + LSFD on frf.uff) finds the truth's seven modes below 420 Hz
  within 0.5 % and 2 % damping within 0.3 points (the window's damping removed);
- ``update`` of the nominal frame file brings both contact stiffnesses within 0.02 of the
  truth's theta and the FOM of Eq. (1) of [000] down a hundredfold.
"""

from __future__ import annotations

import json
import re
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy import linalg

pytestmark = [pytest.mark.ros, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "config" / "scenarios" / "impact_tracking_frame.yaml"
FRAME = ROOT / "config" / "structures" / "tracking_frame.yaml"
TRUTH = {"feet": -0.35, "bearings": 0.25}


def _in_process_frf(params: dict, rig_file: str, acq: dict) -> tuple[np.ndarray, np.ndarray]:
    """The scenario's drive through the rig and the impact processing, without ROS."""
    from modal_twin.acquisition.frames import frame_from_raw
    from modal_twin.acquisition.hammer_test import HammerTest
    from modal_twin.excitation.drive import ExcitationConfig, make_drive
    from modal_twin.models.loading import load_model
    from modal_twin.models.rig_file import load_rig
    from modal_twin.models.sensors import rig_channels
    from modal_twin.paths import resolve_config
    from modal_twin.rig.truth import TruthRig
    from modal_twin.signal_block import SignalBlock

    names = {f.name for f in fields(ExcitationConfig)}
    cfg = ExcitationConfig(**{k: tuple(v) if isinstance(v, list) else v
                              for k, v in params.items() if k in names})
    drive = make_drive(cfg)
    rig = load_rig(resolve_config(rig_file))
    plant = load_model(rig.structure, theta=rig.theta).plant(rig.effects)
    truth = TruthRig(plant, 1.0 / cfg.fs_hz, noise_rms=rig.noise_rms,
                     sensitivity=rig.sensitivity, seed=rig.seed, channels=rig.channels)
    chans = {c.name: c for c in rig_channels(rig)}
    test = HammerTest(list(chans.values()), block_s=acq["impact_block_s"],
                      estimator=acq["impact_estimator"], tau_s=acq["impact_tau_s"],
                      force_range=acq["impact_force_range_n"])
    for i0 in range(0, drive.shape[1], cfg.block_size):
        raw = truth.process(SignalBlock(cfg.channels, cfg.fs_hz, i0,
                                        drive[:, i0:i0 + cfg.block_size]))
        frame, _ = frame_from_raw(raw, chans)
        assert frame is not None
        test.add(frame)
    res = test.finish()
    keep = res.f_hz > 0
    return res.f_hz[keep], res.H[..., keep]


def _closed_form(f: np.ndarray, outs: list, ins: list, *, tau: float, fs: float,
                 zeta: float = 0.02, n_modes: int = 30) -> np.ndarray:
    """Windowed, sampled accelerance of the truth frame (module docstring)."""
    from modal_twin.models.tracking_frame import frame_matrices

    m = frame_matrices(theta=TRUTH)
    w2, phi = linalg.eigh(m["K0"], m["M"])
    w, phi = np.sqrt(w2[:n_modes]), phi[:, :n_modes]
    dofs = [str(d) for d in m["dofs"]]
    o = [dofs.index(f"{n}:{d}") for n, d in outs]
    i = [dofs.index(f"{n}:{d}") for n, d in ins]
    T, H = 1.0 / fs, np.zeros((len(o), len(i), f.size), complex)
    for k in range(-4, 5):  # the aliases of the sampled response
        om = 2 * np.pi * f + k * 2 * np.pi * fs
        s = 1j * om + 1.0 / tau
        modal = s**2 / (s**2 + 2 * zeta * w[:, None] * s + w[:, None] ** 2)
        hold = np.sinc(om * T / (2 * np.pi)) ** 2  # sin(x)/x squared, x = om T / 2
        H += np.einsum("or,ir,rf->oif", phi[o], phi[i], modal) * hold
    return H


def test_impact_scenario_from_launch_to_updated_contact_stiffness(
        domain_id: int, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from modal_twin.cli import main
    from modal_twin.io.impact_files import read_frf_matrix
    from modal_twin.io.uff import read_uff
    from modal_twin.models.tracking_frame import frame_matrices

    doc = yaml.safe_load(SCENARIO.read_text())
    run = tmp_path / "run"
    # 12.5 s of hits played at four times real time, stopped 8 s after the start
    assert main(["launch", str(SCENARIO), "--run-dir", str(run), "--duration", "8",
                 "--set", "excitation.rate=4.0"]) == 0
    said = capsys.readouterr().out
    assert "impact: 4 hits averaged, 2 rejected" in said, said
    assert re.search(r"rejected at table_force_203_x, sample \d+: double hit", said), said
    assert re.search(r"rejected at table_force_203_x, sample \d+: overload: force 300 N",
                     said), said
    hits = yaml.safe_load((run / "impact" / "hits.yaml").read_text())
    verdicts = {p["name"]: [h["reason"].split(":")[0] for h in p["hits"]]
                for p in hits["points"]}
    assert verdicts == {"table_force_402_z": ["", "", ""],
                        "table_force_203_x": ["double hit", "overload", ""]}

    f, H, outs, ins = read_frf_matrix(run / "impact" / "frf.uff")
    assert ins == [("402", "z"), ("203", "x")] and len(outs) == 10
    # the measured points where the frame file places them (UFF 164 / 15 / 82)
    geo = read_uff(run / "impact" / "frf.uff").geometry
    m = {str(int(r[0])): r[1:] for r in frame_matrices()["node_xyz"]}
    assert sorted(geo["nodes"]) == sorted({n for n, _ in outs + ins})
    for n, v in geo["nodes"].items():
        np.testing.assert_allclose(v, m[n], atol=1e-6)
    assert geo["trace_lines"][0]["nodes"] == [101, 105, 301, 303, 405, 404, 402, 401, 203,
                                              201, 101]
    acq = doc["acquisition"]["ros__parameters"]
    f0, H0 = _in_process_frf(doc["excitation"]["ros__parameters"],
                             doc["rig"]["ros__parameters"]["rig_file"], acq)
    np.testing.assert_allclose(f, f0, rtol=1e-6)  # the UFF abscissa increment: 7 digits
    scale = np.abs(H0).max(axis=-1, keepdims=True)
    assert np.max(np.abs(H - H0) / scale) < 1e-9  # measured 3.7e-12: the same numbers
    Hc = _closed_form(f, outs, ins, tau=acq["impact_tau_s"],
                      fs=doc["excitation"]["ros__parameters"]["fs_hz"])
    band = (f >= 10.0) & (f <= 420.0)
    err = (np.linalg.norm((H - Hc)[..., band], axis=-1)
           / np.linalg.norm(Hc[..., band], axis=-1))
    assert err.max() < 0.02, np.round(err, 4)
    # the run's bag holds the test: `impact` on it (the recorded channel map names the
    # forces) gives the node's FRFs again
    assert main(["impact", str(run / "bag"), "--block-s", str(acq["impact_block_s"]),
                 "--tau-s", str(acq["impact_tau_s"]), "--force-range",
                 str(acq["impact_force_range_n"]), "--out", str(tmp_path / "again")]) == 0
    _, H2, outs2, ins2 = read_frf_matrix(tmp_path / "again" / "frf.uff")
    assert (outs2, ins2) == (outs, ins)
    again = read_uff(tmp_path / "again" / "frf.uff").geometry  # the recorded map's positions
    assert again["nodes"] == {k: pytest.approx(v) for k, v in geo["nodes"].items()}
    np.testing.assert_allclose(H2, H, rtol=0, atol=1e-12 * np.abs(H).max())

    assert main(["identify", str(run / "impact" / "frf.uff"), "--f-max", "420",
                 "--out", str(tmp_path / "modes")]) == 0
    modes = json.loads((tmp_path / "modes" / "modes.json").read_text())
    assert modes["geometry"]["nodes"] == {k: pytest.approx(v) for k, v in geo["nodes"].items()}
    f_id = np.array([m["f_hz"] for m in modes["modes"]])
    true = frame_matrices(theta=TRUTH)
    wn = np.sqrt(linalg.eigh(true["K0"], true["M"], eigvals_only=True)) / (2 * np.pi)
    f_true = wn[(wn > 10.0) & (wn < 420.0)]
    assert f_true.size == 7
    np.testing.assert_allclose(f_id, f_true, rtol=0.005)
    np.testing.assert_allclose([m["zeta"] for m in modes["modes"]], 0.02, atol=0.003)
    capsys.readouterr()

    assert main(["update", str(FRAME), "--modes", str(tmp_path / "modes" / "modes.json"),
                 "--prior-weight", "0", "--out", str(tmp_path / "model")]) == 0
    said = capsys.readouterr().out
    rep = json.loads((tmp_path / "model" / "update_v1.json").read_text())
    got = dict(zip(rep["names"], rep["theta"], strict=True))
    for j, th in TRUTH.items():
        assert got[j] == pytest.approx(th, abs=0.02), (j, got)
    fom = re.search(r"FOM \(Eq\. \(1\) of \[000\].*before ([\d.e+-]+), after ([\d.e+-]+)",
                    said)
    assert fom is not None, said
    assert float(fom[2]) < float(fom[1]) / 100
    assert min(rep["mac_after"]) > 0.99
