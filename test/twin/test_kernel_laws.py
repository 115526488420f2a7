"""Every device law of the registry through the twin kernel, and a kernel without a branch.

The kernel (:func:`modal_twin.twin.kernels.run_block`) is driven along a prescribed drift
history: its linear part is replaced by one whose drift of a sample is its input (drift
prediction Ua1 = identity, every other map zero), so the device sees exactly the history
given, while the device arrays are the ones :class:`Simulator` packs for the twin. Its
forces and final state must then be those of the law's own implementation,
:meth:`Device.respond` (models/devices), on the same history.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from modal_twin.errors import ModelError
from modal_twin.models.devices import LinearDevice
from modal_twin.models.devices.base import Device
from modal_twin.models.devices.registry import (
    KINDS,
    LAWS,
    Site,
    build_device,
    build_effect_device,
)
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem
from modal_twin.twin import simulator as simulator_module
from modal_twin.twin.kernels import (
    STATUS_OK,
    STATUS_UNKNOWN_KIND,
    BlockRows,
    LoopMatrices,
    run_block,
)
from modal_twin.twin.simulator import Simulator

_SITE = Site("D", np.array([1.0e6, 1.4e6]), np.array([1.0e3, 2.0e3]), 1.0e6)
# params that make each law's nonlinearity show within the amplitudes below (yield, gap,
# slip at 4-80 mm); a law not named here is built from its effect defaults, and a law
# with only an absolute form must be named here
_PARAMS: dict[str, tuple[str, dict[str, Any]]] = {
    "cubic": ("effect", {"k3": 1.0e9}),
    "bouc_wen_esb": ("absolute", {"A": 1.0, "beta": 555.0, "gamma": 555.0}),
    "prandtl": ("absolute", {"Fs": 5.0e3, "Kb": 1.0e6, "K3": 1.0e8}),
    "maxwell": ("effect", {"c_factor": 100.0, "tau": 0.05}),  # relaxing at ~3 Hz
}
_AMPLITUDES = (0.004, 0.02, 0.08)  # m: below, near and well beyond each law's knee
_DIRECTIONS = ("x", "y", "xy")


def _device(law: str) -> Device:
    form, params = _PARAMS.get(law, ("effect", {}))
    if form == "absolute" or LAWS[law].build_relative is None:
        if law not in _PARAMS:
            pytest.fail(f"law {law} has no relative form: give its params in _PARAMS")
        return build_device(law, params, _SITE)
    return build_effect_device(law, params, _SITE)


def _history(amp: float, direction: str, nt: int = 3001, dt: float = 1e-3
             ) -> tuple[np.ndarray, np.ndarray]:
    """Drift and velocity (2, nt) from rest (u = v = 0 at sample 0): 1.5 cycles at 1 Hz
    with a linear ramp over the first 0.25 s; an ellipse at twice the rate in y for "xy"."""
    t = np.arange(nt) * dt
    r = np.minimum(t / 0.25, 1.0)
    dr = np.where(t < 0.25, 1.0 / 0.25, 0.0)
    u = np.zeros((2, nt))
    v = np.zeros((2, nt))
    for a, w, s in ((0, 2 * np.pi, 1.0), (1, 4 * np.pi, 0.7)):
        if direction in ("xy", "xy"[a]):
            scale = s * amp if direction == "xy" else amp
            u[a] = scale * r * np.sin(w * t)
            v[a] = scale * (dr * np.sin(w * t) + r * w * np.cos(w * t))
    return u, v


def _one_device_simulator(dev: Device) -> Simulator:
    n = 2
    w = 2 * np.pi * np.array([1.0, 1.3])
    B = np.eye(2)[: dev.n_dir]
    s = ReducedSystem(np.eye(n), np.diag(0.04 * w), np.diag(w**2), np.eye(n),
                      (DeviceAttachment(dev, B),), np.zeros((1, 3 * n)), np.zeros((1, n)))
    return Simulator(s, 1e-3)


def _kernel_on_history(sim: Simulator, u: np.ndarray, v: np.ndarray
                       ) -> tuple[int, int, np.ndarray, np.ndarray, np.ndarray]:
    """Run the kernel with the simulator's devices along u, v; return status, index, the
    drifts and device forces (2, nt) and the committed device state."""
    nf = 2
    ns = sim._ns
    n_in = 2 * nf
    m = 4 * ns + 4 * nf
    PinT = np.zeros((n_in, m))
    PinT[:, 4 * ns : 4 * ns + 2 * nf] = np.eye(n_in)  # Ua1 a_k: the drift is the input
    lin = LoopMatrices(PinT=PinT, coef=sim._coef, GfT=np.zeros((nf, 2 * ns)),
                       Q=np.zeros((2 * nf, 2 * ns)), HfT=np.zeros((nf, 2 * nf)),
                       HT=np.zeros((nf, 2 * nf)))
    ag = np.ascontiguousarray(np.vstack([u, v]))  # inputs = [u; v] of the one device
    nt = ag.shape[1]
    rows = BlockRows(Ain=np.empty((64, m)), Z=np.empty((nt, 2 * ns + n_in + nf)),
                     U=np.empty((nt, nf)), out_it=np.empty(nt, dtype=np.int64))
    sim.reset()
    status, idx = run_block(ag, 0, nt, lin, sim._dev, sim._state, rows, 1e-12, 50)
    return (status, idx, rows.U.T.copy(), rows.Z[:, 2 * ns + n_in :].T.copy(),
            sim._state.states[0].copy())


def _cases() -> list[tuple[str, float, str]]:
    out = []
    for law in LAWS:
        dirs = _DIRECTIONS if _device(law).n_dir == 2 else ("x",)
        out += [(law, a, d) for a in _AMPLITUDES for d in dirs]
    return out


def test_every_kind_code_is_a_registry_law() -> None:
    assert sorted(KINDS) == sorted({e.kind for e in LAWS.values()})
    assert sorted(n for names in KINDS.values() for n in names) == sorted(LAWS)


@pytest.mark.parametrize(("law", "amp", "direction"), _cases())
def test_kernel_runs_the_law_as_its_own_implementation(law: str, amp: float,
                                                       direction: str) -> None:
    dev = _device(law)
    sim = _one_device_simulator(dev)
    u, v = _history(amp, direction)
    if dev.n_dir == 1:
        u[1] = v[1] = 0.0
    status, idx, u_twin, f_twin, s_twin = _kernel_on_history(sim, u, v)
    assert (status, idx) == (STATUS_OK, u.shape[1])
    np.testing.assert_array_equal(u_twin[:, 1:], u[:, 1:])  # the device saw the history
    ref = dev.respond(u[: dev.n_dir], v[: dev.n_dir], dt=sim.dt)  # a rate law needs dt
    f_ref = ref.f
    # force scale: the largest force, or k amp where a law gives none (a gap's dead band)
    scale = np.abs(f_ref).max() or float(np.mean(_SITE.k)) * amp
    # sample 0 is the twin's rest state (no force); the law gives 0 there too
    np.testing.assert_allclose(f_ref[:, 0], 0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(f_twin[: dev.n_dir, 1:], f_ref[:, 1:], rtol=0,
                               atol=1e-12 * scale)
    # the twin carries the law's own state slots (Device.n_state); the law run alone on all
    # N_STATE writes nothing beyond them
    assert s_twin.shape == (dev.n_state,)
    np.testing.assert_allclose(s_twin, ref.state[: dev.n_state], rtol=1e-12, atol=1e-12 * amp)
    assert not ref.state[dev.n_state :].any()
    if law != "linear" and amp == max(_AMPLITUDES):  # the nonlinear part was exercised
        k0 = dev.reference_stiffness()[: dev.n_dir, : dev.n_dir]
        c0 = dev.reference_damping()[: dev.n_dir, : dev.n_dir]
        f_lin = k0 @ u[: dev.n_dir] + c0 @ v[: dev.n_dir]
        assert np.abs(f_ref - f_lin).max() > 0.05 * scale


def test_kernel_refuses_a_kind_without_branch_and_runs_nothing() -> None:
    sim = _one_device_simulator(LinearDevice([1.0e6, 1.0e6], [1.0e3, 1.0e3]))
    sim._dev.kinds[0] = 99  # a code the kernel has no branch for
    u, v = _history(0.02, "xy")
    status, idx, _u, f_twin, s_twin = _kernel_on_history(sim, u, v)
    assert (status, idx) == (STATUS_UNKNOWN_KIND, 0)  # device 0 named, at the first sample
    assert not f_twin[:, 0].any()  # only the rest sample was written
    dev = sim.system.devices[0].device
    np.testing.assert_array_equal(s_twin, dev.initial_state()[: dev.n_state])


class _NewLaw(LinearDevice):
    """A law with a kind code the kernel has no branch for (its own evaluation works)."""

    kind = 99

    def reference_stiffness(self) -> np.ndarray:
        return np.diag(self.params[:2])


def test_a_law_missing_from_the_kernel_is_an_error_naming_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # a law added to the registry (kind 99) but not to the kernel: refused, never run as
    # another law
    dev = _NewLaw([1.0e6, 1.0e6], [1.0e3, 1.0e3], name="ISO3")
    monkeypatch.setattr(simulator_module, "KINDS", {**KINDS, 99: ("new_law",)})
    sim = _one_device_simulator(dev)
    with pytest.raises(ModelError, match=r"devices\[0\] \(ISO3\): law new_law \(kind code 99\) "
                                         r"has no branch in the twin kernel"):
        sim.step_block(np.ones((2, 10)))


def test_a_kind_outside_the_registry_is_refused() -> None:
    dev = LinearDevice([1.0], [0.0])
    dev.kind = 42
    with pytest.raises(ModelError, match=r"devices\[0\] \(linear, LinearDevice\): expected a "
                                         r"law kind of the device registry .* got 42"):
        _one_device_simulator(dev)
