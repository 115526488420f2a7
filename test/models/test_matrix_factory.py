"""A user's matrix model (NPZ: M, K, C, DOF map) drives the twin like a structure file.

Known answers: a three-storey shear frame whose modes come from ``scipy.linalg.eigh`` and
whose record is simulated by ``scipy.signal.lsim`` on the full matrices (independent of the
library's reduction and integrator); the twin of the same matrices must reproduce it, one
with a 20 % stiffer storey must not.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as ss
import yaml

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


def truth_record(path: Path, seconds: float = 20.0,
                 band_hz: tuple[float, float] = (0.3, 25.0)) -> Path:
    """Floor accelerations of the frame on random ground motion, by scipy.signal.lsim."""
    K, C = stiffness(K_STOREY), 0.2 * MASS + 1.5e-3 * stiffness(K_STOREY)
    Minv = np.linalg.inv(MASS)
    r = np.ones(3)
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-Minv @ K, -Minv @ C]])
    B = np.concatenate([np.zeros(3), -r])[:, None]
    Cy = np.hstack([-Minv @ K, -Minv @ C])  # relative acceleration; absolute = + a_g
    t = np.arange(round(seconds * FS)) / FS
    rng = np.random.default_rng(7)
    sos = ss.butter(4, list(band_hz), "bandpass", fs=FS, output="sos")
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


def soft_storey_model(path: Path) -> Path:
    """Substructures K_s1..K_s3 of the frame, storey 2 modelled at 4 MN/m (truth 5)."""
    Ks = [stiffness(tuple(k if j == i else 0.0 for j, k in enumerate((6.0e6, 4.0e6, 3.0e6))))
          for i in range(3)]  # type: ignore[arg-type]
    np.savez(path, M=MASS, K_s1=Ks[0], K_s2=Ks[1], K_s3=Ks[2],
             C=0.2 * MASS + 1.5e-3 * stiffness(K_STOREY), dofs=np.array(["1:x", "2:x", "3:x"]))
    return path


def test_diagnosis_finds_the_soft_storey_of_a_matrix_model_and_writes_it(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Substructures K_s1..K_s3; storey 2 modelled at 4 MN/m (truth 5): factor +0.25."""
    import yaml

    model = soft_storey_model(tmp_path / "subs.npz")
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


def test_effects_add_auto_prints_the_table_of_every_round_from_one_diagnosis(
        tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    """Storey 2 modelled at 4 MN/m (truth 5): s2 = +0.25 explains every record exactly.
    Stiffening storey 1 instead (s1) helps the broadband records but makes a record of the
    higher modes (6-25 Hz, another level) worse: it is listed as rejected with that record
    and figure. One diagnosis (two rounds: the second finds nothing significant) gives the
    table and the version written."""
    import modal_twin.diagnosis.pipeline as pipeline
    import modal_twin.diagnosis.workflow as workflow

    model = soft_storey_model(tmp_path / "subs.npz")
    roles = role_map(tmp_path / "map.yaml")
    for name, seconds, band in (("train", 20.0, (0.3, 25.0)), ("test", 15.0, (0.3, 25.0)),
                                ("high", 15.0, (6.0, 25.0))):
        rec = truth_record(tmp_path / f"{name}.npz", seconds, band)
        assert main(["-q", "import", str(rec), "--map", str(roles), "--out",
                     str(tmp_path / name)]) == 0
    calls = {"diagnose": 0, "rounds": 0}

    def counted(name: str, fn):  # type: ignore[no-untyped-def]
        def wrapper(*a, **k):  # type: ignore[no-untyped-def]
            calls[name] += 1
            return fn(*a, **k)
        return wrapper

    monkeypatch.setattr(workflow, "diagnose", counted("diagnose", workflow.diagnose))
    monkeypatch.setattr(pipeline, "diagnose_round", counted("rounds", pipeline.diagnose_round))
    capsys.readouterr()
    assert main(["-q", "effects", "add", str(model), "--train", str(tmp_path / "train"),
                 "--test", str(tmp_path / "test"), "--level", str(tmp_path / "high"),
                 "--out", str(tmp_path / "versions"), "--auto", "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert calls == {"diagnose": 1, "rounds": 2}, calls
    lines = out.splitlines()
    assert lines[0].startswith("FITTED BY SIMULATION")
    assert " round 1: the model as given" in lines
    assert " round 2: the model as given with stiffness at substructure s2" in lines
    s2 = next(ln for ln in lines if "s2 stiffness" in ln and "BIC" in ln)
    assert s2.rstrip().endswith("ADDED") and "->0.00 %" in s2
    s1 = next(ln for ln in lines if "s1 stiffness" in ln and "BIC" in ln)
    assert "REJECTED: makes" in s1 and "high worse (whitened RMS" in s1, s1
    assert "  decision: missing: stiffness (stiffness) at substructure s2 -- held-out NRMSE " \
        "76.98 % -> 0.00 %" in out
    assert any(ln.startswith("  decision: nothing significant is missing") for ln in lines)
    assert lines[-1].startswith(f"wrote {tmp_path / 'versions' / 'v0001.yaml'}: added s")
    v1 = yaml.safe_load((tmp_path / "versions" / "v0001.yaml").read_text())
    assert v1["theta"] == {"s2": pytest.approx(0.25, abs=1e-3)}
    # diagnose prints the same table, and --json holds the same rows and decisions
    table = "\n".join(lines[:next(i for i, ln in enumerate(lines) if ln.startswith("wrote"))])
    assert main(["-q", "diagnose", str(model), "--train", str(tmp_path / "train"), "--test",
                 str(tmp_path / "test"), "--level", str(tmp_path / "high"), "--jobs", "1",
                 "--json", str(tmp_path / "d.json")]) == 0
    assert table in capsys.readouterr().out
    doc = json.loads((tmp_path / "d.json").read_text())
    assert [r["decision"].split(":")[0] for r in doc["rounds"]] == [
        "missing", "nothing significant is missing"]
    rows = {r["component"]: r for r in doc["rounds"][0]["candidates"]}
    assert rows["s2"]["decision"] == "ADDED" and rows["s2"]["family"] == "stiffness"
    assert rows["s1"]["decision"] == "REJECTED" and "high worse" in rows["s1"]["reason"]
    assert [(f["family"], f["component"]) for f in doc["found"]] == [("stiffness", "s2")]
