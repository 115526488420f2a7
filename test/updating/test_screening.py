from __future__ import annotations

import numpy as np
import pytest

from modal_twin.errors import OptionError
from modal_twin.updating.screening import cluster_parameters, lhs_spearman


def chain_f(theta: np.ndarray) -> np.ndarray:
    """3-DOF spring chain, unit masses, springs k1..k3 plus a useless fourth parameter."""
    k1, k2, k3, _ = theta
    K = np.array([[k1 + k2, -k2, 0], [-k2, k2 + k3, -k3], [0, -k3, k3]])
    return np.sqrt(np.linalg.eigvalsh(K)) / (2 * np.pi)


def test_spearman_ranks_the_influential_parameters() -> None:
    names = ("k1", "k2", "k3", "nothing")
    r = lhs_spearman(chain_f, names, np.full(4, 0.5), np.full(4, 2.0), n_samples=80)
    assert r.rho.shape == (3, 4)
    assert np.all(np.abs(r.rho) <= 1.0)
    assert np.max(np.abs(r.rho[:, 3])) < 0.3  # the dummy correlates with nothing
    assert set(r.influential(0.3)) == {"k1", "k2", "k3"}
    # the lowest mode of a chain fixed at k1 is most sensitive to k1
    assert int(np.argmax(r.rho[0, :3])) == 0
    with pytest.raises(OptionError, match="expected finite lower < upper"):
        lhs_spearman(chain_f, names, np.ones(4), np.ones(4))


def test_case_iii_clustering_drops_and_groups() -> None:
    def f(theta: np.ndarray) -> np.ndarray:
        a, b, c, d = theta  # a and b act identically, d not at all
        return chain_f(np.array([a * b, c, 1.0, 0.0])) * (1 + 0 * d)

    out = cluster_parameters(f, ("a", "b", "c", "d"), np.array([1.0, 1.0, 1.0, 1.0]))
    assert out.dropped == ("d",)
    groups = out.groups()
    assert ("a", "b") in groups and ("c",) in groups
