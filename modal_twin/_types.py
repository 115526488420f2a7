"""Array type aliases shared by the core modules."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeAlias

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = ["BoolArray", "ComplexArray", "FloatArray", "IntArray", "Matrix"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: A stiffness, mass or damping matrix: scipy sparse or dense (scipy stays out of the
#: import at run time; the alias is for annotations).
Matrix: TypeAlias = "sp.sparray | sp.spmatrix | FloatArray"
