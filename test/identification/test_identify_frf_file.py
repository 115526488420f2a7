"""``modal-twin identify FILE.uff``: PolyMAX + LSFD on a UFF file's FRF matrix.

Known answer: a two-mass chain (m = 1 kg, k = 1e4 N/m, the first mass on a spring to
ground too) with 1 % modal damping, its accelerance seen through an exponential window of
tau = 0.5 s (the pole moved by 1 / tau: evaluated at s = i w + 1 / tau) and written as UFF
58 beside a ``hits.yaml`` naming the window. ``identify`` finds the chain's two
eigenfrequencies within 0.1 % and, the window's damping removed, 1 % damping; ``update``
reads the modes it writes. Bad inputs are one line and an exit code.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy import linalg

from modal_twin.channels import ChannelSpec
from modal_twin.cli import main
from modal_twin.io.impact_files import read_frf_matrix
from modal_twin.io.uff import write_uff58_frf, write_uff58_time

K, ZETA, TAU = 1.0e4, 0.01, 0.5
M_, K_ = np.eye(2), np.array([[2 * K, -K], [-K, K]])


def _chain_frf(folder: Path) -> tuple[Path, np.ndarray]:
    w2, phi = linalg.eigh(K_, M_)
    w = np.sqrt(w2)
    f = np.arange(1, 801) * 0.125  # 0.125 .. 100 Hz
    s = 2j * np.pi * f + 1.0 / TAU
    modal = s**2 / (s**2 + 2 * ZETA * w[:, None] * s + w[:, None] ** 2)
    H = np.einsum("or,ir,rf->oif", phi, phi, modal)
    folder.mkdir(parents=True, exist_ok=True)
    path = write_uff58_frf(folder / "frf.uff", f, H, [(1, 3), (2, 3)], [(1, 3), (2, 3)])
    (folder / "hits.yaml").write_text(yaml.safe_dump({"tau_s": TAU}))
    return path, w / (2 * np.pi)


def test_frf_matrix_reads_back_with_nodes_and_directions(tmp_path: Path) -> None:
    f = np.linspace(1.0, 50.0, 50)
    H = (np.arange(2 * 3 * 50).reshape(2, 3, 50) + 1j).astype(complex)
    p = write_uff58_frf(tmp_path / "h.uff", f, H, [(7, 1), (8, -3)], [(1, 3), (2, 2), (3, 1)])
    f1, H1, outs, ins = read_frf_matrix(p)
    np.testing.assert_allclose(f1, f, rtol=1e-6)
    np.testing.assert_allclose(H1, H, rtol=1e-5)
    assert outs == [("7", "x"), ("8", "-z")] and ins == [("1", "z"), ("2", "y"), ("3", "x")]


def test_identify_a_frf_file_gives_the_chains_modes(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture) -> None:
    path, f_true = _chain_frf(tmp_path / "impact")
    assert main(["identify", str(path), "--out", str(tmp_path / "modes")]) == 0
    out = capsys.readouterr().out
    assert "band 0.25-40 Hz (40 % of the last line)" in out
    assert "exponential window of 0.5 s" in out
    doc = json.loads((tmp_path / "modes" / "modes.json").read_text())
    np.testing.assert_allclose([m["f_hz"] for m in doc["modes"]], f_true, rtol=1e-3)
    np.testing.assert_allclose([m["zeta"] for m in doc["modes"]], ZETA, atol=5e-4)
    assert [(d["node_label"], d["direction"]) for d in doc["dofs"]] == [("1", "z"), ("2", "z")]
    # the modes go into `update` of a matrix model at the same DOFs
    np.savez(tmp_path / "chain.npz", M=M_, K0=0.8 * K_, K_all=K_, dofs=np.array(["1:z", "2:z"]))
    assert main(["update", str(tmp_path / "chain.npz"), "--modes",
                 str(tmp_path / "modes" / "modes.json"), "--prior-weight", "0",
                 "--out", str(tmp_path / "v")]) == 0
    rep = json.loads((tmp_path / "v" / "update_v1.json").read_text())
    assert rep["theta"][0] == pytest.approx(0.2, abs=2e-3)  # K = 0.8 K + 0.2 K


@pytest.mark.parametrize(("args", "words"), [
    (["--method", "n4sid"], "PolyMAX + LSFD on its FRFs; --method n4sid does not apply"),
    (["--inputs", "a"], "on its FRFs; --inputs does not apply"),
    (["--method", "ssi-cov", "--outputs", "b"], "; --method ssi-cov, --outputs do not apply"),
    (["--f-max", "500"], "at most 100 Hz"),
    (["--f-max", "0.1"], "above 0.25 Hz"),
])
def test_bad_options_on_a_frf_file_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                args: list[str], words: str) -> None:
    path, _ = _chain_frf(tmp_path)
    assert main(["identify", str(path), *args]) != 0
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err, err


def test_a_uff_without_frfs_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    p = write_uff58_time(tmp_path / "t.uff", [ChannelSpec("a", "acceleration", node="1",
                                                          direction="z")], 100.0,
                         np.zeros((1, 64)))
    assert main(["identify", str(p)]) != 0
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "no FRF" in err, err


def test_identify_on_the_folder_of_an_imported_frf_file_says_what_to_do(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """``import frf.uff`` keeps the FRFs as spectra beside no bag; ``identify`` on that
    folder said 'not a rosbag2 bag'; now one line names what it holds and the way on."""
    path, _ = _chain_frf(tmp_path / "test")
    assert main(["import", str(path), "--out", str(tmp_path / "imp")]) == 0
    capsys.readouterr()
    assert main(["identify", str(tmp_path / "imp")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "no time record to identify, only ['spectra_frf.npz']" in err
    assert "modal-twin identify FILE.uff" in err
