"""identification stage of modal_twin: N4SID, SSI-cov, PolyMAX + LSFD, stabilization, MAC."""

from __future__ import annotations

from modal_twin.identification.lsfd import LSFDResult, lsfd, lsfd_modes
from modal_twin.identification.metrics import automac, complexity, mac, mpc
from modal_twin.identification.modal_model import (
    ModalModel,
    PoleSet,
    PoleSweep,
    StabilizationDiagram,
)
from modal_twin.identification.n4sid import n4sid
from modal_twin.identification.polymax import polymax
from modal_twin.identification.ssi_cov import ssi_cov
from modal_twin.identification.stabilization import select_modes, stabilization_diagram

__all__ = [
    "LSFDResult",
    "ModalModel",
    "PoleSet",
    "PoleSweep",
    "StabilizationDiagram",
    "automac",
    "complexity",
    "lsfd",
    "lsfd_modes",
    "mac",
    "mpc",
    "n4sid",
    "polymax",
    "select_modes",
    "ssi_cov",
    "stabilization_diagram",
]
