"""Global search and multi-start give identical results on every executor (issue 14 item 3)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from modal_twin.executors import make_executor
from modal_twin.models.fe import solve_modes
from modal_twin.updating.optimize import global_search, multi_start, update
from modal_twin.updating.problem import ModeTargets, UpdatingProblem

K_TRUE = np.array([1.3e6, 0.8e6, 1.1e6])  # N/m, the three springs of the chain


def chain():
    """Fixed-free chain of four 1000 kg masses; spring i joins mass i-1 (or ground) and i."""
    dK = []
    for i in range(3):
        d = np.zeros((4, 4))
        d[i, i] += 1.0
        if i > 0:
            d[i - 1, i - 1] += 1.0
            d[i - 1, i] = d[i, i - 1] = -1.0
        dK.append(sp.csr_matrix(d))
    d4 = np.zeros((4, 4))
    d4[2:, 2:] = [[1.0, -1.0], [-1.0, 1.0]]
    K0 = sp.csr_matrix(1e6 * d4)
    return K0, sp.identity(4, format="csr") * 1000.0, dK


@pytest.fixture(scope="module")
def problem():
    K0, M, dK = chain()
    K = K0 + sum(k * d for k, d in zip(K_TRUE, dK, strict=True))
    s = solve_modes(K, M, 4)
    t = ModeTargets.create(s.f_hz, s.Phi)
    theta0 = np.full(3, 1.0e6)
    K_nominal = K0 + sum(k * d for k, d in zip(theta0, dK, strict=True))  # K(theta0)
    return UpdatingProblem(K_nominal, M, dK, None, theta0, ("k1", "k2", "k3"),
                           np.full(3, 0.4e6), np.full(3, 2.0e6), np.arange(4), t)


def runs(problem, spec):
    g = global_search(problem, maxiter=6, popsize=6, seed=5, executor=spec)
    m = multi_start(problem, np.full((1, 3), 1.0e6), n_random=4, seed=5, executor=spec,
                    max_nfev=20)
    return g, m


def test_identical_serial_pool_and_dask_cluster(problem):
    serial = runs(problem, 1)
    pool = runs(problem, 2)
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        dask = runs(problem, client.get_executor())
    for other in (pool, dask):
        np.testing.assert_array_equal(other[0][0], serial[0][0])
        assert other[0][1:] == serial[0][1:]
        np.testing.assert_array_equal(other[1][0], serial[1][0])
        assert other[1][1:] == serial[1][1:]
    # the multi-start finds the truth (the chain's stiffnesses are determined by 4 modes)
    np.testing.assert_allclose(serial[1][0], K_TRUE, rtol=1e-6)


def test_update_with_multi_start_on_a_pool(problem):
    with make_executor(2) as ex:
        res = update(problem, maxiter=4, popsize=5, seed=1, executor=ex, n_starts=3)
    np.testing.assert_allclose(res.theta, K_TRUE, rtol=1e-6)
    assert "multi-start: 4 starts" in res.message
    assert res.n_eigen_solves >= res.n_global_evals > 0
