"""What a model parameter is and where it acts.

:class:`ParameterInfo` (shared by the building and the vehicle factories, read by the diagnosis to
name a candidate's family and place).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["Kind", "ParameterInfo"]

Kind = Literal["stiffness", "mass", "damping"]


@dataclass(frozen=True, slots=True)
class ParameterInfo:
    """What a parameter is and where it acts.

    Attributes
    ----------
    name : str
    kind : {"stiffness", "mass", "damping"}
        The physical family it changes (an added mass's position is ``"mass"``).
    place : str
        Where, in words: ``"column line 1A"``, ``"storey 1"``, ``"floor R"``, ``"device ESB1 x"``.
    nominal, lower, upper : float
        Nominal value and plausible bounds, in ``unit``.
    unit : str
        ``"Pa"``, ``"N/m"``, ``"kg"``, ``"m"``, ``"1"`` (a factor), ``"1/s"``, ``"s"`` ...
    family : str
        ``modulus``, ``device``, ``mass``, ``group``, ``link``, ``added_mass``,
        ``added_mass_x``, ``added_mass_y``, ``added_mass_r``, ``modal_damping``,
        ``rayleigh``, ``other``.
    """

    name: str
    kind: Kind
    place: str
    nominal: float
    lower: float
    upper: float
    unit: str
    family: str
