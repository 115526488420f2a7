"""The twin's block products (inputs before the per-sample loop, outputs after it) against a
per-sample numpy restatement of the same scheme (every projection inside the loop, as the
kernel did before the inputs left it), on bench_twin's building well past its isolators'
yield."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from modal_twin.twin.kernels import project_inputs
from modal_twin.twin.simulator import Simulator

_BENCH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_twin.py"


@pytest.fixture(scope="module")
def bench():
    """bench_twin as a module (its building and its per-sample numpy reference)."""
    spec = importlib.util.spec_from_file_location("bench_twin_for_test", _BENCH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _record(nt: int, gain: float) -> np.ndarray:
    rng = np.random.default_rng(7)
    scale = np.array([[1.5], [1.5], [0.5], [0.05], [0.05], [0.05]])
    return gain * rng.standard_normal((6, nt)) * scale


def test_block_products_equal_per_sample_reference(bench) -> None:
    ag = _record(1201, 8.0)
    sim = Simulator(bench.building(), 1e-3, modal_histories=False)
    res = sim.step_block(ag)
    ref_u, ref_y = bench.numpy_reference(sim, ag)
    ref_u = ref_u[sim._row_index]
    # the isolators are driven past their yield: Bouc-Wen and bilinear branches matter
    assert np.abs(res.drift).max() > 0.1  # 0.33 m; RB yield drift 0.0258 m (Table 10 of [004])
    for got, ref in ((res.drift, ref_u), (res.y, ref_y)):
        assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()  # ~2e-15 measured


def test_input_products_do_not_depend_on_the_split(bench) -> None:
    ag = _record(2051, 1.0)
    sim = Simulator(bench.building(), 1e-3)
    m = sim._PinT.shape[1]
    one = np.empty((ag.shape[1], m))
    project_inputs(ag, 0, ag.shape[1], sim._PinT, one)
    parts = np.empty_like(one)
    for k0, k1 in ((0, 1), (1, 3), (3, 1027), (1027, 2051)):
        project_inputs(ag, k0, k1, sim._PinT, parts[k0:k1])
    np.testing.assert_array_equal(parts, one)
    # and they are the projections they stand for: [E1 Ga; E0 Ga] a_k, Ua1 a_k, Ua0 a_k
    ns = sim._ns
    e0 = sim._coef[2] + 1j * sim._coef[3]
    e1 = sim._coef[4] + 1j * sim._coef[5]
    Ga = sim._GaT.T[:ns] + 1j * sim._GaT.T[ns:]
    k = 1500
    g = Ga @ ag[:, k]
    want = np.concatenate([(e1 * g).real, (e1 * g).imag, (e0 * g).real, (e0 * g).imag,
                           sim._Ua1T.T @ ag[:, k], sim._Ua0T.T @ ag[:, k]])
    np.testing.assert_allclose(one[k], want, rtol=0, atol=1e-13 * np.abs(want).max())
