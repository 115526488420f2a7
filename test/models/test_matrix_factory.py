"""A user's matrix model (NPZ: M, K, C, DOF map) drives the twin like a structure file.

Known answers: a three-storey shear frame whose modes come from ``scipy.linalg.eigh`` and
whose record is simulated by ``scipy.signal.lsim`` on the full matrices (independent of the
library's reduction and integrator); the twin of the same matrices must reproduce it, one
with a 20 % stiffer storey must not.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as ss

from modal_twin.cli import main
from modal_twin.errors import ModelError, OptionError
from modal_twin.models.effects import EffectSpec
from modal_twin.models.loading import load_model
from modal_twin.models.matrix_factory import dof_place

FS = 500.0
MASS = np.diag([3.0e3, 3.0e3, 2.0e3])  # kg
K_STOREY = (6.0e6, 5.0e6, 3.0e6)  # N/m, storeys 1..3


def stiffness(k: tuple[float, float, float]) -> np.ndarray:
    k1, k2, k3 = k
    return np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])


def frame_file(path: Path, k: tuple[float, float, float] = K_STOREY) -> Path:
    K = stiffness(k)
    C = 0.2 * MASS + 1.5e-3 * K  # Rayleigh
    np.savez(path, M=MASS, K=K, C=C, dofs=np.array(["1:x", "2:x", "3:x"]))
    return path


def truth_record(path: Path, seconds: float = 20.0) -> Path:
    """Floor accelerations of the frame on random ground motion, by scipy.signal.lsim."""
    K, C = stiffness(K_STOREY), 0.2 * MASS + 1.5e-3 * stiffness(K_STOREY)
    Minv = np.linalg.inv(MASS)
    r = np.ones(3)
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-Minv @ K, -Minv @ C]])
    B = np.concatenate([np.zeros(3), -r])[:, None]
    Cy = np.hstack([-Minv @ K, -Minv @ C])  # relative acceleration; absolute = + a_g
    t = np.arange(round(seconds * FS)) / FS
    rng = np.random.default_rng(7)
    sos = ss.butter(4, [0.3, 25.0], "bandpass", fs=FS, output="sos")
    ag = ss.sosfiltfilt(sos, rng.normal(size=t.size)) * 2.0
    _, y, _ = ss.lsim(ss.StateSpace(A, B, Cy, np.full((3, 1), -1.0)), ag, t)
    acc = y.T + ag  # absolute floor accelerations
    np.savez(path, data=np.vstack([ag, acc]), fs_hz=FS,
             names=np.array(["ground", "floor_1", "floor_2", "roof"]),
             units=np.array(["m/s^2"] * 4))
    return path


def role_map(path: Path) -> Path:
    """The record's roles: ground motion in x drives, floors 1..3 (nodes 1..3) respond."""
    path.write_text(
        "channels:\n"
        "  - {name: ground, role: input, quantity: acceleration, direction: x}\n"
        + "".join(f"  - {{name: {n}, role: output, quantity: acceleration, node: '{k}', "
                  f"direction: x}}\n" for k, n in ((1, "floor_1"), (2, "floor_2"), (3, "roof"))))
    return path


def test_modes_and_plant_of_a_matrix_file(tmp_path: Path) -> None:
    f = load_model(frame_file(tmp_path / "frame.npz"))
    plant = f.plant()
    lam = sla.eigh(stiffness(K_STOREY), MASS, eigvals_only=True)
    np.testing.assert_allclose(np.sort(np.diag(plant.system.K)), lam, rtol=1e-9)
    assert plant.input_names == ("ax",)
    assert plant.channel_names == ("1_x", "2_x", "3_x")
    assert [c.node for c in plant.channels] == ["1", "2", "3"]
    # participation: Phi' M r, summed squares = total mass (all modes kept)
    assert float(np.sum(plant.system.Gamma ** 2)) == pytest.approx(8.0e3, rel=1e-9)
    assert f.parameters() == {}
    with pytest.raises(OptionError, match="has no devices"):
        f.plant([EffectSpec("RB1", "stick_slip", {})])
    assert dof_place("12:Z") == ("12", "z") and dof_place("7") == ("7", "")
    np.savez(tmp_path / "rot.npz", M=np.eye(2), K=np.eye(2), dofs=np.array(["1:rx", "1:ry"]))
    with pytest.raises(ModelError, match="no DOF label names a direction"):
        load_model(tmp_path / "rot.npz").plant()


def test_twin_of_a_matrix_model_reproduces_an_independent_record(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    rec = truth_record(tmp_path / "rec.npz")
    roles = role_map(tmp_path / "map.yaml")
    bag = tmp_path / "bag"
    assert main(["-q", "import", str(rec), "--map", str(roles), "--out", str(bag)]) == 0
    capsys.readouterr()
    assert main(["residual", str(frame_file(tmp_path / "frame.npz")), str(bag)]) == 0
    out = capsys.readouterr().out
    assert "inputs ax; 3 channels compared" in out
    worst = max(float(ln.split()[1]) for ln in out.splitlines()
                if ln.split() and ln.split()[0] in ("1_x", "2_x", "3_x"))
    assert worst < 0.5  # % NRMSE: the same structure, integrated by other code
    stiff = frame_file(tmp_path / "stiff.npz", (6.0e6, 6.0e6, 3.0e6))
    assert main(["residual", str(stiff), str(bag)]) == 0
    out = capsys.readouterr().out
    worst = max(float(ln.split()[1]) for ln in out.splitlines()
                if ln.split() and ln.split()[0] in ("1_x", "2_x", "3_x"))
    assert worst > 10.0


def test_diagnosis_finds_the_soft_storey_of_a_matrix_model_and_writes_it(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Substructures K_s1..K_s3; storey 2 modelled at 4 MN/m (truth 5): factor +0.25."""
    import yaml

    Ks = [stiffness(tuple(k if j == i else 0.0 for j, k in enumerate((6.0e6, 4.0e6, 3.0e6))))
          for i in range(3)]  # type: ignore[arg-type]
    model = tmp_path / "subs.npz"
    np.savez(model, M=MASS, K_s1=Ks[0], K_s2=Ks[1], K_s3=Ks[2],
             C=0.2 * MASS + 1.5e-3 * stiffness(K_STOREY), dofs=np.array(["1:x", "2:x", "3:x"]))
    roles = role_map(tmp_path / "map.yaml")
    bags = []
    for name, seconds in (("train", 20.0), ("test", 15.0)):
        rec = truth_record(tmp_path / f"{name}.npz", seconds)
        assert main(["-q", "import", str(rec), "--map", str(roles), "--out",
                     str(tmp_path / name)]) == 0
        bags.append(str(tmp_path / name))
    assert main(["-q", "effects", "add", str(model), "--train", bags[0], "--test", bags[1],
                 "--out", str(tmp_path / "versions"), "--auto"]) == 0
    v1 = yaml.safe_load((tmp_path / "versions" / "v0001.yaml").read_text())
    assert set(v1["theta"]) == {"s2"} and v1["theta"]["s2"] == pytest.approx(0.25, abs=1e-3)
    assert v1["effects"] == []
    capsys.readouterr()
    assert main(["residual", str(tmp_path / "versions" / "v0001.yaml"), bags[1]]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("median"))
    assert float(line.split()[2]) < 0.5  # % NRMSE of the written version
