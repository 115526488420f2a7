"""acquisition stage of modal_twin: calibration, detrend, decimation, FRF, reciprocity."""

from __future__ import annotations

from modal_twin.acquisition.calibration import calibrate
from modal_twin.acquisition.decimation import Decimated, decimate, lowpass_zero_phase
from modal_twin.acquisition.detrend import detrend
from modal_twin.acquisition.frf import FRFEstimate, frf
from modal_twin.acquisition.reciprocity import ReciprocityCheck, reciprocity

__all__ = [
    "Decimated",
    "FRFEstimate",
    "ReciprocityCheck",
    "calibrate",
    "decimate",
    "detrend",
    "frf",
    "lowpass_zero_phase",
    "reciprocity",
]
