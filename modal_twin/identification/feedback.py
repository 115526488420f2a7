r"""Whether a record's measured inputs are fed back by its outputs (Granger's test).

Input-output identification (N4SID, PolyMAX on H1) identifies the system from the
measured inputs to the outputs. When the "inputs" are motions of the structure's own
foundation (the basement of a building, the column bases and abutments of a bridge)
they move with the structure: the soil-structure interaction feeds the response back
into them, and the system from them to the response is the structure on a *fixed* base,
whose frequencies lie above those of the soil-structure system that the outputs'
spectra (FDD, output-only SSI) show (Stewart & Fenves 1998, "System identification for
evaluating soil-structure interaction effects in buildings from strong motion
recordings", Earthquake Eng. Struct. Dyn. 27; on the Berkeley and Rio Dell records
N4SID sits 1.5-6 % above them).

The test is Granger's (1969, "Investigating causal relations by econometric models and
cross-spectral methods", Econometrica 37; the feedback test of Ljung, System
Identification, 2nd ed., sec. 13.4): each input is predicted one step ahead from the
past of every input (restricted model, :data:`OWN_LAGS` x ``lags`` past samples: a
band-limited input -- a decimated or anti-alias-filtered record -- needs a long past to
be whitened, else the outputs' past, a filtered copy of the input's distant past, would
read as feedback) and from that and ``lags`` past samples of the outputs (full model),
both by least squares; the share of the restricted prediction-error variance the
outputs' past removes,

.. math:: F = 1 - \frac{\hat\sigma^2_{\rm full}}{\hat\sigma^2_{\rm restr}},
          \qquad \hat\sigma^2 = \frac{\lVert e \rVert^2}{N - k},

with each variance divided by its residual degrees of freedom (:math:`k` regressors),
so an exogenous input gives :math:`F \approx 0` whatever the number of lags. The mean of
:math:`F` over the inputs is returned.

Limits: the input must be broadband at the test's rate. A band-limited input (a rig's
drive, random with a flat spectrum in 0.5-5 Hz at 100 Hz, the structure's modes above
it) is partly predictable from a long past only, and the outputs' past then seems to
help: F up to 0.25 for an exogenous drive.
:func:`~modal_twin.identification.record.identify_record` therefore runs the test on
transient records only (earthquake ground motions).
"""

from __future__ import annotations

import numpy as np

from modal_twin._types import FloatArray

__all__ = ["FEEDBACK", "FEEDBACK_LAGS", "OWN_LAGS", "input_feedback"]

FEEDBACK = 0.05
"""Mean share of the inputs' one-step prediction error that the outputs' past explains
from which the inputs are read as fed back (part of the vibrating system). An
exogenous input gives 0 to within the estimate's scatter (0.000-0.006 for a white or a
band-passed base acceleration under a simulated frame, also low-passed at 0.2-0.4 x the
rate, causally or not, as by an instrument; stationary or under an earthquake-like
envelope); a foundation on a soil spring, its only excitation the ground, 0.10 (either);
the real records' ground and basement channels 0.17-0.24
(Rio Dell 0.17, Berkeley 0.20, Hayward 0.21-0.24), each at a rate of at least five
times its band's upper edge (:func:`~modal_twin.identification.record.identify_record`)."""
FEEDBACK_LAGS = 8
"""Past samples of each output in the full model."""
OWN_LAGS = 4
"""Past samples of each input in both models, as a multiple of ``lags``."""


def _lagged(x: FloatArray, lags: int) -> FloatArray:
    """Rows t = lags..n-1 of ``[x(t-1), ..., x(t-lags)]`` (channels inner)."""
    n = x.shape[1]
    return np.vstack([x[:, lags - k - 1 : n - k - 1] for k in range(lags)]).T


def _residual_variance(X: FloatArray, T: FloatArray) -> FloatArray:
    """Least-squares residual variance of every column of T on X (per degree of freedom)."""
    coef, *_ = np.linalg.lstsq(X, T, rcond=None)
    e = T - X @ coef
    out: FloatArray = np.einsum("ij,ij->j", e, e) / max(T.shape[0] - X.shape[1], 1)
    return out


def input_feedback(u: FloatArray, y: FloatArray, lags: int = FEEDBACK_LAGS) -> float:
    """Mean share F of the inputs' prediction error explained by the outputs' past.

    Parameters
    ----------
    u : (n_in, n) array
        Measured inputs.
    y : (n_out, n) array
        Outputs at the same rate.
    lags : int
        Past samples of every output in the full model (of every input:
        :data:`OWN_LAGS` times as many).

    Returns
    -------
    float
        F of the module docstring, averaged over the inputs, clipped to [0, 1]; 0 when
        the record is too short for the full model (no test).
    """
    n = u.shape[1]
    own = OWN_LAGS * lags
    n_reg = own * u.shape[0] + lags * y.shape[0] + 1
    if u.shape[0] == 0 or n - own <= 2 * n_reg:
        return 0.0

    def unit(x: FloatArray) -> FloatArray:
        x0 = x - x.mean(axis=1, keepdims=True)
        out: FloatArray = x0 / np.maximum(x0.std(axis=1, keepdims=True), 1e-300)
        return out

    uu, yy = unit(u), unit(y)
    T = uu[:, own:].T
    Xr = np.column_stack([_lagged(uu, own), np.ones(n - own)])
    Xf = np.column_stack([Xr, _lagged(yy, lags)[own - lags :]])
    share = 1.0 - _residual_variance(Xf, T) / np.maximum(_residual_variance(Xr, T), 1e-300)
    return float(np.clip(np.mean(share), 0.0, 1.0))
