"""Frame files (``kind: frame``): the tracking frame of [000] as a rig driven by point forces.

Known answers: the plant of the shipped frame file, with the truth's contact stiffnesses,
has the accelerance of the frame's own modes (an independent eigen-solution of the frame
matrices, :math:`H_{oi}(\\omega) = \\sum_r \\phi_{or}\\phi_{ir}(-\\omega^2) / (\\omega_r^2 -
\\omega^2 + 2 i \\zeta \\omega_r \\omega)`, 2 % modal damping) at its sensors from its hit
points; a hammer pulse at a driving point first accelerates it along the force (the
direct term :math:`\\sum_r \\phi_{ir}^2 > 0`); every bad input is one line and an exit code.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import linalg

from modal_twin.cli import main
from modal_twin.errors import ConfigError, OptionError, ShapeError
from modal_twin.excitation.drive import ExcitationConfig
from modal_twin.models.loading import load_model
from modal_twin.models.matrix_model import load_matrix_model, matrix_model_from_arrays
from modal_twin.models.rig_file import load_rig
from modal_twin.models.sensors import rig_channels
from modal_twin.models.tracking_frame import frame_matrices

ROOT = Path(__file__).resolve().parents[2]
FRAME = ROOT / "config" / "structures" / "tracking_frame.yaml"
RIG = ROOT / "config" / "rigs" / "tracking_frame_hammer.yaml"
TRUTH = {"feet": -0.35, "bearings": 0.25}


def test_frame_file_is_a_matrix_model_with_force_dofs() -> None:
    mm = load_matrix_model(FRAME)
    nom = frame_matrices()
    assert mm.names == ("feet", "bearings")
    np.testing.assert_allclose(mm.K(np.array([-0.35, 0.25])).toarray(),
                               frame_matrices(theta=TRUTH)["K0"], rtol=1e-12, atol=1e-6)
    assert [mm.dofs[i] for i in mm.force_dofs] == ["402:z", "203:x"]
    assert mm.measured_dofs.size == 10 and mm.n_dof == nom["M"].shape[0]
    np.testing.assert_allclose(mm.lower, [-0.7, -0.7])
    np.testing.assert_allclose(mm.upper, [1.5, 1.5])


def test_rig_channels_have_the_hit_points_node_and_direction() -> None:
    chans = rig_channels(load_rig(RIG))
    forces = [c for c in chans if c.quantity == "force"]
    assert [(c.name, c.node, c.direction, c.effective_role) for c in forces] == [
        ("table_force_402_z", "402", "z", "input"), ("table_force_203_x", "203", "x", "input")]
    assert all(c.quantity == "acceleration" and c.effective_role == "output"
               for c in chans if c not in forces)


def test_force_plant_has_the_frames_accelerance() -> None:
    plant = load_model(FRAME, theta=TRUTH).plant()
    sysm = plant.system
    assert plant.input_names == ("force_402_z", "force_203_x")
    # the plant's FRF from its matrices: (s^2 M + s C + K) q = -Gamma u, y = C_out[:, q'']
    f = np.array([5.0, 18.0, 100.0, 300.0])
    r = sysm.K.shape[0]
    Hp = np.stack([sysm.C_out[:, 2 * r:] @ (s**2 * np.linalg.solve(
        s**2 * sysm.M + s * sysm.C + sysm.K, -sysm.Gamma)) for s in 2j * np.pi * f], axis=-1)
    # independently: the frame's lowest 30 modes, 2 % modal damping
    m = frame_matrices(theta=TRUTH)
    w2, phi = linalg.eigh(m["K0"], m["M"])
    w, phi = np.sqrt(w2[:30]), phi[:, :30]
    dofs = [str(d) for d in m["dofs"]]
    o = [dofs.index(f"{c.node}:{c.direction}") for c in plant.channels]
    i = [dofs.index("402:z"), dofs.index("203:x")]
    om = 2 * np.pi * f
    modal = -om**2 / (w[:, None] ** 2 - om**2 + 2j * 0.02 * w[:, None] * om)
    Hc = np.einsum("or,ir,rf->oif", phi[o], phi[i], modal)
    np.testing.assert_allclose(Hp, Hc, rtol=1e-8, atol=1e-10 * np.abs(Hc).max())


def test_a_hit_first_accelerates_the_driving_point_along_the_force() -> None:
    from modal_twin.excitation.signals import hammer_pulse
    from modal_twin.rig.truth import TruthRig
    from modal_twin.signal_block import SignalBlock

    plant = load_model(FRAME).plant()
    rig = TruthRig(plant, 1.0 / 4096.0)
    pulse = hammer_pulse(64, 4096.0, peak_n=100.0, tip_stiffness_n_m=2e6,
                         hammer_mass_kg=0.3, at_s=0.001)
    out = rig.process(SignalBlock(("force_402_z", "force_203_x"), 4096.0, 0,
                                  np.vstack([pulse, np.zeros(64)])))
    a = out.select(["402_z"]).data[0]
    k = int(np.argmax(pulse))
    assert a[k] > 0 and a[k] > 0.5 * np.abs(a[:k + 1]).max()
    np.testing.assert_array_equal(out.select(["table_force_402_z"]).data[0], pulse)


@pytest.mark.parametrize(("text", "words"), [
    ("kind: frame\nsensors: ['999:z']\n", "sensors"),
    ("kind: frame\nforces: ['402:z', '402:z']\n", "repeated"),
    ("kind: frame\nspec: {height_m: tall}\n", "height_m"),
    ("kind: frame\nbounds: [0.5, 0.1]\n", "bounds"),
    ("kind: frame\ncolour: red\n", "unknown keys"),
])
def test_bad_frame_files_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture,
                                      text: str, words: str) -> None:
    p = tmp_path / "frame.yaml"
    p.write_text(text)
    with pytest.raises(ConfigError, match=words):
        load_matrix_model(p)
    modes = tmp_path / "modes.json"
    modes.write_text("{}")
    assert main(["update", str(p), "--modes", str(modes)]) != 0
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err, err


def test_force_dofs_out_of_range_are_refused() -> None:
    with pytest.raises(ShapeError, match="force_dofs"):
        matrix_model_from_arrays({"M": np.eye(2), "K": np.eye(2), "force_dofs": [2]})


def test_an_overload_every_n_hits_needs_the_hammers_range() -> None:
    with pytest.raises(OptionError, match="overload_n"):
        ExcitationConfig(kind="impact", channels=("f",), rms=(1.0,), overload_every=3)
