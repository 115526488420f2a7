"""Simulators handed back for a model simulated again (modal_twin.twin.reuse).

The known answer: a new :class:`Simulator` of the same numbers, run on the same input.
A simulator handed back must give its run bit for bit, whatever ran on it before (device
memories left by a yielding run are reset), and a model that differs in any number gets
its own.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest

from modal_twin.models.devices import IwanJoint, PrandtlJoint, table10_sdp
from modal_twin.models.devices.base import N_STATE, N_STATE_SMALL
from modal_twin.models.reduced import DeviceAttachment, ReducedSystem, SimResult
from modal_twin.twin import reuse
from modal_twin.twin.reuse import KEPT, simulator_for, system_digest
from modal_twin.twin.simulator import Simulator

DT = 2e-3


def _system(*, uy: float = 0.004, iwan: bool = True) -> ReducedSystem:
    """Four modes, a Bouc-Wen damper, a Prandtl joint and (or not) an Iwan joint.

    Built anew on every call (new arrays, new devices) from the same numbers.
    """
    n, n_in = 4, 2
    w = 2 * np.pi * np.array([0.8, 2.5, 6.0, 13.0])
    K, C = np.diag(w**2), np.diag(2 * 0.02 * w)
    G = np.array([[1.0, 0.2], [0.3, 1.0], [0.5, -0.4], [-0.2, 0.6]])
    B2 = np.array([[0.9, 0.1, -0.3, 0.2], [0.1, 0.8, 0.2, -0.4]]) * 1e-2
    B1 = np.array([[0.5, -0.6, 0.4, 0.3]]) * 1e-2
    devs = [DeviceAttachment(table10_sdp("SDP"), B2),
            DeviceAttachment(PrandtlJoint(2e5, 0.0, 1e9, 50.0, 300.0, 4e5, name="J"), B1)]
    if iwan:
        devs.append(DeviceAttachment(IwanJoint(3e5, 5e4, uy, [40.0, 40.0], name="I"), B2))
    C_out = np.hstack([np.eye(n), np.zeros((n, n)), np.eye(n)])
    return ReducedSystem(np.eye(n), C, K, G, tuple(devs), C_out, np.zeros((n, n_in)))


def _input(seed: int, nt: int = 3000) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(nt) * DT
    return 4.0 * np.sin(2 * np.pi * 1.1 * t) * rng.uniform(0.5, 1.5, (2, 1)) + (
        0.5 * rng.standard_normal((2, nt)))


def _same_run(a: SimResult, b: SimResult) -> None:
    for name in ("y", "drift", "force", "newton_iterations"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.fixture(autouse=True)
def _empty() -> None:
    reuse._local.kept = None  # each test starts with nothing kept


def test_a_model_rebuilt_from_the_same_numbers_gets_the_simulator_at_rest() -> None:
    first = simulator_for(_system(), DT)
    first.step_block(_input(1))  # yields: the devices keep a memory
    virgin = np.array([att.device.initial_state()[: first._state.states.shape[1]]
                       for att in first.system.devices])
    assert not np.array_equal(first._state.states, virgin)
    again = _system()  # new objects, the same numbers
    sim = simulator_for(again, DT)
    assert sim is first
    ag = _input(2)
    _same_run(sim.step_block(ag), Simulator(again, DT, modal_histories=False).step_block(ag))


def test_a_model_that_differs_in_any_number_gets_its_own() -> None:
    base = simulator_for(_system(), DT)
    other = _system(uy=0.004 * (1 + 1e-15))  # one ulp-sized change of one law parameter
    assert system_digest(other) != system_digest(_system())
    sim = simulator_for(other, DT)
    assert sim is not base
    assert simulator_for(_system(), 2 * DT) is not base  # another sample interval
    assert simulator_for(_system(), DT, modal_histories=True) is not base
    ag = _input(3)
    _same_run(sim.step_block(ag), Simulator(other, DT, modal_histories=False).step_block(ag))


def test_at_most_kept_simulators_stay() -> None:
    sims = [simulator_for(_system(uy=0.004 + 1e-4 * i), DT) for i in range(KEPT + 1)]
    assert simulator_for(_system(uy=0.004 + 1e-4 * KEPT), DT) is sims[-1]
    assert simulator_for(_system(uy=0.004), DT) is not sims[0]  # the oldest went first


def test_threads_never_share_a_simulator() -> None:
    mine = simulator_for(_system(), DT)
    theirs: list[Simulator] = []
    t = threading.Thread(target=lambda: theirs.append(simulator_for(_system(), DT)))
    t.start()
    t.join()
    assert theirs and theirs[0] is not mine


def test_device_states_are_as_wide_as_the_widest_law_of_the_plant() -> None:
    # the Iwan joint keeps its reversal stack (N_STATE slots); without it 8 slots do
    assert simulator_for(_system(), DT)._state.states.shape == (3, N_STATE)
    assert simulator_for(_system(iwan=False), DT)._state.states.shape == (2, N_STATE_SMALL)
    # the Prandtl joint's virgin state (its elastic flag, slot 6) survives the narrowing
    sim = Simulator(_system(iwan=False), DT)
    assert sim._state.states[1, 6] == 1.0
