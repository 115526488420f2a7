"""Truth of the base-isolated building: the library's LINEAR structure (FE assembly and
modal reduction of ``config/structures/building.yaml``, possibly edited: a weaker column
line or storey, an eccentric added mass), with the truth's own device laws and its own
time integration (:mod:`.integrate`, RK4 sub-stepped).

Equation in the modal coordinates of the (edited) linear model (Eq. (12) of [004])::

    q'' + (C_r - sum_d B_d' c_d B_d) q' + (K_r - sum_d B_d' k_d B_d) q
        = -Gamma a_g - sum_d B_d' f_d(B_d q, B_d q')

for the devices ``d`` whose nominal spring-dashpot a truth law replaces. Channels: the
sensors' absolute accelerations ``S Phi q'' + S P a_g``, every device's drift
(``<dev>_dx``, ``_dy``) and force (``<dev>_fx``, ``_fy``), in the library plant's order.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from modal_twin.models.building import build_building, modal_reduction
from modal_twin.models.structure_yaml import parse_structure

from .building_own import device_channels
from .integrate import Attached, run_rk4
from .laws import Law

FloatArray = np.ndarray
ROOT = Path(__file__).resolve().parents[3]
BUILDING_YAML = ROOT / "config" / "structures" / "building.yaml"
INPUTS = ("ax", "ay", "az", "arx", "ary", "arz")

Edit = Callable[[dict], dict]


def weaken_columns(which: Callable[[str, str], bool], factor: float) -> Edit:
    """YAML edit: the columns (frames joining two floors at one grid point) for which
    ``which(n1, n2)`` holds get their material's modulus times ``factor``."""

    def edit(doc: dict) -> dict:
        doc = copy.deepcopy(doc)
        for fr in doc["frames"]:
            n1, n2 = fr["n1"], fr["n2"]
            column = n1.split("_", 1)[1] == n2.split("_", 1)[1] and "via" not in fr
            if column and which(n1, n2):
                name = f"{fr['material']}_x{factor:g}"
                if name not in doc["materials"]:
                    base = doc["materials"][fr["material"]]
                    doc["materials"][name] = {"E": base["E"] * factor, "nu": base["nu"]}
                fr["material"] = name
        return doc

    return edit


def add_masses(items: list[tuple[str, float]]) -> Edit:
    """YAML edit: point masses (node, kg) added (an item spread over several nodes carries
    translation, rotary inertia and eccentricity together)."""

    def edit(doc: dict) -> dict:
        doc = copy.deepcopy(doc)
        for node, m in items:
            doc["masses"].append({"m": float(m), "nodes": [node]})
        return doc

    return edit


@dataclass
class BuildingTruth:
    """The building with truth laws at some devices and optional YAML edits.

    Parameters
    ----------
    laws : mapping device -> Law
        Devices whose nominal linear spring-dashpot the law replaces.
    edits : list of YAML edits
    """

    laws: Mapping[str, Law] = field(default_factory=dict)
    edits: list[Edit] = field(default_factory=list)
    structure_file: Path = BUILDING_YAML

    def __post_init__(self) -> None:
        doc = yaml.safe_load(self.structure_file.read_text())
        for e in self.edits:
            doc = e(doc)
        self.bld = build_building(spec=parse_structure(doc, source="truth"))
        self.mb = modal_reduction(self.bld)
        self.weights = self.bld.gravity_loads()

    def weight(self, device: str) -> float:
        """Static vertical load of a device, N."""
        return float(self.weights[self.bld.device_names.index(device)])

    def channel_names(self) -> tuple[str, ...]:
        """Channels in the library plant's order."""
        devs = self.mb.device_names
        return (tuple(self.mb.channel_names) + tuple(f"{d}_d{a}" for d in devs for a in "xy")
                + tuple(f"{d}_f{a}" for d in devs for a in "xy"))

    def simulate(self, ag: FloatArray, fs_hz: float, n_sub: int = 2) -> FloatArray:
        """Clean channels (n_ch, nt) for table accelerations ``ag`` (6, nt)."""
        mb = self.mb
        r = mb.n_modes
        K, C = mb.K.copy(), mb.C.copy()
        att = []
        for name, law in self.laws.items():
            d = mb.device_names.index(name)
            B = mb.B[d]
            K -= B.T @ np.diag(mb.k_dev[d]) @ B  # the law replaces the nominal spring
            C -= B.T @ np.diag(mb.c_dev[d]) @ B
            att.append(Attached(name, law, B))
        res = run_rk4(np.eye(r), C, K, mb.Gamma, att, ag, fs_hz, n_sub)
        acc = mb.C_acc[:, 2 * r:] @ res.xdd + mb.D_acc @ ag
        return np.vstack([acc, device_channels(mb.B, mb.k_dev, mb.c_dev, mb.device_names,
                                               self.laws, res)])
