"""``modal-twin setups`` (issue 22, item 6): roving setups joined from the command line.

The truth is a closed form: a fixed-free chain of n equal masses m and springs k has
w_r = 2 sqrt(k / m) sin((2r - 1) pi / (2 (2n + 1))) and shapes sin(j (2r - 1) pi / (2n + 1)),
j = 1..n. Each setup's modes file holds its channels' part of the first modes at an
arbitrary complex scale (as an identification gives them), 0.2 % frequency scatter and 1 %
shape noise, in the ``modes.json`` format ``identify`` writes.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from modal_twin.cli import main
from modal_twin.exit_codes import ExitCode
from modal_twin.identification.metrics import mac
from modal_twin.io.modes_file import read_modes

N, K_N_M, M_KG = 9, 4.0e5, 10.0
N_MODES = 4


def chain_truth() -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and shapes (N x N_MODES) of the fixed-free chain, closed form."""
    r = np.arange(1, N_MODES + 1)
    theta = (2 * r - 1) * np.pi / (2 * N + 1)
    f = 2 * np.sqrt(K_N_M / M_KG) * np.sin(theta / 2) / (2 * np.pi)
    j = np.arange(1, N + 1)
    return f, np.sin(np.outer(j, theta))


def write_setup(path: Path, points: list[int], rng: np.random.Generator, *,
                extra_mode_hz: float | None = None, missed: tuple[int, ...] = ()) -> Path:
    f, phi = chain_truth()
    scale = rng.standard_normal(N_MODES) + 1j * rng.standard_normal(N_MODES)
    shapes = phi[points] * scale
    shapes = shapes + 0.01 * np.abs(shapes).max(axis=0) * rng.standard_normal(shapes.shape)
    fs = f * (1 + 0.002 * rng.standard_normal(N_MODES))
    modes = [{"f_hz": float(fs[k]), "std_f_hz": None, "zeta": 0.02,
              "shape_re": shapes[:, k].real.tolist(), "shape_im": shapes[:, k].imag.tolist()}
             for k in range(N_MODES) if k not in missed]
    if extra_mode_hz is not None:  # a spurious mode of this setup only
        z = rng.standard_normal(len(points))
        modes.insert(1, {"f_hz": extra_mode_hz, "std_f_hz": None, "zeta": 0.05,
                         "shape_re": z.tolist(), "shape_im": [0.0] * len(points)})
    doc = {"method": "ssi-cov", "inputs": [], "geometry": None,
           "dofs": [{"channel": f"m{p + 1}", "node": k + 1, "node_label": f"m{p + 1}",
                     "direction": "x"} for k, p in enumerate(points)],
           "modes": modes}
    path.write_text(json.dumps(doc))
    return path


def three_setups(tmp: Path, seed: int = 0) -> list[Path]:
    rng = np.random.default_rng(seed)
    groups = [[0, 1, 2, 8], [3, 4, 5, 0, 8], [6, 7, 8, 0]]  # references m1 and m9
    return [write_setup(tmp / f"modes_{k + 1}.json", g, rng,
                        extra_mode_hz=30.0 if k == 1 else None)
            for k, g in enumerate(groups)]


def test_setups_merge_to_the_closed_form_chain(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    files = three_setups(tmp_path)
    out = tmp_path / "merged"
    code = main(["setups", *map(str, files), "--out", str(out)])
    text = capsys.readouterr().out
    assert code == ExitCode.OK, text
    assert "references m1, m9 (the channels every setup measured)" in text
    assert "cross-MAC modes_1.json x modes_2.json on 2 common channels" in text
    assert f"{N_MODES + 1} modes (paired within 5 % and reference MAC >= 0.8): {N_MODES} seen " \
           "in every setup, 1 in some only" in text
    # the 30 Hz mode of setup 2 alone is kept and said, its other channels empty
    assert ("mode 4 (30.0000 Hz): seen in modes_2.json only; not measured there: m2, m3, "
            "m7, m8 (left empty, not zero)") in text
    m = read_modes(out / "modes.json")
    names = [d["channel"] for d in m.dofs]
    assert sorted(names, key=lambda s: int(s[1:])) == [f"m{j + 1}" for j in range(N)]
    order = [names.index(f"m{j + 1}") for j in range(N)]
    f, phi = chain_truth()
    real = [0, 1, 2, 4]
    macs = np.diag(mac(m.shapes[order][:, real], phi))
    assert np.all(macs > 0.99), macs
    np.testing.assert_allclose(m.f_hz[real], f, rtol=0.005)
    assert m.f_hz[3] == pytest.approx(30.0)
    doc = json.loads((out / "modes.json").read_text())
    assert doc["references"] == ["m1", "m9"] and "PoSER" in doc["scaling"]
    assert min(min(x["reference_mac"]) for x in (doc["modes"][k] for k in real)) > 0.99
    assert [x["seen_in"] for x in doc["modes"]] == [
        ["modes_1.json", "modes_2.json", "modes_3.json"]] * 3 + [["modes_2.json"]] + [
        ["modes_1.json", "modes_2.json", "modes_3.json"]]
    assert doc["modes"][3]["not_measured"] == ["m2", "m3", "m7", "m8"]
    # the merged modes travel: UFF 55 written beside, export modes reads the JSON
    u = read_modes(out / "modes.uff")
    np.testing.assert_allclose(u.f_hz, m.f_hz, rtol=1e-5)  # UFF 55: single precision
    assert main(["export", "modes", str(out / "modes.json"), "--out",
                 str(tmp_path / "x.uff")]) == ExitCode.OK
    assert read_modes(tmp_path / "x.uff").shapes.shape == (N, N_MODES + 1)
    assert main(["report", str(out)]) == ExitCode.OK
    assert "5.26" in (out / "report.html").read_text()  # the merged first mode's f


def chain_model(path: Path) -> Path:
    """The chain as a matrix model (one parameter: every spring), DOFs ``m<j>:x``."""
    k = K_N_M * (2 * np.eye(N) - np.eye(N, k=1) - np.eye(N, k=-1))
    k[-1, -1] = K_N_M
    np.savez(path, M=M_KG * np.eye(N), K_springs=k,
             dofs=np.array([f"m{j + 1}:x" for j in range(N)]))
    return path


def test_a_mode_the_first_setup_missed_is_merged_from_the_others(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Setup 1 (rovers m2, m3) reports no mode 3 (its identification missed it); setups 2
    and 3 saw it. Known answer: the closed-form chain; mode 3 merged from setups 2 and 3
    with its entries at m2 and m3 empty (null / NaN), never zero."""
    rng = np.random.default_rng(4)
    groups = [[0, 1, 2, 8], [3, 4, 5, 0, 8], [6, 7, 8, 0]]
    files = [write_setup(tmp_path / f"modes_{k + 1}.json", g, rng,
                         missed=(2,) if k == 0 else ()) for k, g in enumerate(groups)]
    out = tmp_path / "merged"
    assert main(["setups", *map(str, files), "--out", str(out)]) == ExitCode.OK
    text = capsys.readouterr().out
    assert f"{N_MODES} modes (paired within 5 % and reference MAC >= 0.8): 3 seen in every " \
           "setup, 1 in some only" in text
    f, phi = chain_truth()
    f3 = np.mean([json.loads(p.read_text())["modes"][2]["f_hz"] for p in files[1:]])
    assert (f"mode 3 ({f3:.4f} Hz): seen in modes_2.json, modes_3.json only; not measured "
            "there: m2, m3 (left empty, not zero)") in text
    doc = json.loads((out / "modes.json").read_text())
    names = [d["channel"] for d in doc["dofs"]]
    mode3 = doc["modes"][2]
    assert [mode3["shape_re"][names.index(c)] for c in ("m2", "m3")] == [None, None]
    assert mode3["seen_in"] == ["modes_2.json", "modes_3.json"]
    assert mode3["reference_mac"][0] is None and min(mode3["reference_mac"][1:]) > 0.99
    m = read_modes(out / "modes.json")
    order = [names.index(f"m{j + 1}") for j in range(N)]
    S = m.shapes[order]
    assert np.flatnonzero(~np.isfinite(S[:, 2])).tolist() == [1, 2]
    seen = np.isfinite(S[:, 2])
    assert mac(S[seen, 2:3], phi[seen, 2:3])[0, 0] > 0.99
    assert np.all(np.diag(mac(S[:, [0, 1, 3]], phi[:, [0, 1, 3]])) > 0.99)
    np.testing.assert_allclose(m.f_hz, f, rtol=0.005)
    u = read_modes(out / "modes.uff")  # UFF 55: the empty entries stay NaN
    assert np.flatnonzero(~np.isfinite(u.shapes[:, 2])).size == 2
    assert main(["report", str(out)]) == ExitCode.OK
    capsys.readouterr()
    # update compares shapes at every sensor: the incomplete mode is left out, said
    assert main(["update", str(chain_model(tmp_path / "chain.npz")), "--modes",
                 str(out / "modes.json"), "--bounds=-0.5,0.5", "--prior-weight", "0"]) == 0
    said = capsys.readouterr()
    assert ("update: modes.json: left out 1 mode(s) with shape entries not measured (seen in "
            f"some setups only): {m.f_hz[2]:.4f} Hz") in said.err
    assert "3 modes at 9 DOFs" in said.err


def test_cross_mac_table_pairs_each_mode(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    files = three_setups(tmp_path, seed=1)
    assert main(["setups", *map(str, files[:2]), "--references", "m1,m9"]) == ExitCode.OK
    text = capsys.readouterr().out
    lines = text.split("cross-MAC")[1].splitlines()[2:2 + N_MODES]
    f, _ = chain_truth()
    # setup 2 has the spurious mode at index 2 (1-based): modes 1, 3, 4, 5 pair with 1..4
    for i, line in enumerate(lines):
        a, fa, b, fb, _, mac_ = line.split()
        assert (int(a), int(b)) == (i + 1, [1, 3, 4, 5][i])
        assert float(fa) == pytest.approx(f[i], rel=0.01)
        assert float(fb) == pytest.approx(f[i], rel=0.01)
        assert float(mac_) > 0.99


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == ExitCode.USAGE
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    return err


def test_setups_without_common_channels_are_refused(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    rng = np.random.default_rng(2)
    a = write_setup(tmp_path / "a.json", [0, 1, 2], rng)
    b = write_setup(tmp_path / "b.json", [3, 4], rng)
    err = _refused(["setups", str(a), str(b), "--out", str(tmp_path / "o")], capsys)
    assert "no reference channel common to every setup" in err
    assert "a.json: m1, m2, m3" in err and "b.json: m4, m5" in err
    assert not (tmp_path / "o" / "modes.json").exists()


def test_bad_setups_input_is_one_line(tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    files = three_setups(tmp_path)
    err = _refused(["setups", *map(str, files), "--references", "m1,m5"], capsys)
    assert "--references m5: not measured in modes_1.json" in err
    _refused(["setups", str(files[0])], capsys)
    _refused(["setups", *map(str, files), "--df-rel", "-1"], capsys)
    _refused(["setups", *map(str, files), "--min-mac", "2"], capsys)
    (tmp_path / "bad.json").write_text("{not json")
    err = _refused(["setups", str(files[0]), str(tmp_path / "bad.json")], capsys)
    assert "expected a modes JSON" in err
    out = tmp_path / "o"
    out.mkdir()
    (out / "modes.json").write_text("keep")
    err = _refused(["setups", *map(str, files), "--out", str(out)], capsys)
    assert "--force" in err and (out / "modes.json").read_text() == "keep"
