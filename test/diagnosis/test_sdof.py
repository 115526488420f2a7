"""Single-DOF diagnosis: classifier of the linear model's residual and Bouc-Wen fit.

Truth records are integrated by scipy's ``solve_ivp`` (an independent solver) with a
continuous multisine force; the displacement carries seeded white noise.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from modal_twin.diagnosis.restoring_force import (
    ResidualDiagnosis,
    bouc_wen_state,
    check_record,
    classify_residual,
    restoring_force_map,
    state_derivatives,
    stop_operator,
)
from modal_twin.diagnosis.sdof import (
    BoucWenSDOF,
    fit_bouc_wen_sdof,
    fit_linear_sdof,
    simulate_sdof,
)
from modal_twin.errors import ModelError, OptionError, ShapeError, SignalError

FS = 1000.0
NT = 3000
M, K = 1.0, 4.0e4  # f_n = 31.8 Hz
C = 2 * 0.02 * np.sqrt(K * M)
SIGMA = 2e-3  # displacement scale (about std(y) of the linear truth), m


def _force() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    f = np.arange(3.0, 80.0, 1.0 / 3.0)
    ph = rng.uniform(0, 2 * np.pi, f.size)
    amp = 20.0 * np.sqrt(2.0 / f.size)
    return f, ph, np.full(f.size, amp)


def _u(t: np.ndarray | float) -> np.ndarray:
    f, ph, amp = _force()
    return np.sum(amp[:, None] * np.sin(2 * np.pi * f[:, None] * np.atleast_1d(t) + ph[:, None]),
                  axis=0)


@cache
def truth(kind: str, noise: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """Return (u, y) sampled at FS for a known restoring-force law, y with seeded noise."""
    f, ph, amp = _force()
    k3 = 0.2 * K / SIGMA**2
    fc = 5.0  # Coulomb force, N
    k_lin, alpha, a, b = (0.5 * K, 0.5 * K, 0.6 / SIGMA, 0.4 / SIGMA)

    def rhs(t: float, x: np.ndarray) -> list[float]:
        u = float(np.sum(amp * np.sin(2 * np.pi * f * t + ph)))
        y, v, z = x
        if kind == "linear":
            r, dz = K * y, 0.0
        elif kind == "cubic":
            r, dz = K * y + k3 * y**3, 0.0
        elif kind == "coulomb":
            r, dz = K * y + fc * np.tanh(v / 1e-4), 0.0
        else:  # Bouc-Wen, nu = 1
            r, dz = k_lin * y + z, alpha * v - a * abs(v) * z - b * v * abs(z)
        return [v, (u - C * v - r) / M, dz]

    t = np.arange(NT) / FS
    sol = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0, 0.0], t_eval=t, method="LSODA",
                    rtol=1e-9, atol=[1e-12, 1e-10, 1e-8], max_step=1 / (4 * FS))
    y = sol.y[0]
    y = y + noise * np.std(y) * np.random.default_rng(11).standard_normal(NT)
    return _u(t), y


def diagnose(kind: str) -> ResidualDiagnosis:
    u, y = truth(kind)
    lin = fit_linear_sdof(u, y, FS).model
    rf = restoring_force_map(u, y, FS, m=lin.m, c=lin.c, k=lin.k, f_max_hz=150.0)
    return classify_residual(rf)


# --- classifier -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kind", "expected"),
    [("bouc_wen", "hysteresis"), ("cubic", "cubic_stiffness"), ("coulomb", "friction")],
)
def test_classifier_names_the_effect(kind: str, expected: str) -> None:
    dg = diagnose(kind)
    assert dg.top == expected, (dg.explained, dg.unique)
    assert dg.significant
    assert dg.ranking[0] == expected
    others = [dg.explained[g] for g in dg.explained if g != expected]
    assert dg.explained[expected] > max(0.3, 1.5 * max(others))


def test_classifier_says_nothing_for_linear_truth() -> None:
    dg = diagnose("linear")
    assert dg.top == "nothing significant", dg.explained
    assert not dg.significant
    assert max(dg.explained.values()) < dg.min_score


def test_descriptive_indices() -> None:
    # friction: positive jump at velocity reversal; cubic: odd in y
    assert diagnose("coulomb").jump_index > 0.5
    assert diagnose("cubic").odd_index > 0.3
    # Bouc-Wen against its true linear part: the residual z dissipates energy (a loop)
    u, y = truth("bouc_wen")
    rf = restoring_force_map(u, y, FS, m=M, c=C, k=0.5 * K, f_max_hz=150.0)
    assert classify_residual(rf).loop_energy_ratio > 0.5
    # the linear truth against itself: no loop, no jump
    u, y = truth("linear")
    dg = classify_residual(restoring_force_map(u, y, FS, m=M, c=C, k=K, f_max_hz=150.0))
    assert abs(dg.loop_energy_ratio) < 0.05
    assert abs(dg.jump_index) < 0.3


def test_error_surface_eq20_is_normalised() -> None:
    u, y = truth("cubic")
    rf = restoring_force_map(u, y, FS, m=M, c=C, k=K, f_max_hz=150.0, n_bins=11)
    assert rf.surface.shape == (11, 11)
    np.testing.assert_allclose(rf.e_norm, rf.e / (K * np.max(np.abs(rf.y))))
    # residual of the true linear part is the cubic force k3 y^3 (up to noise and filter)
    k3 = 0.2 * K / SIGMA**2
    cub = k3 * rf.y**3
    assert np.std(rf.e - cub) < 0.15 * np.std(cub)


# --- simulation and fits ----------------------------------------------------------------


def test_simulator_matches_solve_ivp() -> None:
    u, y = truth("bouc_wen", noise=0.0)
    model = BoucWenSDOF(M, C, 0.5 * K, 0.5 * K, 0.6 / SIGMA, 0.4 / SIGMA)
    ys = simulate_sdof(model, u, FS, oversample=10)
    assert np.sqrt(np.mean((ys - y) ** 2)) < 2e-4 * np.std(y)


def test_linear_fit_recovers_m_c_k() -> None:
    u, y = truth("linear")
    fit = fit_linear_sdof(u, y, FS)
    np.testing.assert_allclose([fit.model.m, fit.model.c, fit.model.k], [M, C, K], rtol=0.02)
    assert fit.nrmse < 0.02  # noise is 1 % of std(y)
    assert fit.converged


def test_bouc_wen_fit_recovers_parameters() -> None:
    u, y = truth("bouc_wen")
    fit = fit_bouc_wen_sdof(u, y, FS, f_max_hz=150.0)
    true = [M, C, 0.5 * K, 0.5 * K, 0.6 / SIGMA, 0.4 / SIGMA]
    np.testing.assert_allclose(fit.model.vector(), true, rtol=0.05)
    assert fit.nrmse < 0.015
    assert fit.std.shape == (6,)
    assert np.all(fit.std < 0.05 * np.abs(true))


def test_periodic_simulation_is_steady_state() -> None:
    # a linear SDOF under one multisine period: the FRF gives the steady state exactly
    n = 1000
    rng = np.random.default_rng(3)
    U = np.zeros(n // 2 + 1, complex)
    U[3:60] = np.exp(2j * np.pi * rng.uniform(size=57))
    u = np.fft.irfft(U, n) * 200.0
    w = 2 * np.pi * np.fft.rfftfreq(n, 1 / FS)
    y_ref = np.fft.irfft(np.fft.rfft(u) / (K - M * w**2 + 1j * C * w), n)
    ys = simulate_sdof(BoucWenSDOF(M, C, K), u, FS, period=n, oversample=10)
    # one warm-up period (1 s) leaves exp(-zeta w_n t) ~ 2e-2 of the transient
    assert np.sqrt(np.mean((ys - y_ref) ** 2)) < 0.05 * np.std(y_ref)


def test_operators_known_answers() -> None:
    y = np.array([0.0, 1.0, 3.0, 2.0, -2.0])
    np.testing.assert_allclose(stop_operator(y, 1.5), [0.0, 1.0, 1.5, 0.5, -1.5])
    # nu = 1, a = b = 0: the state is the displacement itself
    np.testing.assert_allclose(bouc_wen_state(y, 0.0, 0.0), y)
    # loading from rest: w = (1 - exp(-(a + b) y)) / (a + b)
    yy = np.linspace(0, 2e-3, 200)
    np.testing.assert_allclose(bouc_wen_state(yy, 300.0, 200.0)[-1],
                               (1 - np.exp(-500 * 2e-3)) / 500, rtol=1e-8)
    # spectral derivatives of a periodic sine
    t = np.arange(500) / 500.0
    x, v, a = state_derivatives(np.sin(2 * np.pi * 5 * t), 500.0, periodic=True)
    np.testing.assert_allclose(v, 2 * np.pi * 5 * np.cos(2 * np.pi * 5 * t), atol=1e-9)
    np.testing.assert_allclose(a, -(2 * np.pi * 5) ** 2 * x, atol=1e-7)


# --- bad input --------------------------------------------------------------------------


def test_bad_records() -> None:
    u, y = truth("linear")
    with pytest.raises(ShapeError, match=r"u, y: expected equal lengths, got 3000 and 2999"):
        fit_linear_sdof(u, y[:-1], FS)
    yn = y.copy()
    yn[17] = np.nan
    with pytest.raises(SignalError, match=r"y: expected finite samples, got nan at index 17"):
        fit_bouc_wen_sdof(u, yn, FS)
    with pytest.raises(ShapeError, match=r"expected at least 64 samples, got 10"):
        fit_linear_sdof(u[:10], y[:10], FS)
    with pytest.raises(ShapeError, match=r"u: expected one channel"):
        check_record(np.ones((2, 100)), np.ones(100), FS)
    with pytest.raises(SignalError, match=r"fs_hz: expected a positive finite"):
        check_record(u, y, -1.0)


def test_bad_options() -> None:
    u, y = truth("linear")
    with pytest.raises(OptionError, match=r"period: expected a divisor of the record length"):
        fit_linear_sdof(u, y, FS, period=7)
    with pytest.raises(OptionError, match=r"period: expected a divisor"):
        restoring_force_map(u, y, FS, m=M, c=C, k=K, period=7)
    with pytest.raises(OptionError, match=r"oversample: expected an integer >= 1"):
        simulate_sdof(BoucWenSDOF(M, C, K), u, FS, oversample=0)
    with pytest.raises(OptionError, match=r"f_max_hz: expected 0 < f_max_hz"):
        state_derivatives(y, FS, f_max_hz=600.0)
    rf = restoring_force_map(u, y, FS, m=M, c=C, k=K)
    with pytest.raises(OptionError, match=r"min_score: expected a fraction in \(0, 1\)"):
        classify_residual(rf, min_score=1.5)
    with pytest.raises(OptionError, match=r"r: expected a positive yield"):
        stop_operator(y, 0.0)
    with pytest.raises(OptionError, match=r"nu: expected nu >= 1"):
        bouc_wen_state(y, 1.0, 1.0, nu=0.5)


def test_bad_models() -> None:
    u, y = truth("linear")
    with pytest.raises(ModelError, match=r"m, c, k, alpha: expected m > 0"):
        BoucWenSDOF(-1.0, C, K)
    with pytest.raises(ModelError, match=r"nu: expected nu >= 1"):
        BoucWenSDOF(M, C, K, nu=0.5)
    with pytest.raises(ModelError, match=r"m, k: expected positive mass and stiffness"):
        restoring_force_map(u, y, FS, m=0.0, c=C, k=K)
    # force and displacement unrelated: the equation-error start has a negative mass
    rng = np.random.default_rng(5)
    with pytest.raises(ModelError, match=r"equation-error start has m="):
        fit_linear_sdof(rng.standard_normal(500), -np.cumsum(rng.standard_normal(500)) * 0, FS)


def test_unstable_candidate_does_not_crash() -> None:
    # a strongly hardening start (a + b < 0) runs away: the simulation stops at the limit
    u, _ = truth("linear")
    ys = simulate_sdof(BoucWenSDOF(M, C, K, 10 * K, -5e4, -5e4), 50 * u, FS, y_limit=1.0)
    assert np.all(np.isfinite(ys))
    assert ys[-1] == 1.0


# --- the external benchmark data, when present ------------------------------------------

DATA = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "boucwen"


def test_benchmark_train_names_hysteresis() -> None:
    h5py = pytest.importorskip("h5py")
    if not (DATA / "train.h5").is_file():
        pytest.skip(f"Bouc-Wen benchmark data not found in {DATA}")
    with h5py.File(DATA / "train.h5", "r") as h:
        u = np.asarray(h["multisine/u"][()], float).ravel()
        y = np.asarray(h["multisine/y"][()], float).ravel()
    lin = fit_linear_sdof(u, y, 750.0, period=8192)
    # the best linear SDOF errs by ~1.8e-4 m (benchmark README)
    assert 1.5e-4 < lin.rmse_m < 2.2e-4
    m = lin.model
    rf = restoring_force_map(u, y, 750.0, m=m.m, c=m.c, k=m.k, period=8192, f_max_hz=200.0)
    dg = classify_residual(rf)
    assert dg.top == "hysteresis"
    assert dg.explained["hysteresis"] > 0.8


# --- modal-twin sdof RECORD ---------------------------------------------------------------


def _sdof_cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from modal_twin.cli import main

    rc = main(["sdof", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def _write_csv(path: Path, cols: dict[str, np.ndarray]) -> Path:
    t = np.arange(next(iter(cols.values())).size) / FS
    np.savetxt(path, np.column_stack([t, *cols.values()]), delimiter=",",
               header=",".join(["t [s]", *cols]), comments="")
    return path


def test_sdof_command_names_hysteresis_and_recovers_bouc_wen(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # truth: solve_ivp (independent of the library's RK4) with known parameters, 1 % noise
    u, y = truth("bouc_wen")
    csv = _write_csv(tmp_path / "bw.csv", {"F [N]": u, "y [mm]": 1e3 * y})
    rc, out, _ = _sdof_cli([str(csv), "--f-max", "150", "--json", str(tmp_path / "s.json"),
                            "--out", str(tmp_path / "out")], capsys)
    assert rc == 0
    assert "bw.csv: force F, response y" in out
    assert "-> effect: hysteresis" in out
    d = json.loads((tmp_path / "s.json").read_text())
    assert d["classifier"]["top"] == "hysteresis"
    assert d["classifier"]["explained"]["hysteresis"] > 0.3
    bw = d["bouc_wen"]["parameters"]
    true = {"m": M, "c": C, "k": 0.5 * K, "alpha": 0.5 * K, "a": 0.6 / SIGMA, "b": 0.4 / SIGMA}
    for name, v in true.items():  # the tolerance of test_bouc_wen_fit_recovers_parameters
        assert bw[name] == pytest.approx(v, rel=0.05), name
    assert d["bouc_wen"]["nrmse"] < 0.015 < d["linear"]["nrmse"]
    assert json.loads((tmp_path / "out" / "sdof.json").read_text()) == d
    with np.load(tmp_path / "out" / "sdof_map.npz") as z:
        assert np.sqrt(np.mean((z["y_bouc_wen"] - y) ** 2)) == pytest.approx(
            d["bouc_wen"]["rmse_m"], rel=1e-6)


def test_sdof_command_acceleration_of_a_linear_steady_state(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a linear SDOF in steady state under a multisine: the FRF gives the response exactly
    n, reps = 4000, 2
    rng = np.random.default_rng(3)
    U = np.zeros(n // 2 + 1, complex)
    U[12:320] = np.exp(2j * np.pi * rng.uniform(size=308))  # 3-80 Hz
    u = np.fft.irfft(U, n) * 400.0
    w = 2 * np.pi * np.fft.rfftfreq(n, 1 / FS)
    acc = np.fft.irfft(-(w**2) * np.fft.rfft(u) / (K - M * w**2 + 1j * C * w), n)
    acc = np.tile(acc, reps)
    acc += 0.01 * np.std(acc) * np.random.default_rng(4).standard_normal(acc.size)
    npz = tmp_path / "lin.npz"
    np.savez(npz, data=np.vstack([np.tile(u, reps), acc / 9.80665]), fs_hz=FS,
             names=np.array(["hammer", "acc"]), units=np.array(["N", "g"]),
             roles=np.array(["input", "output"]))
    rc, out, _ = _sdof_cli([str(npz), "--period", str(n), "--json",
                            str(tmp_path / "s.json")], capsys)
    assert rc == 0
    assert "acceleration integrated above 3 Hz" in out  # the force band starts at 3 Hz
    d = json.loads((tmp_path / "s.json").read_text())
    assert d["response_quantity"] == "acceleration"
    assert d["classifier"]["top"] == "nothing significant"
    assert not d["classifier"]["significant"]
    lin = d["linear"]["parameters"]
    np.testing.assert_allclose([lin["m"], lin["c"], lin["k"]], [M, C, K], rtol=0.01)


def test_sdof_command_reads_a_mat_record_by_variable_names(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from scipy.io import savemat

    u, y = truth("linear")
    mat = tmp_path / "uval.mat"
    savemat(mat, {"uval": u[:, None], "yval": y[:, None]})
    names = ["--force-channel", "uval", "--response-channel", "yval"]
    rc, _, err = _sdof_cli([str(mat), *names], capsys)
    assert rc == 2 and "no sample rate variable 'fs'; give --fs" in err
    rc, out, _ = _sdof_cli([str(mat), *names, "--fs", str(FS), "--json", str(tmp_path / "s.json")],
                           capsys)
    assert rc == 0 and "uval.mat: force uval, response yval; 3000 samples" in out
    d = json.loads((tmp_path / "s.json").read_text())
    assert d["classifier"]["top"] == "nothing significant"
    lin = d["linear"]["parameters"]  # the tolerance of test_linear_fit_recovers_m_c_k
    np.testing.assert_allclose([lin["m"], lin["c"], lin["k"]], [M, C, K], rtol=0.02)
    assert d["linear"]["nrmse"] < 0.02


def test_sdof_command_bad_input_is_one_line(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    u, y = truth("linear")
    two = _write_csv(tmp_path / "two.csv", {"F1 [N]": u, "F2 [N]": u, "y [m]": y})
    nan = y.copy()
    nan[5] = np.nan
    cases = {
        str(tmp_path / "none.csv"): "no such record",
        str(two): "2 channels could be the force (['F1', 'F2']); name one with --force-channel",
        str(_write_csv(tmp_path / "nan.csv", {"F [N]": u, "y [m]": nan})):
            "expected finite samples",
        str(_write_csv(tmp_path / "short.csv", {"F [N]": u[:20], "y [m]": y[:20]})):
            "expected at least 64 samples",
        str(tmp_path / "rec.txt"): "unknown record kind '.txt'",
    }
    (tmp_path / "rec.txt").write_text("1 2\n")
    for rec, words in cases.items():
        rc, _, err = _sdof_cli([rec], capsys)
        assert rc == 2, rec
        lines = err.strip().splitlines()
        assert len(lines) == 1 and words in lines[0], err
    rc, _, err = _sdof_cli([str(two), "--force-channel", "F1", "--period", "7"], capsys)
    assert rc == 2 and "period: expected a divisor" in err
    (tmp_path / "s.json").write_text("{}")
    rc, _, err = _sdof_cli([str(two), "--force-channel", "F1", "--json",
                            str(tmp_path / "s.json")], capsys)
    assert rc == 2 and "exists; give --force to overwrite it" in err
    assert (tmp_path / "s.json").read_text() == "{}"
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "r.h5", "w") as h:
        h["run/u"], h["run/y"], h["run/fs"] = u, y, [FS]
    rc, _, err = _sdof_cli([f"{tmp_path / 'r.h5'}:other"], capsys)
    assert rc == 2 and "no group 'other'; groups with ['u', 'y']: ['run']" in err


def test_sdof_command_on_the_benchmark_gives_the_readme_figures(
        shared_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("h5py")
    data = shared_dir / "benchmarks" / "boucwen"
    if not (data / "train.h5").is_file() or not (data / "test.h5").is_file():
        pytest.skip(f"Bouc-Wen benchmark data not found in {data}")
    rc, _, _ = _sdof_cli([str(data / "train.h5"), "--period", "8192", "--f-max", "200",
                            "--test", f"{data / 'test.h5'}:multisine",
                            "--test", f"{data / 'test.h5'}:sinesweep",
                            "--json", str(tmp_path / "s.json")], capsys)
    assert rc == 0
    d = json.loads((tmp_path / "s.json").read_text())
    assert d["classifier"]["top"] == "hysteresis"
    assert 1.5e-4 < d["linear"]["rmse_m"] < 2.2e-4  # the best linear SDOF: ~1.8e-4 m (README)
    ms, sw = d["tests"]
    assert ms["steady_state"] and not sw["steady_state"]
    # README, bench_boucwen.py: multisine RMS error 1.7e-7 m, sine sweep 2.3e-6 m
    assert f"{ms['rmse_bouc_wen_m']:.1e}" == "1.7e-07"
    assert f"{sw['rmse_bouc_wen_m']:.1e}" == "2.3e-06"
    bw = d["bouc_wen"]["parameters"]  # the benchmark's published system (its README)
    true = {"m": 2.0, "c": 10.0, "k": 5e4, "alpha": 5e4, "a": 800.0, "b": -1100.0}
    for name, v in true.items():
        assert bw[name] == pytest.approx(v, rel=0.01), name
