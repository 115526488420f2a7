"""Modal view of the model error: the modes the model misses.

Identify the measured modes (N4SID with the table inputs) and pair them with the
model's (MAC and frequency, Eqs. (4)-(5) of [004]) -- which modes the model misses in
frequency, damping or shape.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from modal_twin._types import FloatArray
from modal_twin.acquisition.decimation import decimate
from modal_twin.diagnosis.record import Record
from modal_twin.errors import ModalTwinError, SignalError
from modal_twin.identification import n4sid, select_modes, stabilization_diagram
from modal_twin.models.plant import Plant
from modal_twin.updating.matching import match_modes

__all__ = ["ModalView", "modal_view", "model_modes"]


@dataclass(frozen=True, slots=True)
class ModalView:
    """Identified modes paired with the model's (NaN where unmatched)."""

    f_id_hz: FloatArray
    zeta_id: FloatArray
    f_model_hz: FloatArray
    zeta_model: FloatArray
    mac: FloatArray

    def format(self) -> str:
        """Table: identified vs model frequency, damping and MAC."""
        out = [f"{'f id Hz':>9}{'f model':>9}{'df %':>8}{'zeta id %':>10}{'zeta mod %':>11}"
               f"{'MAC':>7}"]
        for i in range(self.f_id_hz.size):
            df = 100 * (self.f_model_hz[i] / self.f_id_hz[i] - 1)
            out.append(f"{self.f_id_hz[i]:9.3f}{self.f_model_hz[i]:9.3f}{df:8.2f}"
                       f"{100 * self.zeta_id[i]:10.2f}{100 * self.zeta_model[i]:11.2f}"
                       f"{self.mac[i]:7.3f}")
        return "\n".join(out)


def model_modes(plant: Plant, rows: list[int]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Return frequencies (Hz), damping ratios and complex shapes of the plant's linear part.

    Shapes are at output ``rows``; devices at their reference stiffness are not included.
    """
    s = plant.system
    n = s.n
    Minv = np.linalg.inv(s.M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ s.K, -Minv @ s.C]])
    lam, V = sla.eig(A)
    keep = lam.imag > 1e-9
    lam, V = lam[keep], V[:, keep]
    order = np.argsort(np.abs(lam))
    lam, V = lam[order], V[:, order]
    q = V[:n]
    shapes = s.C_out[rows] @ np.vstack([q, lam * q, lam**2 * q])
    w = np.abs(lam)
    return w / (2 * np.pi), -lam.real / w, shapes


def modal_view(plant: Plant, rec: Record, *, fs_target_hz: float | None = None,
               f_max_hz: float | None = None) -> ModalView:
    """Identify ``rec``'s modes (N4SID, table inputs) and pair them with the plant's.

    The band defaults to the model's first twelve modes (10 % beyond the twelfth, at most
    0.4 of the sampling rate) and the decimated rate to 2.5 times its top: derived from
    the model and the record, not a fixed Hz.

    Raises
    ------
    SignalError
        No acceleration channel or too short a record for the identification.
    """
    acc = [c.name for c in plant.channels
           if c.quantity == "acceleration" and c.name in rec.channel_names]
    if not acc:
        msg = "modal view: the record has no acceleration channel of the model"
        raise SignalError(msg)
    if f_max_hz is None:
        f_all = model_modes(plant, [plant.channel_names.index(acc[0])])[0]
        f_max_hz = float(min(1.1 * f_all[min(11, f_all.size - 1)], 0.4 * rec.fs_hz))
    if fs_target_hz is None:
        fs_target_hz = 2.5 * f_max_hz
    factor = max(1, round(rec.fs_hz / fs_target_hz))
    sd = np.std(rec.inputs, axis=1)
    active = [i for i, v in enumerate(sd) if v > 1e-2 * sd.max()]  # driven axes, not noise
    u = decimate(rec.inputs[active][:, rec.skip:], rec.fs_hz, factor).x
    fs = rec.fs_hz / factor
    horizontal = [c for c in acc if not c.endswith("_z")]
    ends = [c for c in horizontal if c.startswith((horizontal[0][:2], horizontal[-1][:2]))] \
        if horizontal else []
    for channels in (acc, horizontal, ends):  # a short record: fewer outputs
        y = decimate(rec.channels(channels)[:, rec.skip:], rec.fs_hz, factor).x
        try:
            with warnings.catch_warnings():  # the modal view uses no standard deviations
                warnings.filterwarnings("ignore", message="n_blocks_std", category=RuntimeWarning)
                sw = n4sid(u, y, fs, orders=np.arange(20, 62, 4), f_min_hz=0.5)
            mm = select_modes(stabilization_diagram(sw), f_range_hz=(0.2, f_max_hz))
        except ModalTwinError as err:
            error = err
            continue
        acc = channels
        break
    else:
        msg = f"identification failed ({error})"
        raise SignalError(msg)
    rows = [plant.channel_names.index(c) for c in acc]
    f_m, z_m, sh_m = model_modes(plant, rows)
    band = f_m <= 1.2 * f_max_hz
    p = match_modes(mm.f_hz, mm.shapes, f_m[band], sh_m[:, band], r_f=0.25, r_mac=0.5)
    j = p.fem_index
    pick = np.where(j >= 0, j, 0)
    nan = np.full(j.shape, np.nan)
    return ModalView(mm.f_hz, mm.zeta, np.where(j >= 0, f_m[band][pick], nan),
                     np.where(j >= 0, z_m[band][pick], nan), p.mac)
