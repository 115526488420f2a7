"""Simulators of models simulated again: one per model content and sample interval.

Building a :class:`~modal_twin.twin.simulator.Simulator` (eigen-decomposition of the state
matrix, first-order-hold weights per mode, the loop's matrices) costs about as much as
simulating a 10 s record at 500 Hz. The offline work simulates one model on several
records in a row (a fit's training and low-level records, a judge's every record, the
criterion of a set of effects found): :func:`simulator_for` builds the simulator of a
model once and hands it back, reset to rest, while the same content comes again. The
content is the model's digest (:func:`system_digest`), not the object, so a model rebuilt
from the same numbers is found too. A simulator handed back is bitwise the one a new
construction gives (the construction depends on nothing else; test/twin/test_reuse.py).

For a whole run at a time (:func:`modal_twin.diagnosis.fitting.simulate_record`): a
streaming twin keeps its own simulator.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

import numpy as np

from modal_twin.models.reduced import ReducedSystem
from modal_twin.twin.simulator import Simulator

__all__ = ["KEPT", "simulator_for", "system_digest"]

KEPT = 4  # simulators kept per thread (the least recently used goes first)

_local = threading.local()


def _update(h: hashlib.blake2b, a: object) -> None:
    """Feed an array (its type, shape and bytes) or None to the digest ``h``."""
    if a is None:
        h.update(b"none;")
        return
    arr = np.ascontiguousarray(a)
    h.update(f"{arr.dtype.str}{arr.shape};".encode())
    h.update(arr.tobytes())


def system_digest(system: ReducedSystem) -> bytes:
    """Return a digest of everything a :class:`Simulator` is built from.

    The linear part (M, C, K, Gamma, C_out, D_out) and per device its law (class, kind
    code, directions, name, state slots, sample-interval slot, parameters), its drift
    matrices (B, E, Ed) and what the simulator asks of it (virgin state, reference
    stiffness and damping).
    """
    h = hashlib.blake2b(digest_size=20)
    for m in (system.M, system.C, system.K, system.Gamma, system.C_out, system.D_out):
        _update(h, m)
    for att in system.devices:
        dev = att.device
        h.update(repr((type(dev).__module__, type(dev).__qualname__, dev.kind, dev.n_dir,
                       dev.name, dev.n_state, dev.time_step_index)).encode())
        arrays: tuple[object, ...] = (dev.params, att.B, att.E, att.Ed, dev.initial_state(),
                                      dev.reference_stiffness(), dev.reference_damping())
        for a in arrays:
            _update(h, a)
    return h.digest()


def simulator_for(system: ReducedSystem, dt: float, *, rtol: float = 1e-6,
                  max_iter: int = 50, modal_histories: bool = False) -> Simulator:
    """Return a simulator of ``system`` at rest: the one built before for the same content.

    Parameters are those of :class:`Simulator`. At most :data:`KEPT` simulators are kept
    per thread (the caches of threads are apart: a simulator is never run by two at once).
    A construction that raises is not kept (it raises again next time).
    """
    kept: OrderedDict[tuple[object, ...], Simulator] | None = getattr(_local, "kept", None)
    if kept is None:
        kept = _local.kept = OrderedDict()
    key = (system_digest(system), float(dt), float(rtol), int(max_iter), bool(modal_histories))
    sim = kept.get(key)
    if sim is None:
        sim = Simulator(system, dt, rtol=rtol, max_iter=max_iter,
                        modal_histories=modal_histories)
        kept[key] = sim
        while len(kept) > KEPT:
            kept.popitem(last=False)
    else:
        kept.move_to_end(key)
        sim.reset()
    return sim
