"""Own structure, own data: import -> identify -> export -> update from the command line.

Synthetic known answers first (a two-storey shear frame on a measured base motion, exact
frequencies from its matrices), then the bad-input contract (one line, exit code 2,
nothing written), then the real records of ../shared/realdata (skipped where absent).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from modal_twin.cli import main
from modal_twin.exit_codes import ExitCode

MASS = np.array([2000.0, 1500.0])  # kg
K_STORY = np.array([3.0e6, 2.0e6])  # N/m, the truth


def _k(k: np.ndarray) -> np.ndarray:
    return np.array([[k[0] + k[1], -k[1]], [-k[1], k[1]]])


def exact_f_hz() -> np.ndarray:
    w2 = sla.eigh(_k(K_STORY), np.diag(MASS), eigvals_only=True)
    return np.sqrt(w2) / (2 * np.pi)


def shear_frame_csv(path: Path, fs: float = 100.0, seconds: float = 120.0, *,
                    unmeasured: float = 0.0) -> Path:
    """Base acceleration (white, 0.5 m/s^2 RMS) and the floors' absolute accelerations, 2 %
    modal damping, 2 % sensor noise, written with units (floor 2 in g to check the
    conversion); ``unmeasured`` x another white base motion drives the frame too but is
    not in the ``ground`` column."""
    M, K = np.diag(MASS), _k(K_STORY)
    w2, V = sla.eigh(K, M)
    C = M @ V @ np.diag(2 * 0.02 * np.sqrt(w2)) @ V.T @ M  # V^T M V = I
    Mi = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ K, -Mi @ C]])
    B = np.vstack([np.zeros((2, 1)), -np.ones((2, 1))])
    Cy = np.hstack([-Mi @ K, -Mi @ C])  # absolute acceleration = relative + base
    Ad, Bd, Cd, Dd, _ = sig.cont2discrete((A, B, Cy, np.zeros((2, 1))), 1 / fs)
    rng = np.random.default_rng(7)
    ag = 0.5 * rng.standard_normal(int(fs * seconds))
    hidden = unmeasured * 0.5 * np.random.default_rng(11).standard_normal(ag.size)
    _, y, _ = sig.dlsim((Ad, Bd, Cd, Dd, 1 / fs), ag + hidden)
    y = y + 0.02 * y.std(axis=0) * rng.standard_normal(y.shape)  # sensor noise, 2 % RMS
    t = np.arange(ag.size) / fs
    rows = np.column_stack([t, ag, y[:, 0], y[:, 1] / 9.80665])
    np.savetxt(path, rows, delimiter=",", fmt="%.9g",
               header="t [s],ground [m/s^2],floor1 [m/s^2],floor2 [g]", comments="")
    return path


def matrix_model_npz(path: Path, scale: float = 0.85, *, sensors: bool = True) -> Path:
    """The frame as a matrix model: substructures = the two storeys, both ``scale`` x the
    truth (K(theta) = sum (1 + theta_j) K_j), sensors at both floors (or no sensor list:
    the channels' node and direction find their DOFs by label)."""
    k1 = _k(np.array([K_STORY[0], 0.0])) * scale
    k2 = _k(np.array([0.0, K_STORY[1]])) * scale
    extra = {"measured_dofs": np.array([0, 1])} if sensors else {}
    np.savez(path, M=np.diag(MASS), K_story1=k1, K_story2=k2, dofs=np.array(["1:x", "2:x"]),
             **extra)
    return path


@pytest.fixture(scope="module")
def frame(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("frame")
    csv = shear_frame_csv(d / "frame.csv")
    roles = d / "roles.yaml"
    roles.write_text("channels:\n  - {name: ground, role: input}\n"
                     "  - {name: floor1, node: '1', direction: x}\n"
                     "  - {name: floor2, node: '2', direction: x}\n")
    assert main(["import", str(csv), "--map", str(roles), "--out", str(d / "bag")]) == 0
    assert main(["identify", str(d / "bag"), "--out", str(d / "id")]) == 0
    return {"dir": d, "bag": d / "bag", "modes": d / "id" / "modes.json"}


def test_import_identify_known_frame(frame: dict[str, Path], capsys: pytest.CaptureFixture
                                     ) -> None:
    cmap = json.loads((frame["bag"] / "channel_map.json").read_text())
    assert [(c["name"], c["role"], c["node"]) for c in cmap["channels"]] == [
        ("ground", "input", ""), ("floor1", "output", "1"), ("floor2", "output", "2")]
    assert cmap["fs_hz"] == pytest.approx(100.0)
    doc = json.loads(frame["modes"].read_text())
    f = np.array([m["f_hz"] for m in doc["modes"]])
    z = np.array([m["zeta"] for m in doc["modes"]])
    np.testing.assert_allclose(f, exact_f_hz(), rtol=0.01)
    np.testing.assert_allclose(z, 0.02, atol=0.006)
    assert doc["method"] == "n4sid"
    assert all(m["mpc"] > 0.95 for m in doc["modes"])
    for png in ("stabilization.png", "mac.png"):
        assert (frame["modes"].parent / png).stat().st_size > 1000


def test_polymax_and_ssi_cov_on_the_frame(frame: dict[str, Path], tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    for method, tol in (("polymax", 0.01), ("ssi-cov", 0.01)):
        out = tmp_path / method
        assert main(["identify", str(frame["bag"]), "--method", method, "--out", str(out)]) == 0
        table = capsys.readouterr().out
        # PolyMAX estimates no spread: its std columns read "-", never "nan"
        assert "nan" not in table
        assert ("(std: not estimated by polymax)" in table) == (method == "polymax")
        doc = json.loads((out / "modes.json").read_text())
        f = np.array([m["f_hz"] for m in doc["modes"]])
        near = f[[int(np.argmin(np.abs(f - x))) for x in exact_f_hz()]]
        np.testing.assert_allclose(near, exact_f_hz(), rtol=tol)  # measured 0.4 % / 0.6 %
        # output-only on two channels over the 99 % band: two-entry shapes cannot tell a
        # spurious column from a mode (the clustering keeps two, 5.88 and 8.60 Hz, of 11
        # and 24 poles); PolyMAX on H1 reports exactly the two modes
        assert f.size == 2 if method == "polymax" else f.size <= 4


def test_identify_keeps_existing_outputs_unless_forced(frame: dict[str, Path], tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    out = tmp_path / "id"
    out.mkdir()
    (out / "modes.json").write_text("KEEP\n")
    assert main(["identify", str(frame["bag"]), "--out", str(out)]) == ExitCode.USAGE
    assert capsys.readouterr().err.strip().endswith("exists; give --force to overwrite it")
    assert [p.name for p in out.iterdir()] == ["modes.json"]
    assert main(["identify", str(frame["bag"]), "--out", str(out), "--force"]) == 0
    assert json.loads((out / "modes.json").read_text()) == json.loads(frame["modes"].read_text())
    assert sorted(p.name for p in out.iterdir()) == ["mac.png", "modes.json", "modes.uff",
                                                      "stabilization.png"]  # no temp left


def test_export_modes_and_model_round_trip(frame: dict[str, Path], tmp_path: Path) -> None:
    import pyuff

    out = tmp_path / "modes.uff"
    assert main(["export", "modes", str(frame["modes"]), "--out", str(out)]) == 0
    sets = pyuff.UFF(str(out)).read_sets()
    doc = json.loads(frame["modes"].read_text())
    f = [abs(s["eig"]) / (2 * np.pi) for s in (sets if isinstance(sets, list) else [sets])]
    np.testing.assert_allclose(f, [m["f_hz"] for m in doc["modes"]], rtol=1e-5)
    from modal_twin.io.modes_file import read_modes

    js = read_modes(frame["modes"])
    for uff in (out, frame["modes"].with_suffix(".uff")):  # export's and identify's
        back = read_modes(uff)
        assert [(d["channel"], d["node"], d["direction"]) for d in back.dofs] == [
            ("floor1", 1, "x"), ("floor2", 2, "x")]
        np.testing.assert_allclose(back.f_hz, js.f_hz, rtol=1e-5)
        np.testing.assert_allclose(back.zeta, js.zeta, rtol=1e-4)
        np.testing.assert_allclose(back.shapes, js.shapes, rtol=1e-4,
                                   atol=1e-5 * np.abs(js.shapes).max())
    assert main(["import", str(out), "--out", str(tmp_path / "again")]) == 0
    again = read_modes(tmp_path / "again" / "modes_modes.json")
    np.testing.assert_allclose(again.f_hz, js.f_hz, rtol=1e-5)
    assert [d["channel"] for d in again.dofs] == ["floor1", "floor2"]
    npz = matrix_model_npz(tmp_path / "frame.npz", scale=1.0)
    back = tmp_path / "frame_out.npz"
    assert main(["export", "model", str(npz), "--out", str(back)]) == 0
    from modal_twin.models.matrix_model import read_matrix_arrays

    z = read_matrix_arrays(back)
    np.testing.assert_allclose(z["K"].toarray(), _k(K_STORY))  # stored sparse
    assert list(z["parameter_names"]) == ["story1", "story2"]
    frf = tmp_path / "frf.uff"
    assert main(["export", "frf", str(frame["bag"]), "--out", str(frf)]) == 0
    sets = pyuff.UFF(str(frf)).read_sets()
    assert [int(s["func_type"]) for s in sets] == [4, 4, 6, 6]  # FRFs, then coherences
    # floor over ground acceleration: numerator and denominator both acceleration (12)
    assert [(s["ordinate_spec_data_type"], s["orddenom_spec_data_type"])
            for s in sets[:2]] == [(12, 12), (12, 12)]


def test_export_structure_to_npz_keeps_its_modes(tmp_path: Path) -> None:
    from modal_twin.models.building import build_building, modal_reduction
    from modal_twin.models.fe import solve_modes
    from modal_twin.models.matrix_model import load_matrix_model

    yaml = Path(__file__).resolve().parents[1] / "config" / "structures" / "building.yaml"
    out = tmp_path / "b.npz"
    assert main(["export", "model", str(yaml), "--out", str(out)]) == 0
    mm = load_matrix_model(out)
    f = solve_modes(mm.K0, mm.M, 4).f_hz
    ref = modal_reduction(build_building(yaml), 4).f_hz
    np.testing.assert_allclose(f, ref[:4], rtol=1e-8)
    assert "E_Fc36" in mm.names


def test_update_frame_to_identified_modes(frame: dict[str, Path], tmp_path: Path,
                                          capsys: pytest.CaptureFixture) -> None:
    npz = matrix_model_npz(tmp_path / "frame.npz", scale=0.85)
    out = tmp_path / "versions"
    assert main(["update", str(npz), "--modes", str(frame["modes"]), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "determined by the data: ['story1', 'story2']" in text
    rep = json.loads((out / "update_v1.json").read_text())
    # truth = 1 / 0.85 - 1 = +17.6 % on both storeys, to the identification's accuracy
    np.testing.assert_allclose(rep["theta"], 1 / 0.85 - 1, atol=0.02)
    assert max(abs(v) for v in rep["df_pct_after"]) < 0.5
    assert (out / "model_v1.npz").is_file()
    assert main(["update", str(npz), "--modes", str(frame["modes"]), "--out", str(out)]) == 0
    assert (out / "model_v2.npz").is_file()  # a new version, the old one kept
    bare = matrix_model_npz(tmp_path / "bare.npz", scale=0.85, sensors=False)
    assert main(["update", str(bare), "--modes", str(frame["modes"]), "--out", str(out)]) == 0
    rep3 = json.loads((out / "update_v3.json").read_text())
    np.testing.assert_allclose(rep3["theta"], rep["theta"], rtol=1e-9)  # DOFs by label


def _bad(argv: list[str], capsys: pytest.CaptureFixture, *needles: str) -> None:
    assert main(argv) == ExitCode.USAGE
    err = capsys.readouterr().err.strip()
    lines = [ln for ln in err.splitlines() if not ln.startswith("import: ")]  # progress
    assert len(lines) == 1, err
    assert lines[0].startswith("modal-twin ")
    assert "Traceback" not in err
    for n in needles:
        assert n in err


def test_bad_input_one_line_exit_2_nothing_written(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "bag"
    no_units = tmp_path / "nounits.csv"
    no_units.write_text("t,a\n0,1\n0.1,2\n")
    _bad(["import", str(no_units), "--out", str(out)], capsys, "nounits.csv", "without units")
    short = tmp_path / "short.csv"
    short.write_text("t [s],a [m/s^2],b [m/s^2]\n0,1,2\n0.1,2\n")
    _bad(["import", str(short), "--out", str(out)], capsys, "short.csv", "missing columns")
    other = tmp_path / "other.uff"
    other.write_text("    -1\n  2412\n    -1\n")  # FE elements only
    _bad(["import", str(other), "--out", str(out)], capsys, "other.uff",
         "no supported UFF dataset", "2412")
    good = shear_frame_csv(tmp_path / "good.csv", seconds=2.0)
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text("channels:\n  - {name: floor9, role: input}\n")
    _bad(["import", str(good), "--map", str(wrong), "--out", str(out)], capsys, "wrong.yaml",
         "does not fit the data", "floor9")
    odd = tmp_path / "model.fem"
    odd.write_bytes(b"\x00\x01binary")
    _bad(["model", "info", str(odd)], capsys, "model.fem", "unknown model file kind")
    _bad(["import", str(odd), "--out", str(out)], capsys, "model.fem", "unknown file kind")
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []
    # a role the data lack: n4sid without inputs
    assert main(["import", str(good), "--out", str(out)]) == 0
    capsys.readouterr()
    _bad(["identify", str(out), "--method", "n4sid"], capsys, "needs input channels",
         "ssi-cov")
    # a direction no output has (it read as 'no channel with role output'), an azimuth
    # that is not one (NaN gave every direction 'nan,nan,0' and exit 0)
    _bad(["identify", str(out), "--directions", "q"], capsys, "directions ['q']: no output "
         "channel along them (the outputs' directions: ['none']")
    for az in ("nan", "400", "-1"):
        _bad(["import", str(good), "--structure-frame", az, "--out", str(tmp_path / "az")],
             capsys, "--structure-frame: expected an azimuth in [0, 360) deg from north")
    assert not (tmp_path / "az").exists()


# ---------------------------------------------------------------- real records
def _real(shared: Path, *parts: str) -> Path:
    p = shared.joinpath("realdata", *parts)
    if not p.exists():
        pytest.skip(f"{p} absent")
    return p


REAL = [("uff", n) for n in ("accel_4ch_3200hz_uff58b.uff", "geometry_artemis_export.uff",
                              "geometry_testlab_15_18_82_161_164.uff", "sample_uff58_ascii.uff",
                              "sample_uff58b_binary.uff", "shaker_psd_uff58.uff")] + [
    ("earthquakes", n) for n in ("csmip58658_hayward_bridge_2021-04-26.zip",
                                 "csmip58658_hayward_bridge_2021-11-17.zip",
                                 "csmip89324_riodell_overpass_2021-12-20.zip",
                                 "nsmp1103_berkeley_building_2018-01-04.zip")]


def test_every_real_file_imports(shared_dir: Path, tmp_path: Path,
                                 capsys: pytest.CaptureFixture) -> None:
    folder = shared_dir / "realdata"
    found = sorted(p.name for sub in ("uff", "earthquakes") for p in (folder / sub).iterdir())
    assert found == sorted(n for _, n in REAL)  # a new file gets a line here
    for sub, name in REAL:
        out = tmp_path / name
        assert main(["import", str(folder / sub / name), "--out", str(out)]) == 0, name
        assert out.is_dir()
    text = capsys.readouterr().out
    assert "4 channels x 222400 samples at 3200 Hz" in text
    geo = json.loads((tmp_path / "geometry_artemis_export.uff" /
                      "geometry_artemis_export.json").read_text())
    assert len(geo["nodes"]) == 74
    assert len(geo["trace_lines"]) == 2
    cmap = json.loads((tmp_path / REAL[6][1] / "channel_map.json").read_text())
    ch06 = next(c for c in cmap["channels"] if c["name"] == "58658.ch06")
    assert (ch06["role"], ch06["direction"]) == ("input", "x")
    assert ch06["meta"]["filter_hz"] == [0.3, 40.0]
    assert ch06["meta"]["spectra_file"] == "chan006.v3"
    bld = json.loads((tmp_path / REAL[9][1] / "channel_map.json").read_text())
    assert bld["structure_frame"]["x_azimuth_deg"] == 171.0
    dirs = {c["name"]: c["direction"] for c in bld["channels"]}
    assert dirs["1103.HN3.NP.RE"] == dirs["1103.HN3.NP.RS"] == "y"  # 261 and 81 deg


def _first_modes(bag: Path, tmp: Path, *extra: str) -> np.ndarray:
    assert main(["identify", str(bag), "--out", str(tmp), *extra]) == 0
    return np.array([m["f_hz"] for m in json.loads((tmp / "modes.json").read_text())["modes"]])


def test_hayward_bridge_both_events_from_the_command_line(shared_dir: Path,
                                                          tmp_path: Path) -> None:
    zmap = Path(__file__).resolve().parents[1] / "config" / "channel_maps"
    f1 = []
    for event in ("2021-04-26", "2021-11-17"):
        z = _real(shared_dir, "earthquakes", f"csmip58658_hayward_bridge_{event}.zip")
        bag = tmp_path / event
        assert main(["import", str(z), "--map", str(zmap / "csmip58658_hayward.yaml"),
                     "--out", str(bag)]) == 0
        # without the map the headers' location words give the map's roles
        assert main(["import", str(z), "--out", str(tmp_path / f"{event}-own")]) == 0
        roles = [[(c["name"], c["role"]) for c in
                  json.loads((b / "channel_map.json").read_text())["channels"]]
                 for b in (bag, tmp_path / f"{event}-own")]
        assert roles[0] == roles[1]
        assert sum(r == "input" for _, r in roles[1]) == 6
        f1.append(_first_modes(tmp_path / f"{event}-own", tmp_path / f"id{event}"))
    # the default (SSI-cov: the ground channels explain 64-65 % of the response) reports,
    # within 0.5 %, modes an FDD and a plain SSI-cov agree on (bench_real_modes.py): the
    # three first of 2021-04-26 and two of 2021-11-17 (the 3.3 Hz mode is 3.35 / 3.19 Hz)
    for f, agreed in zip(f1, ([1.756, 2.493, 3.343], [15.265, 21.807]), strict=True):
        assert all(np.min(np.abs(f / fa - 1)) < 0.005 for fa in agreed), f


def _v2_file(loc: str, chan: int) -> str:
    rng = np.random.default_rng(chan)
    vals = "".join(f"{v:10.6f}" for v in rng.standard_normal(400))
    body = "\n".join(vals[k : k + 80] for k in range(0, len(vals), 80))
    return ("Corrected accelerogram   99999-X.01       Chan  1:  Long\n"
            "Station No. 99999   37.691N, 122.099W    Granit  s/n  133 (2 Chns of 2 at Sta)\n"
            "Somewhere - Test Overpass  CGS   Data: Acceleration\n"
            f"Chan  {chan}:  Long                      Location: {loc}\n"
            f" 400 points of accel data equally spaced at 0.01 sec, in cm/sec2. (8f10.6)\n"
            f"{body}\n")


def test_import_prints_roles_and_refuses_what_headers_cannot_tell(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    import zipfile

    z = tmp_path / "rec.zip"
    with zipfile.ZipFile(z, "w") as f:
        f.writestr("chan001.v2", _v2_file("Free Field", 1))
        f.writestr("chan002.v2", _v2_file("Bent 3", 2))
    assert main(["import", str(z), "--out", str(tmp_path / "a")]) == ExitCode.USAGE
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "cannot tell the role of 1 channel(s) ['99999.ch02']" in err
    assert "no base or structure word in 'Bent 3'" in err and "--map" in err
    assert not (tmp_path / "a").exists()
    m = tmp_path / "m.yaml"
    m.write_text("channels:\n  - {name: 99999.ch02, role: output}\n")
    assert main(["import", str(z), "--map", str(m), "--out", str(tmp_path / "b")]) == 0
    out = capsys.readouterr().out
    assert "roles from the headers of Somewhere - Test Overpass and" in out
    assert "99999.ch01  input      'Free Field': base word 'Free Field'" in out
    assert f"99999.ch02  output     --map {m}; headers: cannot tell" in out


def test_berkeley_building_with_azimuths(shared_dir: Path, tmp_path: Path) -> None:
    z = _real(shared_dir, "earthquakes", "nsmp1103_berkeley_building_2018-01-04.zip")
    assert main(["import", str(z), "--out", str(tmp_path / "b")]) == 0
    f = _first_modes(tmp_path / "b", tmp_path / "id", "--directions", "x,y")
    # output-only (the basement is fed back by the building): 1.023, 1.244 Hz; the plain
    # SSI-cov reference 1.025, 1.237, FDD 1.055, 1.25 (N4SID, the fixed base: 1.044, 1.265)
    np.testing.assert_allclose(f[:2], [1.03, 1.245], rtol=0.01)


def test_uff58b_record_gives_modes(shared_dir: Path, tmp_path: Path,
                                   capsys: pytest.CaptureFixture) -> None:
    u = _real(shared_dir, "uff", "accel_4ch_3200hz_uff58b.uff")
    geo = _real(shared_dir, "uff", "geometry_testlab_15_18_82_161_164.uff")
    assert main(["import", str(u), str(geo), "--out", str(tmp_path / "b")]) == 0
    cmap = json.loads((tmp_path / "b" / "channel_map.json").read_text())
    nodes = json.loads((tmp_path / "b" / f"{geo.stem}.json").read_text())["nodes"]
    c0 = cmap["channels"][0]
    assert (c0["node"], c0["direction"]) == ("1", "z")
    assert c0["position_m"] == nodes["1"]  # the sensor placed on the test geometry
    f = _first_modes(tmp_path / "b", tmp_path / "id", "--f-max", "400")
    assert f.size >= 1
    assert "ssi-cov on 0 inputs, 4 outputs" in capsys.readouterr().out
    assert np.min(np.abs(f - 182.3)) < 1.0  # the record's sharp, dominant peak


def test_bridge_updates_from_the_command_line(shared_dir: Path, tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    pre = "SteelPedestrianBridge__Experiment__Experiment_Model_Updating__"
    model = _real(shared_dir, "model_updating", pre + "SteelPedestrianBridgeExp.mat")
    modes = _real(shared_dir, "model_updating", pre + "ExpModeInfo_FEM.mat")
    rules = Path(__file__).resolve().parents[1] / "config" / "matrix_models" / \
        "pedestrian_bridge.yaml"  # the data set's parameter order and bounds (README)
    assert main(["update", str(model), "--rules", str(rules), "--modes", str(modes),
                 "--out", str(tmp_path)]) == 0
    rep = json.loads((tmp_path / "update_v1.json").read_text())
    assert max(abs(v) for v in rep["df_pct_after"]) <= 0.52  # bench_updating.py: 0.519
    assert min(rep["mac_after"]) >= 0.885
    out = capsys.readouterr().out
    assert "determined by the data: ['Frame', 'y1', 'y2']" in out
    # before and after for every mode: the nominal's unmatched modes 1 and 4 (outside the
    # 10 % window) at their nearest partner; known answer: the nominal model's own
    # frequencies (scipy on its matrices) over the identified ones
    import re

    import scipy.io as sio

    rows = {int(m[0]): m for m in re.findall(
        r"^\s+(\d) +([\d.]+) +(\d)([* ]) +(-?[\d.]+) +([\d.]+) +(\d)[* ] +(-?[\d.]+)", out,
        re.MULTILINE)}
    assert sorted(rows) == [1, 2, 3, 4, 5]  # no row without a partner
    assert [rows[k][3] for k in range(1, 6)] == ["*", " ", " ", "*", " "]
    d = sio.loadmat(model)
    k0 = sum(d[k] for k in d if k.startswith("K_") and k != "K_whole")  # K(theta = 0)
    mu = sla.eigh(d["M0"], k0, eigvals_only=True)[::-1][:8]  # 1 / omega^2, massless DOFs 0
    f_nom = 1.0 / np.sqrt(mu) / (2 * np.pi)
    for k in (1, 4):
        j, f_id = int(rows[k][2]) - 1, float(rows[k][1])
        assert float(rows[k][4]) == pytest.approx(100 * (f_nom[j] / f_id - 1), abs=2e-3)
    worst = max(abs(float(r[4])) for r in rows.values())
    assert f"before: max |df| {worst:.3f} %" in out and worst > 14.0


def test_identify_warnings_no_mode_and_non_stationary(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    frame = shear_frame_csv(tmp_path / "f.csv", seconds=60.0)
    roles = tmp_path / "roles.yaml"
    roles.write_text("channels:\n  - {name: ground, role: input}\n")
    assert main(["import", str(frame), "--map", str(roles), "--out", str(tmp_path / "n")]) == 0
    # a band below the first mode (3.97 Hz): nothing to find, and the command says so
    assert main(["identify", str(tmp_path / "n"), "--f-max", "3"]) == ExitCode.FAILED
    err = capsys.readouterr().err
    assert "warning: no mode found in 0.333-3 Hz" in err
    assert "--f-max" in err
    rows = np.loadtxt(frame, delimiter=",", skiprows=1)
    rows[:, 1:] *= np.exp(-rows[:, :1] / 8.0)  # a decaying, earthquake-like record
    burst = tmp_path / "burst.csv"
    np.savetxt(burst, rows, delimiter=",", comments="", fmt="%.9g",
               header="t [s],ground [m/s^2],floor1 [m/s^2],floor2 [g]")
    assert main(["import", str(burst), "--out", str(tmp_path / "b")]) == 0
    main(["identify", str(tmp_path / "b"), "--method", "ssi-cov"])
    assert "output-only SSI on a non-stationary record" in capsys.readouterr().err


def _f_in_page(page: str) -> np.ndarray:
    """The identified frequencies of the report's modes table (its second column)."""
    import re

    return np.array([float(x) for x in re.findall(r"<tr><td>[^<]*</td><td>([\d.]+)</td>",
                                                  page)])


def test_report_on_an_imported_record_and_an_identify_folder(
        frame: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Known answer: the frame's two frequencies, identified by the report itself on the
    imported bag (stabilization, modes, MAC, FRFs), and read from identify's folder."""
    out = tmp_path / "bag.html"
    assert main(["report", str(frame["bag"]), "--out", str(out)]) == 0
    page = out.read_text()
    for section in ("identification", "frf"):
        assert f'<section id="{section}">' in page
    np.testing.assert_allclose(_f_in_page(page), exact_f_hz(), rtol=0.01)
    assert page.count("data:image/png;base64,") == 3  # stabilization, MAC, FRF
    ident = tmp_path / "id.html"
    assert main(["report", str(frame["modes"].parent), "--out", str(ident)]) == 0
    page = ident.read_text()
    doc = json.loads(frame["modes"].read_text())
    np.testing.assert_allclose(_f_in_page(page), [m["f_hz"] for m in doc["modes"]],
                               atol=6e-5)
    assert page.count("data:image/png;base64,") == 3  # auto-MAC and identify's two PNGs


def test_report_shows_the_frfs_of_a_record_identified_output_only(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """The frame driven as much again by a base motion nobody measured: the ground channel
    explains half the response (< 0.8), the identification runs output-only, and the
    report still shows the H1 FRFs to the measured input; |H1| of the top floor peaks at
    the first frequency of the truth's matrices (to 2 %)."""
    from modal_twin.commands.report_record import _identified

    csv = shear_frame_csv(tmp_path / "frame.csv", unmeasured=1.0)
    roles = tmp_path / "roles.yaml"
    roles.write_text("channels:\n  - {name: ground, role: input}\n")
    assert main(["import", str(csv), "--map", str(roles), "--out", str(tmp_path / "bag")]) == 0
    notes: list[str] = []
    out, _ = _identified(tmp_path / "bag", notes)
    assert any("output-only" in n for n in notes)
    assert any("FRF: H1 of every output to the input ground (a measured input the "
               "output-only identification left out)" in n for n in notes)
    f, h, names, _ = out["frf"]
    assert names == ["floor1", "floor2"]
    np.testing.assert_allclose(f[np.argmax(np.abs(h[1]))], exact_f_hz()[0], rtol=0.02)
    page = tmp_path / "bag.html"
    assert main(["report", str(tmp_path / "bag"), "--out", str(page)]) == 0
    assert '<section id="frf">' in page.read_text()


def test_report_on_an_imported_uff_with_geometry_and_on_an_empty_folder(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from modal_twin.io.uff import write_uff55

    geo = {"nodes": {"1": [0.0, 0.0, 0.0], "2": [0.0, 0.0, 3.0], "3": [0.0, 0.0, 6.0]},
           "trace_lines": [{"number": 1, "id": "column", "nodes": [1, 2, 3]}]}
    uff = write_uff55(tmp_path / "tower.uff", np.array([1.25, 3.5]), np.array([0.01, 0.02]),
                      np.array([[0.5, 1.0], [1.0, -0.6]]), [2, 3], [1, 1],
                      names=["mid", "top"], geometry=geo)
    assert main(["import", str(uff), "--out", str(tmp_path / "tower")]) == 0
    out = tmp_path / "tower.html"
    assert main(["report", str(tmp_path / "tower"), "--out", str(out)]) == 0
    page = out.read_text()
    assert '<section id="scene">' in page and "MeshCat" in page
    assert "mode 2: 3.500 Hz" in html_unescape(page)  # the labelled mode on the geometry
    np.testing.assert_allclose(_f_in_page(page), [1.25, 3.5], rtol=1e-5)
    empty = tmp_path / "empty"
    empty.mkdir()
    capsys.readouterr()
    assert main(["report", str(empty)]) == ExitCode.USAGE
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "nothing to report" in err and "modes.json" in err
    assert not (empty / "report.html").exists()


def html_unescape(page: str) -> str:
    import html

    return html.unescape(html.unescape(page))  # the scene sits in an escaped srcdoc
