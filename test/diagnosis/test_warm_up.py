"""The diagnosis node compiles its kernels before it says ready (its first ~/run waits for none).

Known answer, in a fresh interpreter (nothing compiled or loaded yet): the numba
dispatchers of the simulator and of the device laws hold no signature after the imports;
:func:`~modal_twin.diagnosis.fitting.warm_up_kernels` of the nominal building gives the
simulator's kernel, the law at rest and the law driver one each; then what a first
diagnosis runs (the nominal model and a model with a Bouc-Wen isolator simulated on a
record, a rate law driven along a drift history as the evidence and the labels drive it,
the evidence's stop operator) adds none: nothing is compiled after the warm-up.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = r"""
import importlib, json, pkgutil
import numpy as np
from numba.core.registry import CPUDispatcher
import modal_twin.models.devices as devices
import modal_twin.twin.kernels
from modal_twin.diagnosis.fitting import simulate_record, warm_up_kernels
from modal_twin.diagnosis.record import Record
from modal_twin.models.building_factory import BuildingFactory
from modal_twin.models.devices.maxwell import MaxwellDamper
from modal_twin.models.effects import EffectSpec

import modal_twin.diagnosis.restoring_force as restoring_force
mods = [modal_twin.twin.kernels, restoring_force] + [
    importlib.import_module(f"{devices.__name__}.{m.name}")
    for m in pkgutil.iter_modules(devices.__path__)]
jitted = {f"{m.__name__}.{k}": v for m in mods for k, v in vars(m).items()
          if isinstance(v, CPUDispatcher)}

def compiled():
    return {k: len(v.signatures) for k, v in sorted(jitted.items())}

factory = BuildingFactory("config/structures/building.yaml")
nominal = factory.plant()
at_import = compiled()
took = warm_up_kernels(nominal)
warm = compiled()
rng = np.random.default_rng(1)
fs, n = 500.0, 200
ag = np.zeros((len(nominal.input_names), n))
ag[0] = 0.5 * rng.standard_normal(n)
rec = Record(fs, nominal.input_names, ag, nominal.channel_names[:4],
             np.zeros((4, n)), "first request")
simulate_record(nominal, rec)
simulate_record(factory.plant([EffectSpec("RB1", "bouc_wen", {"uy": 0.02, "alpha": 0.3})]),
                rec)
law = MaxwellDamper([1e6], [5e6], [1e4], name="SDP1")  # a rate law: dt given
u = 0.01 * np.sin(np.linspace(0, 20, n))[None]
law.respond(u, np.gradient(u, 1 / fs, axis=1), dt=1 / fs)
restoring_force.stop_operator(u[0], 0.002)
print(json.dumps({"at_import": at_import, "warm": warm, "after": compiled(), "took": took}))
"""


def test_warm_up_compiles_what_a_first_diagnosis_runs() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", SCRIPT], cwd=ROOT, env=env, check=True,
                         capture_output=True, text=True).stdout
    doc = json.loads(out.strip().splitlines()[-1])
    kernels = "modal_twin.twin.kernels.run_block"
    laws = [f"modal_twin.models.devices._dispatch.{k}" for k in ("evaluate_law", "drive_law")]
    stop = "modal_twin.diagnosis.restoring_force._stop"
    assert not any(doc["at_import"].values())  # a fresh interpreter: nothing yet
    assert [doc["warm"][k] for k in (kernels, *laws, stop)] == [1, 1, 1, 1]
    assert doc["after"] == doc["warm"]  # the first request compiles nothing more
