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


def test_a_mode_missing_from_one_setup_is_kept_with_the_setups_that_saw_it() -> None:
    rng = np.random.default_rng(1)
    parts, phi = setups(rng)
    p = parts[1]
    parts[1] = SetupModes(p.channels, p.f_hz[[0, 1, 3]], p.zeta[[0, 1, 3]],
                          p.shapes[:, [0, 1, 3]])
    merged = merge_setups(parts, ["p0", "p7"])
    assert merged.f_hz.size == 4
    assert merged.seen_in == ((0, 1, 2), (0, 1, 2), (0, 2), (0, 1, 2))
    assert merged.complete().tolist() == [True, True, False, True]
    order = [merged.channels.index(f"p{i}") for i in range(8)]
    full = merged.shapes[order]
    # setup 2's rovers p3, p4 are empty in mode 3, not zero; the rest is the truth
    assert np.flatnonzero(~np.isfinite(full[:, 2])).tolist() == [3, 4]
    seen = np.isfinite(full[:, 2])
    assert mac(full[seen, 2:3], phi[seen, 2:3])[0, 0] == pytest.approx(1.0, abs=1e-10)
    assert np.isnan(merged.ref_mac[2, 1]) and merged.ref_mac[2, 2] > 0.999


def fixed_fixed_chain(n: int = 8, k: float = 1e5, m: float = 1.0
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Closed form of n equal masses between two walls: f_r = sqrt(k / m) sin(r pi /
    (2 (n + 1))) / pi, shapes sin(j r pi / (n + 1)), j = 1..n."""
    r = np.arange(1, n + 1)
    f = np.sqrt(k / m) * np.sin(r * np.pi / (2 * (n + 1))) / np.pi
    return f, np.sin(np.outer(np.arange(1, n + 1), r) * np.pi / (n + 1))


def test_a_mode_unseen_by_the_first_setup_is_merged_from_the_others() -> None:
    """Mode 3 of an 8-mass chain between walls has nodes at masses 3 and 6 (sin(j pi / 3)
    = 0): setup 1 roves exactly there, so its identification misses the mode (its
    references at masses 1 and 8 see it at 0.87 of the peak). Setups 2 and 3 see it; PoSER
    through the references gives it from them, its entries at masses 3 and 6 unmeasured.
    Known answer: the closed-form frequencies and shapes (MAC 1 on the measured entries)."""
    f, phi = fixed_fixed_chain()
    assert np.abs(phi[[2, 5], 2]).max() < 1e-12  # the nodes of mode 3
    rng = np.random.default_rng(5)
    groups = [[0, 7, 2, 5], [0, 7, 1, 3, 4], [0, 7, 6]]  # masses (0-based); refs 0 and 7
    kept = [[0, 1, 3], [0, 1, 2, 3], [0, 1, 2, 3]]       # setup 1 misses mode 3
    parts = []
    for g, modes in zip(groups, kept, strict=True):
        scale = rng.standard_normal(len(modes)) + 1j * rng.standard_normal(len(modes))
        parts.append(SetupModes(tuple(f"m{i + 1}" for i in g), f[modes], np.full(len(modes),
                                0.01), phi[np.ix_(g, modes)] * scale))
    merged = merge_setups(parts, ["m1", "m8"])
    np.testing.assert_allclose(merged.f_hz, f[:4], rtol=1e-12)
    assert merged.seen_in == ((0, 1, 2), (0, 1, 2), (1, 2), (0, 1, 2))
    order = [merged.channels.index(f"m{i + 1}") for i in range(8)]
    full = merged.shapes[order]
    assert np.flatnonzero(~np.isfinite(full[:, 2])).tolist() == [2, 5]  # empty, not 0
    assert np.all(np.isfinite(full[:, [0, 1, 3]]))
    seen = np.isfinite(full[:, 2])
    assert mac(full[seen, 2:3], phi[seen, 2:3])[0, 0] == pytest.approx(1.0, abs=1e-10)
    assert np.diag(mac(full[:, [0, 1, 3]], phi[:, [0, 1, 3]])) == pytest.approx(
        np.ones(3), abs=1e-10)


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


def test_mac_measured_leaves_out_the_unmeasured_entries() -> None:
    from modal_twin.identification.metrics import mac_measured

    a = np.array([[1.0, 1.0], [np.nan, 2.0], [3.0, np.nan]])
    b = np.array([[2.0], [5.0], [6.0]])
    got = mac_measured(a, b)
    np.testing.assert_allclose(got, [[mac([1.0, 3.0], [2.0, 6.0])[0, 0]],
                                     [mac([1.0, 2.0], [2.0, 5.0])[0, 0]]])
    assert got[0, 0] == pytest.approx(1.0) and got[1, 0] == pytest.approx(144 / 145)
    assert np.isnan(mac_measured(np.array([np.nan, 1.0]), np.array([1.0, np.nan]))[0, 0])
