"""Several setups merged into one set of shapes (issue 22, item 6): a chain of eight masses
measured in three setups with two reference sensors, each setup's shapes scaled at random."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg

from modal_twin.errors import SignalError
from modal_twin.identification.metrics import mac
from modal_twin.identification.setups import SetupModes, cross_mac, merge_setups


def chain(n: int = 8) -> tuple[np.ndarray, np.ndarray]:
    k = 1e5 * (np.diag([2.0] * n) - np.diag([1.0] * (n - 1), 1) - np.diag([1.0] * (n - 1), -1))
    k[-1, -1] = 1e5
    w2, phi = linalg.eigh(k, np.eye(n))
    return np.sqrt(w2) / (2 * np.pi), phi


def setups(rng: np.random.Generator, n_modes: int = 4) -> tuple[list[SetupModes], np.ndarray]:
    f, phi = chain()
    names = [f"p{i}" for i in range(8)]
    groups = [[0, 1, 2, 7], [3, 4, 7, 0], [5, 6, 0, 7]]  # references p0 and p7 in all
    out = []
    for g in groups:
        scale = rng.standard_normal(n_modes) + 1j * rng.standard_normal(n_modes)
        shapes = phi[g, :n_modes] * scale[None, :]
        # each setup identifies slightly different frequencies and damping
        out.append(SetupModes(tuple(names[i] for i in g),
                              f[:n_modes] * (1 + 0.002 * rng.standard_normal(n_modes)),
                              0.01 + 0.001 * rng.standard_normal(n_modes), shapes))
    return out, phi[:, :n_modes]


def test_poser_recovers_the_full_shapes() -> None:
    rng = np.random.default_rng(0)
    parts, phi = setups(rng)
    merged = merge_setups(parts, ["p0", "p7"])
    order = [merged.channels.index(f"p{i}") for i in range(8)]
    full = merged.shapes[order]
    assert np.diag(mac(full, phi)) == pytest.approx(np.ones(4), abs=1e-10)
    f, _ = chain()
    np.testing.assert_allclose(merged.f_hz, f[:4], rtol=0.005)
    assert np.all(merged.f_spread_hz < 0.02 * merged.f_hz)
    assert merged.ref_mac.shape == (4, 3) and np.all(merged.ref_mac > 0.999)


def test_a_mode_missing_from_one_setup_is_left_out() -> None:
    rng = np.random.default_rng(1)
    parts, _ = setups(rng)
    p = parts[1]
    parts[1] = SetupModes(p.channels, p.f_hz[[0, 1, 3]], p.zeta[[0, 1, 3]],
                          p.shapes[:, [0, 1, 3]])
    merged = merge_setups(parts, ["p0", "p7"])
    assert merged.f_hz.size == 3


def test_cross_mac_on_the_common_channels_is_diagonal() -> None:
    rng = np.random.default_rng(2)
    parts, _ = setups(rng)
    cm = cross_mac(parts[0], parts[1])  # common: p0, p7 only
    assert cm.shape == (4, 4)
    assert np.all(np.diag(cm) > 0.999)


def test_a_setup_without_the_references_is_refused() -> None:
    rng = np.random.default_rng(3)
    parts, _ = setups(rng)
    with pytest.raises(SignalError, match="lacks reference channels"):
        merge_setups(parts, ["p0", "p5"])
