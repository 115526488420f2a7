"""The twin's outputs are those it gave before its kernel's arrays were grouped (issue 19).

A base-isolated building (3 base modes without linear stiffness, 9 flexible modes) stands
on one isolator of every law of the device registry; a fixed random table input drives
every law into its nonlinear range (peak drift ~0.1 m) and the Newton correction on most
samples. The figures below are what the kernel gave at commit e45ae40, before
``run_block`` took its arrays in typed groups (LoopMatrices, DeviceArrays, LoopState,
BlockRows) and dispatched every kind explicitly: a weighted sum and the sum of squares of
each output, and the total count of law evaluations. Measured after the change: bitwise
equal; the tolerance, 1e-12, leaves room for a cold numba compile contracting a
multiply-add differently (see test_simulator.py).
"""

from __future__ import annotations

import numpy as np
import pytest

from modal_twin.models.devices.registry import LAWS, Site, build_device, build_effect_device
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.twin.simulator import Simulator

# the registry's laws at commit e45ae40, whose building the digests below are of (the laws
# added since, maxwell, smooth_bilinear and iwan, are run through the kernel by
# test_kernel_laws.py; iwan's closed forms by test_iwan.py)
_LAWS_THEN = tuple(law for law in LAWS if law not in ("maxwell", "smooth_bilinear", "iwan"))
# law -> absolute params for the laws without a relative form
_ABSOLUTE = {"bouc_wen_esb": {"A": 1.0, "beta": 555.0, "gamma": 555.0},
             "prandtl": {"Fs": 5.0e3, "Kb": 1.0e6}}
# modal_histories -> {output: (weighted sum, sum of |terms|, sum of squares)}, "evals": law
# evaluations; printed by `python test/twin/test_twin_regression.py` (at commit e45ae40)
_BEFORE = {
    False: {
        "y": (135.64428512510472, 86119.43949039439, 632279.3569191527),
        "drift": (9.436096317864422, 941.9434757671138, 31.81258236510766),
        "force": (13610314.68993005, 1049853431.6477182, 44493538109007.7),
        "evals": 7973,
    },
    True: {
        "y": (135.6442851251046, 86119.43949039439, 632279.3569191527),
        "drift": (9.436096317864422, 941.9434757671138, 31.81258236510766),
        "force": (13610314.68993005, 1049853431.6477182, 44493538109007.7),
        "q": (1539.158810484432, 118285.62539391327, 2744396.888922475),
        "qd": (-4431.942402581722, 502738.7141567877, 24783168.06742069),
        "qdd": (44440.93069026369, 28900119.84649735, 71541741587.83014),
        "evals": 7973,
    },
}


def _every_law_building() -> ReducedSystem:
    rng = np.random.default_rng(3)
    n, m_tot = 12, 686e3
    J = m_tot * (10.0**2 + 12.0**2) / 12.0
    w = 2 * np.pi * np.concatenate([[0.0, 0.0, 0.0], np.geomspace(2.0, 30.0, n - 3)])
    att = []
    for i, law in enumerate(_LAWS_THEN):
        # regularised_friction keeps c_factor of each direction's dashpot since session 9
        # (b5615fe; of their mean before): its site's dashpot is the mean in both directions,
        # so that its device is the one of e45ae40 (test_kernel_laws.py runs it anisotropic)
        c = np.full(2, 1.5e3) if law == "regularised_friction" else np.array([1.0e3, 2.0e3])
        site = Site(f"D{i}", np.array([1.0e6, 1.4e6]), c, 1.0e6)
        dev = (build_device(law, _ABSOLUTE[law], site) if law in _ABSOLUTE
               else build_effect_device(law, {}, site))
        px, py = rng.uniform(-5, 5), rng.uniform(-6, 6)
        B = np.zeros((2, n))
        B[0, 0] = B[1, 1] = 1 / np.sqrt(m_tot)
        B[0, 2], B[1, 2] = -py / np.sqrt(J), px / np.sqrt(J)
        B[:, 3:] = 0.05 * rng.standard_normal((2, n - 3)) / np.sqrt(m_tot)
        att.append(DeviceAttachment(dev, B[: dev.n_dir]))
    Gamma = rng.standard_normal((n, 3)) * np.sqrt(m_tot) * 0.2
    Gamma[:3] = np.diag([np.sqrt(m_tot), np.sqrt(m_tot), np.sqrt(J)])
    C_out = np.hstack([np.zeros((8, 2 * n)), rng.standard_normal((8, n)) * 1e-3])
    return ReducedSystem(np.eye(n), np.diag(0.04 * w), np.diag(w**2), Gamma, tuple(att),
                         C_out, rng.standard_normal((8, 3)) * 0.1)


def _digest(modal_histories: bool) -> dict[str, tuple[float, float, float] | int]:
    """Run 4 s in two blocks; return the weighted sum, the sum of its terms' magnitudes and
    the sum of squares of each output, and the count of law evaluations."""
    ag = np.random.default_rng(7).standard_normal((3, 4001)) * np.array([[3.0], [3.0], [0.1]])
    sim = Simulator(_every_law_building(), 1e-3, modal_histories=modal_histories)
    parts = [sim.step_block(ag[:, :1500]), sim.step_block(ag[:, 1500:])]
    names = ["y", "drift", "force"] + (["q", "qd", "qdd"] if modal_histories else [])
    out: dict[str, tuple[float, float, float] | int] = {}
    for name in names:
        x = np.hstack([getattr(p, name) for p in parts])
        wts = np.random.default_rng(0).standard_normal(x.shape)
        out[name] = (float(np.sum(wts * x)), float(np.sum(np.abs(wts * x))),
                     float(np.sum(x * x)))
    out["evals"] = int(sum(int(p.newton_iterations.sum()) for p in parts))
    return out


@pytest.mark.parametrize("modal_histories", [False, True])
def test_outputs_as_before_the_typed_groups(modal_histories: bool) -> None:
    got = _digest(modal_histories)
    ref = _BEFORE[modal_histories]
    assert got.keys() == ref.keys()
    assert got["evals"] == ref["evals"]
    for name in ref.keys() - {"evals"}:
        ws, sa, ss = ref[name]
        gws, _, gss = got[name]
        assert gss == pytest.approx(ss, rel=1e-12, abs=0), name
        assert gws == pytest.approx(ws, rel=0, abs=1e-12 * sa), name


def test_the_building_reaches_every_law_nonlinear_range() -> None:
    sim = Simulator(_every_law_building(), 1e-3, modal_histories=False)
    ag = np.random.default_rng(7).standard_normal((3, 4001)) * np.array([[3.0], [3.0], [0.1]])
    r = sim.step_block(ag)
    assert len({a.device.kind for a in sim.system.devices}) == len(
        {LAWS[law].kind for law in _LAWS_THEN})
    assert np.abs(r.drift).max() > 0.08  # beyond the gap (10 mm), yield (30 mm), slip
    assert r.newton_iterations[1:].mean() > 1.5  # the Newton correction runs on most samples


if __name__ == "__main__":
    print({mh: _digest(mh) for mh in (False, True)})
